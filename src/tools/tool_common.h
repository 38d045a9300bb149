// What every command-line tool of src/tools shares, with no Eigen, yaml-cpp or ROS behind it (the ROS tools
// include it too): exit codes, strict command-line numbers and JSON strings.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdio>
#include <exception>
#include <optional>
#include <string>
#include <system_error>

namespace cloth_sim::bench {

constexpr int kExitOk = 0;
constexpr int kExitRunFailed = 1;  ///< the run itself failed (a bug, out of memory, an output not written)
constexpr int kExitUsage = 2;      ///< bad flag, unknown key, invalid value

// ---- command-line numbers: the whole text must be the number -------------------------------------------------------

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

// ---- JSON ----------------------------------------------------------------------------------------------------------

/// `text` as a JSON string, quotes included: a name from the user or a scene file may hold quotes,
/// backslashes or control characters, and must not break the line a script parses.
inline std::string jsonQuoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", static_cast<unsigned>(c));
          out += escaped;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

}  // namespace cloth_sim::bench
