#include "io/scene.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "io/file_kind.hpp"
#include "io/file_name.hpp"
#include "io/printable.hpp"

namespace grains {

std::string describe_allowed(const SchemaEntry& e);   // scene_schema.cpp

namespace {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string suggestion(std::string_view path) {
  std::string_view best;
  std::size_t best_d = 4;
  for (const auto& e : scene_schema()) {
    auto d = edit_distance(path, e.path);
    if (d < best_d) best_d = d, best = e.path;
  }
  return best.empty() ? "" : fmt::format(" (did you mean '{}'?)", best);
}

// The sections of the schema, in order, and the keys of one section.
std::vector<std::string> section_names() {
  std::vector<std::string> out;
  for (const auto& e : scene_schema()) {
    std::string s(e.path.substr(0, e.path.find('.')));
    if (std::find(out.begin(), out.end(), s) == out.end()) out.push_back(s);
  }
  return out;
}
std::string section_keys(std::string_view section) {
  std::string out;
  for (const auto& e : scene_schema())
    if (e.path.substr(0, e.path.find('.')) == section) out += (out.empty() ? "" : ", ") + std::string(e.path.substr(section.size() + 1));
  return out;
}
// What is allowed in place of an unknown key or section: the nearest name, else the full list.
std::string allowed_keys(std::string_view path) {
  std::string hint = suggestion(path);
  if (!hint.empty()) return hint;
  auto dot = path.find('.');
  std::string section(path.substr(0, dot == std::string_view::npos ? 0 : dot));
  std::string keys = section.empty() ? "" : section_keys(section);
  if (!keys.empty()) return fmt::format("; the keys of [{}] are: {}", section, keys);
  return fmt::format("; the sections are: {}", fmt::join(section_names(), ", "));
}
std::string allowed_sections(std::string_view path) {
  std::string best;
  std::size_t best_d = 3;
  for (const auto& s : section_names())
    if (auto d = edit_distance(path, s); d < best_d) best_d = d, best = s;
  std::string list = fmt::format("the sections are: {}", fmt::join(section_names(), ", "));
  return best.empty() ? "; " + list : fmt::format(" (did you mean [{}]?); {}", best, list);
}

bool is_section(std::string_view prefix) {
  for (const auto& e : scene_schema())
    if (e.path.size() > prefix.size() && e.path.substr(0, prefix.size()) == prefix && e.path[prefix.size()] == '.') return true;
  return false;
}

std::string render(const toml::node& n) {
  std::ostringstream s;
  n.visit([&](auto&& v) {
    if constexpr (toml::is_string<decltype(v)>) s << '"' << v.get() << '"';
    else if constexpr (toml::is_table<decltype(v)>) s << "{table}";
    else s << v;
  });
  return s.str();
}

// A value as a message quotes it: numbers as they read (100, not 100.0).
std::string value_text(const toml::node& n) {
  if (n.is_floating_point()) return fmt::format("{}", *n.value<double>());
  return render(n);
}

void collect_unknown(const toml::table& t, const std::string& prefix, std::vector<std::string>& problems) {
  for (auto&& [k, v] : t) {
    std::string path = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    if (v.is_table()) {
      if (is_section(path)) collect_unknown(*v.as_table(), path, problems);
      else if (!find_schema_entry(path))   // a key written as a table: its type check names it
        problems.push_back(fmt::format("unknown section [{}]{}", path, allowed_sections(path)));
    } else if (is_section(path)) {
      problems.push_back(fmt::format("'{}' is a section, not a key: write its keys under [{}] (got {} = {})", path, path,
                                     path, render(v)));
    } else if (!find_schema_entry(path)) {
      problems.push_back(fmt::format("unknown key '{}'{}", path, allowed_keys(path)));
    }
  }
}

// A decimal number that no double holds (1e-400, 1e999): TOML refuses it, though it is a number.
bool beyond_double(std::string_view text) {
  const char* first = text.data() + (!text.empty() && text[0] == '+');
  double value;
  const auto [end, ec] = std::from_chars(first, text.data() + text.size(), value);
  return ec == std::errc::result_out_of_range && end == text.data() + text.size();
}

// An integer literal (sign, digits) that no 64-bit integer holds: TOML refuses it, though it is a number.
bool beyond_64_bits(std::string_view text) {
  std::string_view digits = text.substr(!text.empty() && (text[0] == '+' || text[0] == '-'));
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string_view::npos) return false;
  std::int64_t value;
  const char* first = text.data() + (text[0] == '+');
  return std::from_chars(first, text.data() + text.size(), value).ec == std::errc::result_out_of_range;
}

// What is wrong with a number literal that TOML cannot hold (1e999, 2^63), as the key's allowed values say it;
// empty where the literal is no such number or the key takes none.
std::string unholdable_number(const SchemaEntry& e, std::string_view literal) {
  if (e.kind == ValueKind::integer && beyond_64_bits(literal))
    return fmt::format("{}: value {} is out of range: allowed {}", e.path, literal, describe_allowed(e));
  if (e.kind != ValueKind::real && e.kind != ValueKind::real_array) return "";
  if (beyond_double(literal))
    return fmt::format("{}: value {} is beyond a double's range (magnitudes 2.2e-308 to 1.8e308, or 0): allowed {}", e.path,
                       literal, describe_allowed(e));
  if (beyond_64_bits(literal))   // a whole number too long for TOML's integers, which a double holds
    return fmt::format("{}: value {} is too long for a TOML integer: write it with an exponent (e.g. {:.6g}): allowed {}",
                       e.path, literal, std::strtod(std::string(literal).c_str(), nullptr), describe_allowed(e));
  return "";
}

// The schema key whose `key = value` is on line `line` (1-based) of a scene's text (its section the last
// [header] above it), and the text after its '='. A null key where the line holds none (a row of an array
// written over several lines).
struct KeyOnLine {
  const SchemaEntry* entry = nullptr;
  std::string_view value;
};
KeyOnLine key_on_line(std::string_view text, std::size_t line) {
  auto trim = [](std::string_view v) {
    const auto first = v.find_first_not_of(" \t"), last = v.find_last_not_of(" \t\r");
    return first == std::string_view::npos ? std::string_view() : v.substr(first, last - first + 1);
  };
  std::string section;
  std::size_t number = 1;
  for (std::size_t start = 0; start <= text.size() && number <= line; ++number) {
    auto end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view content = trim(text.substr(start, end - start));
    start = end + 1;
    if (number < line) {
      if (content.starts_with('[') && !content.starts_with("[[") && content.find(']') != std::string_view::npos)
        section = std::string(trim(content.substr(1, content.find(']') - 1)));
      continue;
    }
    const auto eq = content.find('=');
    if (eq == std::string_view::npos) return {};
    const std::string key(trim(content.substr(0, eq)));
    return {find_schema_entry(section.empty() ? key : section + "." + key), content.substr(eq + 1)};
  }
  return {};
}

bool in_range(const SchemaEntry& e, double x) {
  if (!std::isfinite(x)) return false;
  if (e.min_open ? x <= e.min : x < e.min) return false;
  if (e.max_open ? x >= e.max : x > e.max) return false;
  return true;
}

}  // namespace

Scene Scene::from_string(std::string_view text, std::string origin, const std::vector<std::string>& overrides,
                         const std::filesystem::path& directory) {
  Scene s;
  s.origin_ = std::move(origin);
  s.directory_ = directory;
  try {
    s.table_ = toml::parse(text, s.origin_);
  } catch (const toml::parse_error& err) {
    // A number too large for TOML (toml++ quotes it in its message) is named by its key and the key's range.
    const std::string_view what = err.description();
    const auto open = what.find('\''), close = what.rfind('\'');
    const KeyOnLine at = key_on_line(text, err.source().begin.line);
    std::string named;
    if (at.entry && what.ends_with("not representable in 64 bits") && open < close) {
      std::string_view literal = what.substr(open + 1, close - open - 1);   // toml++ quotes it without its sign
      const auto in_line = at.value.find(literal);
      if (in_line != std::string_view::npos && in_line > 0 && (at.value[in_line - 1] == '-' || at.value[in_line - 1] == '+'))
        literal = at.value.substr(in_line - 1, literal.size() + 1);
      named = unholdable_number(*at.entry, literal);
    }
    if (!named.empty()) throw SceneError(fmt::format("{}:{}: {}", s.origin_, err.source().begin.line, named));
    throw SceneError(fmt::format("{}:{}:{}: TOML syntax error: {}", s.origin_, err.source().begin.line,
                                 err.source().begin.column, err.description()));
  }
  std::string length_override;   // the run-length key an override gave, if any
  // Each key an override gave: its value as written and as read. A key given again with another value was the
  // last one silently winning; the same value again passes (nothing is lost, and a script that repeats a
  // setting keeps working).
  std::map<std::string, std::pair<std::string, std::string>, std::less<>> given;
  std::vector<std::string> problems;   // the overrides': one list with the scene's own problems
  for (const auto& o : overrides) {
    try {
      auto eq = o.find('=');
      if (eq == std::string::npos || eq == 0)
        throw SceneError(fmt::format("--set '{}': expected key.path=value, e.g. contact.restitution=0.5", o));
      const std::string_view key = std::string_view(o).substr(0, eq);
      if (s.replace_run_length(key)) {
        if (!length_override.empty() && length_override != key)
          throw SceneError(fmt::format("--set {}: given together with --set {}: give one of time.duration, time.steps and "
                                       "time.free_fall_times", key, length_override));
        length_override = key;
      }
      const std::string_view written = std::string_view(o).substr(eq + 1);
      s.set_value(key, written);
      const std::string read = value_text(*s.node(key).node());
      const auto [first, is_new] = given.try_emplace(std::string(key), std::string(written), read);
      if (!is_new && first->second.second != read)
        throw SceneError(fmt::format("--set {}: given twice, as {} and as {}: give each key once", key,
                                     first->second.first, written));
    } catch (const SceneError& err) {
      problems.push_back(err.what());
    }
  }
  // Later problems may come from an override: say so where they name the scene.
  if (!overrides.empty()) s.origin_ += fmt::format(" with {} --set override{}", overrides.size(), overrides.size() > 1 ? "s" : "");
  if (!problems.empty()) s.report_problems(std::move(problems));
  return s;
}

// The run's length is one of three keys (protocols/run_length.hpp): an override giving one replaces
// whichever the file gave, so `--set time.steps=100` shortens a scene written with free_fall_times.
bool Scene::replace_run_length(std::string_view key) {
  static constexpr std::string_view lengths[] = {"duration", "steps", "free_fall_times"};
  if (key.substr(0, 5) != "time.") return false;
  const std::string_view name = key.substr(5);
  if (std::find(std::begin(lengths), std::end(lengths), name) == std::end(lengths)) return false;
  if (auto* time = table_["time"].as_table())
    for (std::string_view other : lengths)
      if (other != name) time->erase(other);
  return true;
}

Scene Scene::from_file(const std::filesystem::path& file, const std::vector<std::string>& overrides,
                       const std::string& origin) {
  const std::string allowed = fmt::format("a scene is a TOML file (a regular file or a pipe) of at most {} MiB",
                                          scene_file_limit >> 20);
  std::error_code ec;
  if (const auto kind = not_a_regular_file(file.string()); kind && !std::filesystem::is_fifo(file, ec))
    throw SceneError(fmt::format("scene file '{}' is {}: {}", file.string(), *kind, allowed));
  const auto too_large = [&](const std::string& bytes) {
    return SceneError(fmt::format("scene file '{}' holds {} bytes: {} ({} bytes); a large particle set belongs in "
                                  "particles.file", file.string(), bytes, allowed, scene_file_limit));
  };
  if (const auto size = std::filesystem::file_size(file, ec); !ec && size > scene_file_limit)
    throw too_large(std::to_string(size));
  std::ifstream in(file, std::ios::binary);
  if (!in) throw SceneError(fmt::format("cannot read scene file '{}': no such file or not readable", file.string()));
  // Read in pieces up to the limit: a pipe has no size to check beforehand.
  std::string text;
  std::array<char, 1 << 16> piece;
  while (in.read(piece.data(), piece.size()) || in.gcount() > 0) {
    text.append(piece.data(), std::size_t(in.gcount()));
    if (text.size() > scene_file_limit) throw too_large(fmt::format("more than {}", scene_file_limit));
  }
  return from_string(text, origin.empty() ? file.string() : origin, overrides, std::filesystem::absolute(file).parent_path());
}

void Scene::set_value(std::string_view path, std::string_view toml_value) {
  // `--set box=4` was "unknown key 'box'", followed by a list of sections that includes box.
  if (is_section(path))
    throw SceneError(fmt::format("--set: '{}' is a section, not a key: give one of its keys, --set {}.KEY=value; "
                                 "the keys of [{}] are: {}",
                                 path, path, path, section_keys(path)));
  if (!find_schema_entry(path))
    throw SceneError(fmt::format("--set: unknown key '{}'{}", path, allowed_keys(path)));
  const SchemaEntry& e = *find_schema_entry(path);
  toml::table parsed;
  try {
    parsed = toml::parse(fmt::format("v = {}", toml_value));
  } catch (const toml::parse_error&) {   // a bare word is taken as a string: --set output.file=run.h5
    if (std::string named = unholdable_number(e, toml_value); !named.empty()) throw SceneError(named);
  }
  // A text key takes the bare word as written, though it reads as a number or boolean (--set scene.name=2024).
  if (!parsed.contains("v") || (e.kind == ValueKind::text && !parsed.get("v")->is_string())) {
    toml::table t;
    t.insert("v", std::string(toml_value));
    parsed = std::move(t);
  }
  toml::table* tbl = &table_;
  std::string_view rest = path;
  for (auto dot = rest.find('.'); dot != std::string_view::npos; dot = rest.find('.')) {
    auto key = rest.substr(0, dot);
    if (!tbl->contains(key)) tbl->insert(key, toml::table{});
    tbl = (*tbl)[key].as_table();
    if (!tbl) throw SceneError(fmt::format("--set '{}': '{}' is not a section", path, key));
    rest = rest.substr(dot + 1);
  }
  parsed.get("v")->visit([&](auto&& v) { tbl->insert_or_assign(rest, v); });
}

const SchemaEntry& Scene::entry(std::string_view path) const {
  const SchemaEntry* e = find_schema_entry(path);
  if (!e) throw std::logic_error(fmt::format("scene key '{}' is used by the engine but missing from the schema", path));
  return *e;
}

toml::node_view<const toml::node> Scene::node(std::string_view path) const { return table_.at_path(path); }

bool Scene::has(std::string_view path) const { return static_cast<bool>(node(path)); }

void Scene::fail(std::string_view path, const std::string& what) const {
  throw SceneError(fmt::format("{}: {}: {}", origin_, path, what));
}

namespace {
template <class F>
auto with_default(const Scene& s, toml::node_view<const toml::node> n, const SchemaEntry& e, F&& read) {
  if (n) return read(*n.node());
  if (e.fallback.empty()) s.fail(e.path, fmt::format("required here but missing ({})", e.doc));
  auto t = toml::parse(fmt::format("v = {}", e.fallback));
  return read(*t.get("v"));
}
}  // namespace

double Scene::real(std::string_view path) const {
  const auto& e = entry(path);
  return with_default(*this, node(path), e, [&](const toml::node& n) {
    auto x = n.value<double>();
    if (!x || n.is_boolean()) fail(path, fmt::format("expected a number, got {}: allowed {}", render(n), describe_allowed(e)));
    if (!in_range(e, *x)) fail(path, fmt::format("value {} is out of range: allowed {}", *x, describe_allowed(e)));
    return *x;
  });
}

long Scene::integer(std::string_view path) const {
  const auto& e = entry(path);
  return with_default(*this, node(path), e, [&](const toml::node& n) {
    auto x = n.value<int64_t>();
    if (!n.is_integer() || !x)
      fail(path, fmt::format("expected an integer, got {}: allowed {}", render(n), describe_allowed(e)));
    // Compared as doubles, 9200000000000000001 rounds onto a bound of 9.2e18: the bounds within int64's range are
    // compared as integers too.
    const bool past_max = std::abs(e.max) <= 9.2e18 && *x > static_cast<std::int64_t>(e.max);
    const bool past_min = std::abs(e.min) <= 9.2e18 && *x < static_cast<std::int64_t>(e.min);
    if (!in_range(e, double(*x)) || past_max || past_min)
      fail(path, fmt::format("value {} is out of range: allowed {}", *x, describe_allowed(e)));
    return long(*x);
  });
}

bool Scene::boolean(std::string_view path) const {
  const auto& e = entry(path);
  return with_default(*this, node(path), e, [&](const toml::node& n) {
    if (!n.is_boolean()) fail(path, fmt::format("expected true or false, got {}", render(n)));
    return *n.value<bool>();
  });
}

std::string Scene::text(std::string_view path) const {
  const auto& e = entry(path);
  return with_default(*this, node(path), e, [&](const toml::node& n) {
    if (!n.is_string()) fail(path, fmt::format("expected a string, got {}: allowed {}", render(n), describe_allowed(e)));
    std::string v = *n.value<std::string>();
    // TOML's "\u0000" and the like: a NUL would end a file name where the operating system reads it, silently, and an
    // escape drives the terminal the value is printed on. Tabs and line ends stay (a description of several lines).
    const auto control = [](unsigned char b) { return (b < 0x20 && b != '\t' && b != '\n' && b != '\r') || b == 0x7f; };
    if (const auto c = std::find_if(v.begin(), v.end(), control); c != v.end())
      fail(path, fmt::format("value \"{}\" holds a control character (byte 0x{:02x} at position {}): allowed text without "
                             "control characters (but tabs and line ends)", printable(v), static_cast<unsigned char>(*c),
                             c - v.begin() + 1));
    if (const auto choices = choice_list(e); !choices.empty() && std::find(choices.begin(), choices.end(), v) == choices.end())
      fail(path, fmt::format("value \"{}\" is not allowed: allowed {}", v, describe_allowed(e)));
    if (e.file_name && !is_plain_file_name(v))
      fail(path, fmt::format("value \"{}\" is not allowed: allowed {}", v, describe_allowed(e)));
    return v;
  });
}

std::vector<double> Scene::reals(std::string_view path) const {
  const auto& e = entry(path);
  return with_default(*this, node(path), e, [&](const toml::node& n) {
    const auto* a = n.as_array();
    if (!a) fail(path, fmt::format("expected an array of numbers, got {}: allowed {}", render(n), describe_allowed(e)));
    std::vector<double> out;
    for (std::size_t i = 0; i < a->size(); ++i) {
      auto x = (*a)[i].value<double>();
      if (!x || (*a)[i].is_boolean())
        fail(path, fmt::format("element {} is {}, expected a number: allowed {}", i, render((*a)[i]), describe_allowed(e)));
      if (!in_range(e, *x)) fail(path, fmt::format("element {} = {} is out of range: allowed {}", i, *x, describe_allowed(e)));
      out.push_back(*x);
    }
    return out;
  });
}

std::vector<std::vector<double>> Scene::matrix(std::string_view path) const {
  const auto& e = entry(path);
  return with_default(*this, node(path), e, [&](const toml::node& n) {
    const auto* a = n.as_array();
    if (!a) fail(path, fmt::format("expected an array of arrays of numbers, got {}", render(n)));
    std::vector<std::vector<double>> out;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const auto* row = (*a)[i].as_array();
      if (!row) fail(path, fmt::format("element {} is {}, expected an array of numbers", i, render((*a)[i])));
      std::vector<double> r;
      for (std::size_t j = 0; j < row->size(); ++j) {
        auto x = (*row)[j].value<double>();
        if (!x || !std::isfinite(*x)) fail(path, fmt::format("element [{}][{}] is {}, expected a finite number", i, j, render((*row)[j])));
        r.push_back(*x);
      }
      out.push_back(std::move(r));
    }
    return out;
  });
}

void Scene::validate() const { report_problems({}); }

// The first key a rule's key needs that the scene sets otherwise, if any.
std::optional<Scene::UnmetNeed> Scene::unmet_need(const UnreadKeyRule& rule) const {
  for (const auto& [key, needed] : rule.needs) {
    const auto m = node(key);
    std::string value = m ? render(*m.node()) : std::string(entry(key).fallback);
    if (value != needed) return UnmetNeed{key, std::move(value), needed};
  }
  return std::nullopt;
}

namespace {
bool supersession(const UnreadKeyRule& rule) { return rule.needs.size() == 1 && rule.needs[0].second.empty(); }
}  // namespace

bool Scene::superseded(const UnreadKeyRule& rule) const {
  return supersession(rule) && node(rule.path) && node(rule.needs[0].first);
}

std::vector<std::string> Scene::superseded_keys() const {
  std::vector<std::string> notes;
  for (const auto& rule : unread_key_rules())
    if (superseded(rule)) {
      const std::string& other = rule.needs[0].first;
      notes.push_back(fmt::format("{} = {} is not used: {} = {} is given and takes its place", rule.path,
                                  value_text(*node(rule.path).node()), other, value_text(*node(other).node())));
    }
  return notes;
}

// A key given (in the scene or by --set) that the scene does not read, as its other keys set it up: refused
// rather than ignored, so that no one believes it took effect. Keys not given are never refused.
// A key another given key replaces is warned about instead (superseded_keys()).
void Scene::unread_keys(std::vector<std::string>& problems) const {
  for (const auto& rule : unread_key_rules()) {
    const auto n = node(rule.path);
    if (!n || supersession(rule) || (!rule.when.empty() && render(*n.node()) != rule.when)) continue;
    if (const auto unmet = unmet_need(rule))
      problems.push_back(fmt::format("{}: value {} is not used with {} = {}: it needs {} = {}", rule.path,
                                     value_text(*n.node()), unmet->key, unmet->value, unmet->key, unmet->needed));
  }
}

void Scene::report_problems(std::vector<std::string> problems) const {
  collect_unknown(table_, "", problems);
  for (const auto& e : scene_schema()) {
    if (!has(e.path)) continue;
    try {
      switch (e.kind) {
        case ValueKind::real: real(e.path); break;
        case ValueKind::integer: integer(e.path); break;
        case ValueKind::boolean: boolean(e.path); break;
        case ValueKind::text: text(e.path); break;
        case ValueKind::real_array: reals(e.path); break;
        case ValueKind::real_matrix: matrix(e.path); break;
      }
    } catch (const SceneError& err) {
      std::string what = err.what();
      if (what.rfind(origin_ + ": ", 0) == 0) what.erase(0, origin_.size() + 2);
      problems.push_back(what);
    }
  }
  if (refuse_unread_) unread_keys(problems);
  if (problems.empty()) return;
  std::string msg = fmt::format("{}: {} problem{} in the scene:", origin_, problems.size(), problems.size() > 1 ? "s" : "");
  for (const auto& p : problems) msg += "\n  - " + p;
  throw SceneError(msg);
}

// Whether the scene reads the key (no rule leaves it unread here).
bool Scene::read_by_scene(std::string_view path) const {
  for (const auto& rule : unread_key_rules())
    if (rule.path == path && rule.when.empty() && unmet_need(rule)) return false;
  return true;
}

std::string Scene::resolved_toml() const {
  toml::table out;
  for (const auto& e : scene_schema()) {
    toml::node_view<const toml::node> n = node(e.path);
    toml::table parsed;
    bool replaced = false;   // given, and superseded by another given key
    for (const auto& rule : unread_key_rules()) replaced = replaced || (rule.path == e.path && superseded(rule));
    if (replaced) continue;
    if (!n) {
      if (e.fallback.empty() || !read_by_scene(e.path)) continue;   // a default the scene does not read is left out,
      parsed = toml::parse(fmt::format("v = {}", e.fallback));         // so the resolved scene runs as it is
      n = toml::node_view<const toml::node>(parsed.get("v"));
    }
    auto dot = e.path.find('.');
    auto section = e.path.substr(0, dot);
    if (!out.contains(section)) out.insert(section, toml::table{});
    auto* t = out[section].as_table();
    n.node()->visit([&](auto&& v) { t->insert_or_assign(e.path.substr(dot + 1), v); });
  }
  std::ostringstream s;
  s << out;
  return s.str();
}

}  // namespace grains
