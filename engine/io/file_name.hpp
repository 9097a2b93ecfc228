// Names that become part of an output file's name (scene.name, an FMU instance's name for its
// snapshots) must stay one plain file name inside the output folder: no '/', no "..", not hidden.
#pragma once
#include <string_view>

namespace grains {

inline constexpr std::string_view plain_file_name_rule = "1 to 100 of the characters A-Z a-z 0-9 . _ -, not starting with '.'";

inline bool is_plain_file_name(std::string_view s) {
  if (s.empty() || s.size() > 100 || s.front() == '.') return false;
  for (char c : s)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-'))
      return false;
  return true;
}

}  // namespace grains
