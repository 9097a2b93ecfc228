// Names that become part of an output file's name (scene.name, an FMU instance's name for its
// snapshots) must stay one plain file name inside the output folder: no '/', no "..", not hidden.
#pragma once
#include <string>
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

// A plain file name made of any text, for the FMU's snapshots: hosts name instances by the FMU's path (Ecos passes
// "/path/to/model.fmu"), which is no file name. Of a text longer than the rule allows its last characters are kept
// (where paths differ); the others outside the rule, and a leading '.', become '_'.
inline std::string plain_file_name_from(std::string_view s) {
  if (s.size() > 100) s.remove_prefix(s.size() - 100);
  std::string name(s.empty() ? "_" : s);
  for (char& c : name)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-'))
      c = '_';
  if (name.front() == '.') name.front() = '_';
  return name;
}

}  // namespace grains
