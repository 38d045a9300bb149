// Command-line numbers for cloth_bench and its modes: the whole text must be the number.
#pragma once

#include <charconv>
#include <cmath>
#include <exception>
#include <optional>
#include <string>
#include <system_error>

namespace cloth_sim::bench {

inline std::optional<int> parseInt(const std::string& text) {
  int value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

/// A finite number spanning the whole text (stod: libstdc++ before GCC 11 has no from_chars for double).
inline std::optional<double> parseDouble(const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(value)) return std::nullopt;
    return value;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

}  // namespace cloth_sim::bench
