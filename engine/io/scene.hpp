// A scene: the TOML file that describes one run, checked against the schema in scene_schema.cpp.
// Every accessor validates type and range and names the key, the value and what is allowed.
#pragma once
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io/toml.hpp"

#include "io/scene_units.hpp"

namespace grains {

struct SceneError : std::runtime_error { using std::runtime_error::runtime_error; };

enum class ValueKind { real, integer, boolean, text, real_array, real_matrix };

// One documented key of the scene format. `fallback` is the default in TOML syntax ("" = no default:
// the key is optional and its absence has a documented meaning, or it is required where used).
struct SchemaEntry {
  std::string_view path;
  ValueKind kind;
  // Every number's dimension, a pure number's too (Dimension{}); none for text and switches, which are not
  // quantities. A number without one was forgotten (a test says which).
  std::optional<Dimension> dimension;
  std::string_view fallback;
  double min = -1e308, max = 1e308;
  bool min_open = false, max_open = false;
  std::string_view choices;       // for text: "a|b|c"
  std::string_view doc;
  bool file_name = false;         // for text: the value names output files (io/file_name.hpp)
};

const std::vector<SchemaEntry>& scene_schema();
const SchemaEntry* find_schema_entry(std::string_view path);
// A text key's choices in order ("a|b|c": a, b, c); none for a key without.
std::vector<std::string_view> choice_list(const SchemaEntry& e);
// The SI unit of a schema key in a scene of this dimension (2D densities per area): "" for a pure number, text or a
// switch. The FMUs declare it, and the engine's variables named after a key.
std::string scene_key_unit(std::string_view path, int scene_dimension);
std::string schema_reference_markdown();   // the scene reference page, generated from the schema

struct UnreadKeyRule;

// The most a scene file may hold. A scene is TOML that a person writes: the shipped ones are a few kB, and 16 MiB
// holds the listed positions of some 250,000 particles at full precision (larger sets belong in particles.file,
// which has no such limit). Past it, and from a device (/dev/zero has no end), the whole text was read into
// memory until none was left, and the run said only "out of memory".
inline constexpr std::uintmax_t scene_file_limit = std::uintmax_t(16) << 20;

class Scene {
 public:
  // Parse a file (or text) and apply "key.path=value" overrides. Throws SceneError. `origin` names the
  // scene in messages (default: the file's path). The file is a regular file or a pipe (`<(...)`) of at most
  // scene_file_limit bytes: a folder, a device or a socket is refused, naming what it is.
  static Scene from_file(const std::filesystem::path& file, const std::vector<std::string>& overrides = {},
                         const std::string& origin = "");
  // `directory`: where relative file paths in the text (particles.file) lie; default the working directory.
  static Scene from_string(std::string_view text, std::string origin, const std::vector<std::string>& overrides = {},
                           const std::filesystem::path& directory = {});

  // Check every present key: known, right type, in range, and read by the scene as its other keys set it
  // up (unread_keys()). Throws SceneError listing all problems.
  void validate() const;
  // A scene whose every key was written out with its value (resolved_toml(), as a checkpoint stores it):
  // keys it does not read are defaults there, not settings a user gave, and are not refused.
  void accept_unread_keys() { refuse_unread_ = false; }

  bool has(std::string_view path) const;
  double real(std::string_view path) const;
  long integer(std::string_view path) const;
  bool boolean(std::string_view path) const;
  std::string text(std::string_view path) const;
  std::vector<double> reals(std::string_view path) const;
  std::vector<std::vector<double>> matrix(std::string_view path) const;

  // Set or replace a value (used by --set and by hosts); the key must be in the schema.
  void set_value(std::string_view path, std::string_view toml_value);

  // Every schema key with its effective value (defaults filled in), as TOML text; a superseded key is left out.
  std::string resolved_toml() const;
  // Keys given together with a key that takes their place (box.lengths over particles.solid_fraction, time.dt
  // over time.steps_per_contact, ...): not refused, since an override cannot remove the scene's own key, but
  // not read either. One note per such key, for a warning.
  std::vector<std::string> superseded_keys() const;
  const std::string& origin() const { return origin_; }
  std::filesystem::path directory() const { return directory_; }   // for relative file paths

  [[noreturn]] void fail(std::string_view path, const std::string& what) const;

 private:
  bool replace_run_length(std::string_view key);   // true: key is a run-length key
  // Throws SceneError listing `problems` (e.g. the --set overrides') and every problem of the scene, if any.
  void report_problems(std::vector<std::string> problems) const;
  void unread_keys(std::vector<std::string>& problems) const;   // appends the keys given but not read
  struct UnmetNeed {
    std::string key, value, needed;   // the key a rule needs, its value here, the value it needs
  };
  std::optional<UnmetNeed> unmet_need(const UnreadKeyRule& rule) const;
  bool read_by_scene(std::string_view path) const;   // no rule leaves the key unread here
  bool superseded(const UnreadKeyRule& rule) const;   // a supersession rule whose key and replacement are both given
  toml::node_view<const toml::node> node(std::string_view path) const;
  const SchemaEntry& entry(std::string_view path) const;
  toml::table table_;
  std::string origin_;
  std::filesystem::path directory_;
  bool refuse_unread_ = true;
};

// A key that the scene reads only when other keys have given values (a module on, a choice made); given
// without them it would be silently ignored, so validate() refuses it. `when`: refused only with this value
// (TOML text, e.g. "true"), empty: with any value. A single need with an empty value is a supersession: the key
// is read only while that other key is not given, and given with it is warned about (superseded_keys()), not refused.
struct UnreadKeyRule {
  std::string path;
  std::vector<std::pair<std::string, std::string>> needs;   // key, value (TOML text) it is read with
  std::string when;
};
const std::vector<UnreadKeyRule>& unread_key_rules();

}  // namespace grains
