// Text from a user's file or value, fit for a message on a terminal: control bytes (a NUL, an escape sequence) shown
// as \xHH, so that a message neither ends early nor drives the terminal. Other bytes (UTF-8 names) as they are.
#pragma once
#include <string>
#include <string_view>

#include <fmt/format.h>

namespace grains {

inline std::string printable(std::string_view text) {
  std::string out;
  for (const char c : text) {
    const auto b = static_cast<unsigned char>(c);
    if (b < 0x20 || b == 0x7f) out += fmt::format("\\x{:02x}", b);
    else out += c;
  }
  return out;
}

}  // namespace grains
