// The names scenes and parameters give an option's values (bend_model: springs, compression_model:
// buckling, a camera's noise: kinect), one table per option, read both ways.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <utility>

namespace cloth_sim::core {

/// Each value of Enum with its name; the first is what a value missing from the table is called.
template <typename Enum, std::size_t N>
using EnumNames = std::array<std::pair<Enum, const char*>, N>;

template <typename Enum, std::size_t N>
const char* enumName(const EnumNames<Enum, N>& names, Enum value) {
  for (const auto& [candidate, name] : names) {
    if (candidate == value) return name;
  }
  return names.front().second;
}

/// Sets *value to the value named `text`; false (and *value untouched) for a name not in the table.
template <typename Enum, std::size_t N>
bool parseEnumName(const EnumNames<Enum, N>& names, const std::string& text, Enum* value) {
  for (const auto& [candidate, name] : names) {
    if (text == name) {
      *value = candidate;
      return true;
    }
  }
  return false;
}

}  // namespace cloth_sim::core
