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

/// Bytes of the well-formed UTF-8 sequence starting at text[i], or 0 where none starts there (a stray
/// continuation byte, a cut sequence, an overlong form, a surrogate, beyond U+10FFFF: RFC 3629's table).
inline std::size_t utf8SequenceLength(const std::string& text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  if (lead < 0x80) return 1;
  std::size_t length = 0;
  unsigned char low = 0x80;  // the second byte's range, narrower after E0, ED, F0 and F4
  unsigned char high = 0xBF;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) low = 0xA0;
    if (lead == 0xED) high = 0x9F;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) low = 0x90;
    if (lead == 0xF4) high = 0x8F;
  } else {
    return 0;
  }
  if (i + length > text.size() || byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (std::size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  }
  return length;
}

/// `text` as a JSON string, quotes included: a name from the user or a scene file may hold quotes,
/// backslashes, control characters or bytes that are not UTF-8 (each of those becomes U+FFFD), and must
/// not break the line a script parses (JSON text is UTF-8: Python's json refused the line).
inline std::string jsonQuoted(const std::string& text) {
  std::string out = "\"";
  for (std::size_t i = 0; i < text.size();) {
    const char c = text[i];
    const std::size_t length = utf8SequenceLength(text, i);
    if (length == 0) {
      out += "\\ufffd";
      ++i;
      continue;
    }
    if (length > 1) {
      out.append(text, i, length);
      i += length;
      continue;
    }
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
    ++i;
  }
  return out + "\"";
}

}  // namespace cloth_sim::bench
