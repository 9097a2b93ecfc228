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

// printable() of at most the first `limit` bytes, cut before a whole UTF-8 character, with the length when cut:
// a 20 MB word in a particle file was echoed whole in its error message.
inline std::string printable_excerpt(std::string_view text, std::size_t limit = 60) {
  if (text.size() <= limit) return printable(text);
  std::size_t cut = limit;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xc0) == 0x80) --cut;   // not inside a character
  return fmt::format("{}... ({} bytes)", printable(text.substr(0, cut)), text.size());
}

}  // namespace grains
