// Every class of bad scene is refused with a grains::SceneError whose message names the key, the
// offending value and what is allowed.
#include <catch2/catch.hpp>

#include <regex>

#include <algorithm>
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Contains;

namespace {

const std::string good = R"(
[scene]
dimension = 3
[particles]
layout = "lattice"
count = 27
solid_fraction = 0.2
[contact]
restitution = 0.5
duration = 0.05
[run]
threads = 1
)";

// The same without its particle count, for scenes that list their particles or read them from a file (where a
// count must agree with them).
const std::string good_uncounted = [] {
  std::string text = good;
  return text.erase(text.find("count = 27\n"), 11);
}();

void build(const std::string& text, const std::vector<std::string>& overrides = {}) {
  Simulation::create(Scene::from_string(text, "bad.toml", overrides));
}

std::string build_error(const std::string& text) {
  try {
    build(text);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

// Replace the first occurrence of `what` in the good scene.
std::string with(const std::string& what, const std::string& by) {
  std::string s = good;
  auto at = s.find(what);
  REQUIRE(at != std::string::npos);
  return s.replace(at, what.size(), by);
}

}  // namespace

TEST_CASE("scene errors: the reference scene itself is accepted", "[scene][errors]") {
  REQUIRE_NOTHROW(build(good));
}

TEST_CASE("scene errors: an unknown key is named, with the nearest key or the section's keys", "[scene][errors]") {
  // Typo: did-you-mean.
  REQUIRE_THROWS_AS(build(with("restitution = 0.5", "restitutoin = 0.5")), SceneError);
  REQUIRE_THROWS_WITH(build(with("restitution = 0.5", "restitutoin = 0.5")),
                      Contains("unknown key 'contact.restitutoin'") && Contains("did you mean 'contact.restitution'"));
  // Nothing close: the keys that [contact] does have.
  REQUIRE_THROWS_WITH(build(with("duration = 0.05", "duration = 0.05\nstiffness = 1e4")),
                      Contains("unknown key 'contact.stiffness'") && Contains("restitution") && Contains("duration") &&
                          Contains("calibration"));
}

TEST_CASE("scene errors: an unknown section is named, with the nearest section and the list", "[scene][errors]") {
  REQUIRE_THROWS_AS(build(good + "[walls]\nx = 1\n"), SceneError);
  REQUIRE_THROWS_WITH(build(good + "[walls]\nx = 1\n"),
                      Contains("unknown section [walls]") && Contains("particles") && Contains("contact") && Contains("friction"));
  REQUIRE_THROWS_WITH(build(good + "[fricton]\ncoefficient = 0.3\n"),
                      Contains("unknown section [fricton]") && Contains("did you mean [friction]"));
}

TEST_CASE("scene errors: a wrong type names key, value and expected type", "[scene][errors]") {
  REQUIRE_THROWS_AS(build(with("restitution = 0.5", "restitution = \"0.5\"")), SceneError);
  REQUIRE_THROWS_WITH(build(with("restitution = 0.5", "restitution = \"0.5\"")),
                      Contains("contact.restitution") && Contains("\"0.5\"") && Contains("expected a number"));
  REQUIRE_THROWS_WITH(build(with("count = 27", "count = 27.0")),
                      Contains("particles.count") && Contains("27") && Contains("expected an integer"));
  // An integer written as a float (1e16 for 10^16) is also told the range allowed.
  REQUIRE_THROWS_WITH(build(with("count = 27", "count = 1e16")),
                      Contains("particles.count") && Contains("expected an integer, got 1e+16: allowed integer in [1, 1000000000]"));
  REQUIRE_THROWS_WITH(build(good + "[box]\nperiodic = \"yes\"\n"),
                      Contains("box.periodic") && Contains("\"yes\"") && Contains("true or false"));
  REQUIRE_THROWS_WITH(build(good, {"box.lengths=3.0"}), Contains("box.lengths") && Contains("3") && Contains("array of numbers"));
}

TEST_CASE("scene errors: out-of-range values name key, value and the allowed interval", "[scene][errors]") {
  REQUIRE_THROWS_AS(build(with("restitution = 0.5", "restitution = 1.5")), SceneError);
  REQUIRE_THROWS_WITH(build(with("restitution = 0.5", "restitution = 1.5")),
                      Contains("contact.restitution") && Contains("1.5") && Contains("out of range") && Contains("(0, 1]"));
  REQUIRE_THROWS_WITH(build(with("restitution = 0.5", "restitution = 0.0")),
                      Contains("contact.restitution") && Contains("value 0 ") && Contains("(0, 1]"));
  REQUIRE_THROWS_WITH(build(good, {"particles.diameter=-0.5"}),
                      Contains("particles.diameter") && Contains("-0.5") && Contains("[1e-100, 1e+100]"));
  REQUIRE_THROWS_WITH(build(with("dimension = 3", "dimension = 4")),
                      Contains("scene.dimension") && Contains("value 4") && Contains("[2, 3]"));
  REQUIRE_THROWS_WITH(build(good, {"box.lengths=[4.0, -2.0, 4.0]"}),
                      Contains("box.lengths") && Contains("element 1") && Contains("-2") && Contains("(0, inf)"));
  REQUIRE_THROWS_WITH(build(good, {"contact.duration=0"}), Contains("contact.duration") && Contains("(0, inf)"));
}

TEST_CASE("scene errors: a bad choice for a text key lists the choices", "[scene][errors]") {
  REQUIRE_THROWS_AS(build(with("layout = \"lattice\"", "layout = \"hexagonal\"")), SceneError);
  REQUIRE_THROWS_WITH(build(with("layout = \"lattice\"", "layout = \"hexagonal\"")),
                      Contains("particles.layout") && Contains("\"hexagonal\"") && Contains("lattice, random, list, file"));
  REQUIRE_THROWS_WITH(build(good, {"contact.calibration=\"pairwise\""}),
                      Contains("contact.calibration") && Contains("\"pairwise\"") && Contains("global, per-pair, exact"));
}

TEST_CASE("scene errors: a scene name that cannot be a file name is refused", "[scene][errors]") {
  // scene.name forms the default output file names: it must not leave the output folder.
  for (const std::string& bad : std::vector<std::string>{"../x", "a/b", "", ".hidden", "with space", std::string(101, 'a')}) {
    INFO(bad);
    REQUIRE_THROWS_WITH(build(with("dimension = 3", fmt::format("dimension = 3\nname = \"{}\"", bad))),
                        Contains("scene.name") && Contains(fmt::format("\"{}\"", bad)) &&
                            Contains("A-Z a-z 0-9 . _ -, not starting with '.'"));
  }
  REQUIRE_NOTHROW(build(good, {"scene.name=\"gas-2_run.v1\""}));
  // A NUL (TOML's \u0000) in any text value: a file name would end there where the system reads it
  // (particles.file = "p.txt\u0000junk" would read p.txt).
  for (const std::string& set : {std::string("output.file=\"o.h5\\u0000zz\""), std::string("particles.layout=\"file\\u0007\"")})
    REQUIRE_THROWS_WITH(build(good, {set}), Contains("holds a control character") && Contains("allowed text without control"));
  // Tabs and line ends stay: a description of several lines.
  REQUIRE_NOTHROW(build(good, {"scene.description=\"First line.\\nSecond\\tline.\\r\""}));
  REQUIRE_NOTHROW(build(good, {"scene.name=\"" + std::string(100, 'a') + "\""}));
}

TEST_CASE("scene errors: a TOML syntax error gives the file and line", "[scene][errors]") {
  const std::string broken = "[scene]\ndimension = 3\n\n[contact]\nrestitution = = 0.5\n";
  REQUIRE_THROWS_AS(build(broken), SceneError);
  REQUIRE_THROWS_WITH(build(broken), Contains("bad.toml:5") && Contains("syntax"));
  REQUIRE_THROWS_WITH(build("[scene\ndimension = 3\n"), Contains("bad.toml:1") && Contains("syntax"));
}

// Found by fuzzing (tests/fuzz/fuzz_scene), two defects of toml++ 3.3.0 behind a syntax error
// (io/toml.hpp): a table header whose name starts with neither a key's character nor a quote broke an assertion, which
// aborted a build without NDEBUG (Debug, the sanitized builds); a character such as U+00A1 or U+FEFD where whitespace
// may stand reached __builtin_unreachable() (undefined behaviour, which UBSan reports). A Release build reported both.
TEST_CASE("scene errors: a malformed table header or a stray character is a syntax error, not an abort", "[scene][errors]") {
  const std::pair<std::string, std::string> cases[] = {
      {"[:", "expected bare key starting character or string delimiter, saw ':'"},
      {"[[=", "expected bare key starting character or string delimiter, saw '='"},
      {"[[[1]]]", "expected bare key starting character or string delimiter, saw '['"},
      {"[ :]", "expected bare key starting character or string delimiter, saw ':'"},
      {"seed = 1 \u00a1", "expected a comment or whitespace, saw '\u00a1'"},
      {"\ufefd", "expected keys, tables, whitespace or comments, saw '\ufefd'"},
      {"seed = [1, \u00a1]", "could not determine value type"}};
  for (const auto& [line, what] : cases) {
    INFO(line);
    REQUIRE_THROWS_WITH(build("[scene]\ndimension = 3\n" + line + "\n"),
                        Contains("bad.toml:3") && Contains("TOML syntax error") && Contains(what));
  }
}

TEST_CASE("scene errors: inconsistent layouts name the key, the value and what would work", "[scene][errors]") {
  // Lattice count not n^D: names the count and the nearest n^D.
  REQUIRE_THROWS_AS(build(with("count = 27", "count = 30")), SceneError);
  REQUIRE_THROWS_WITH(build(with("count = 27", "count = 30")),
                      Contains("particles.count") && Contains("30") && Contains("n^3") && Contains("27"));
  REQUIRE_THROWS_WITH(build(with("dimension = 3", "dimension = 2"), {"particles.count=20"}),
                      Contains("particles.count") && Contains("20") && Contains("n^2") && Contains("16"));
  // Periodic box too small for the particles.
  REQUIRE_THROWS_AS(build(good, {"particles.count=8", "box.lengths=[2.0, 2.0, 2.0]", "particles.diameter=0.9"}), SceneError);
  REQUIRE_THROWS_WITH(build(good, {"particles.count=8", "box.lengths=[2.0, 2.0, 2.0]", "particles.diameter=0.9"}),
                      Contains("box.lengths") && Contains("2 long") && Contains("periodic box must be longer"));
  // One vector is not a row of a list (the message said "row 0 has 2 components").
  REQUIRE_THROWS_WITH(build(good, {"box.lengths=[3.0, 3.0]"}), Contains("box.lengths: 2 values; a 3D scene needs 3"));
  // A count no machine here holds is refused before anything is allocated, naming the memory it needs.
  REQUIRE_THROWS_WITH(build(good, {"particles.layout=\"random\"", "particles.count=1000000000"}),
                      Contains("particles.count") && Contains("1000000000") && Contains("750 GB"));
  // Masses whose products would vanish (they once surfaced as "time.dt: required when contacts are off").
  REQUIRE_THROWS_WITH(build(good, {"particles.density=1e-308"}),
                      Contains("particles.density") && Contains("[1e-150, 1e150]"));
  // Random insertion at an impossible solid fraction: names the fraction.
  REQUIRE_THROWS_AS(build(good, {"particles.layout=\"random\"", "particles.count=200", "particles.solid_fraction=0.7"}),
                    SceneError);
  REQUIRE_THROWS_WITH(build(good, {"particles.layout=\"random\"", "particles.count=200", "particles.solid_fraction=0.7"}),
                      Contains("particles.solid_fraction") && Contains("0.7") && Contains("random insertion could not place") &&
                          Contains("lower the solid fraction"));
  // ... the fraction it reached, its share of the 0.7 asked (equal sizes), and that the reach falls with the count
  // (the message had said "jams near 0.38" while 10^5 spheres jammed at 0.34).
  try {
    build(good, {"particles.layout=\"random\"", "particles.count=200", "particles.solid_fraction=0.7"});
    FAIL("no error");
  } catch (const SceneError& e) {
    const std::string what = e.what();
    std::smatch m;
    REQUIRE(std::regex_search(what, m, std::regex(R"(jammed at ([0-9.]+) \((\d+) of 200 placed)")));
    CHECK(std::stod(m[1]) == Approx(0.7 * std::stod(m[2]) / 200).epsilon(1e-3));
    CHECK(std::stod(m[1]) < 0.7);
    CHECK_THAT(what, Contains("falls as the particles grow in number") && Contains("particles.layout = \"lattice\""));
  }
  // Disks are told of disks only (the spheres' 10^4 / 10^5 figures were said to disks too).
  REQUIRE_THROWS_WITH(build(with("dimension = 3", "dimension = 2"), {"particles.layout=\"random\"", "particles.count=200",
                                                                    "particles.solid_fraction=0.85"}),
                      Contains("equal disks jam near 0.55") && !Contains("spheres"));
  // Lists of mismatched lengths.
  const std::vector<std::string> two = {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[2,0,0]]",
                                        "box.periodic=false"};
  auto plus = [&](std::string extra) { auto v = two; v.push_back(std::move(extra)); return v; };
  REQUIRE_THROWS_AS(build(good_uncounted, plus("particles.diameters=[1.0]")), SceneError);
  REQUIRE_THROWS_WITH(build(good_uncounted, plus("particles.diameters=[1.0]")), Contains("particles.diameters") && Contains("1 values for 2"));
  REQUIRE_THROWS_WITH(build(good_uncounted, plus("particles.masses=[1.0, 2.0, 3.0]")),
                      Contains("particles.masses") && Contains("3 values for 2"));
  auto vel = plus("particles.velocity=\"list\"");
  vel.push_back("particles.velocities=[[1,0,0]]");
  REQUIRE_THROWS_WITH(build(good_uncounted, vel), Contains("particles.velocities") && Contains("1 velocities for 2"));
  REQUIRE_THROWS_WITH(build(good_uncounted, {"particles.layout=\"list\"", "particles.positions=[[0,0],[2,0]]", "box.periodic=false"}),
                      Contains("particles.positions") && Contains("2 components") && Contains("3D scene needs 3"));
}

TEST_CASE("scene errors: a key that the chosen layout or velocity does not read is refused", "[scene][errors]") {
  // Velocities without velocity = "list" were once dropped silently: the particles started at rest.
  const std::vector<std::string> two = {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[2,0,0]]",
                                        "box.periodic=false", "particles.velocities=[[1,0,0],[-1,0,0]]"};
  REQUIRE_THROWS_WITH(build(good_uncounted, two), Contains("particles.velocities") && Contains("particles.velocity = \"zero\"") &&
                                            Contains("particles.velocity = \"list\""));
  auto listed = two;
  listed.push_back("particles.velocity=\"list\"");
  REQUIRE_NOTHROW(build(good_uncounted, listed));
  REQUIRE_THROWS_WITH(build(good, {"particles.positions=[[0,0,0]]"}),
                      Contains("particles.positions") && Contains("particles.layout = \"lattice\"") &&
                          Contains("particles.layout = \"list\""));
  REQUIRE_THROWS_WITH(build(good, {"particles.diameters=[1.0]"}), Contains("particles.diameters") && Contains("\"list\""));
  REQUIRE_THROWS_WITH(build(good, {"particles.masses=[1.0]"}), Contains("particles.masses") && Contains("\"list\""));
  REQUIRE_THROWS_WITH(build(good, {"particles.file=\"rows.txt\""}),
                      Contains("particles.file") && Contains("particles.layout = \"file\""));
}

TEST_CASE("scene errors: a particle file's word that is not a number is named with its line and column", "[scene][errors]") {
  const auto path = std::filesystem::temp_directory_path() / "grains-bad-rows.txt";
  {
    std::ofstream f(path);
    f << "# x y z diameter mass\n0 0 0 1 1\n2 0 0 1 1\n4 0 0 1 np.float64(1.0)\n";
  }
  const std::vector<std::string> file = {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                         "box.periodic=false"};
  REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("particles.file") && Contains("grains-bad-rows.txt:4") &&
                                             Contains("column 5") && Contains("'np.float64(1.0)' is not a decimal number"));
  // C's hexadecimal numbers, which strtod reads (0x10 = 16), and control bytes, shown escaped (a NUL would end the
  // message, an escape sequence drive the terminal).
  for (const auto& [word, shown] : {std::pair<std::string, std::string>{"0x10", "'0x10'"},
                                    std::pair<std::string, std::string>{std::string("\0\x01", 2), "'\\x00\\x01'"},
                                    std::pair<std::string, std::string>{"\x1b[31mRED", "'\\x1b[31mRED'"},
                                    // a NUL inside a number: strtod stops there and would read "3\077" as 3, as a
                                    // crash's zero-filled block would be
                                    std::pair<std::string, std::string>{std::string("3\0" "77", 4), "'3\\x0077'"},
                                    // a 20 MB word was echoed whole: now its start and its length
                                    std::pair<std::string, std::string>{std::string(100000, '7') + "z",
                                                                        "'" + std::string(60, '7') + "... (100001 bytes)'"}}) {
    {
      std::ofstream f(path);
      f << "0 0 0 1 1\n2 " << word << " 0 1 1\n";
    }
    INFO(shown);
    REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("grains-bad-rows.txt:2: column 2") &&
                                                         Contains(shown + " is not a decimal number"));
  }
  // Words strtod reads as non-finite numbers failed only later, naming neither the file nor the line.
  for (const auto& [word, value] : {std::pair{"nan", "nan"}, std::pair{"-inf", "-inf"}, std::pair{"1e999", "inf"}}) {
    {
      std::ofstream f(path);
      f << "0 0 0 1 1\n2 " << word << " 0 1 1\n";
    }
    REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("particles.file") && Contains("grains-bad-rows.txt:2: column 2") &&
                                               Contains(fmt::format("'{}' is {}, expected a finite number", word, value)));
  }
  {
    std::ofstream f(path);
    f << "0 0 0 1 1\n2 0 0 1 1\n";
  }
  REQUIRE_NOTHROW(build(good_uncounted, file));
  // A byte-order mark before the first row (some editors write one) was "'\xef\xbb\xbf0' is not a decimal number",
  // shown as "'0'": it is skipped.
  {
    std::ofstream f(path);
    f << "\xef\xbb\xbf" "0 0 0 1 1\n2 0 0 1 1\n";
  }
  REQUIRE(Simulation::create(Scene::from_string(good_uncounted, "bad.toml", file))->particle_count() == 2);
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: particle file rows with different column counts are refused, naming the line", "[scene][errors]") {
  // Velocities were read from every row by the first row's width: past the end of a shorter row (a heap
  // read out of bounds), or silently dropped when the first row had none.
  const auto path = std::filesystem::temp_directory_path() / "grains-ragged-rows.txt";
  const std::vector<std::string> file = {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                         "box.periodic=false"};
  {
    std::ofstream f(path);
    f << "# x y z diameter mass vx vy vz\n0 0 0 1 1 1 0 0\n2 0 0 1 1\n";
  }
  REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("particles.file") && Contains("grains-ragged-rows.txt:3") &&
                                             Contains("5 columns") && Contains("first particle row (line 2) has 8"));
  {
    std::ofstream f(path);
    f << "0 0 0 1 1\n\n2 0 0 1 1 -1 0 0\n";
  }
  REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("particles.file") && Contains("grains-ragged-rows.txt:3") &&
                                             Contains("8 columns") && Contains("first particle row (line 1) has 5"));
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: a bad --set override is named", "[scene][errors]") {
  REQUIRE_THROWS_AS(build(good, {"contact.restitutoin=0.3"}), SceneError);
  REQUIRE_THROWS_WITH(build(good, {"contact.restitutoin=0.3"}),
                      Contains("--set") && Contains("contact.restitutoin") && Contains("did you mean 'contact.restitution'"));
  REQUIRE_THROWS_WITH(build(good, {"contact.stiffness=3"}),
                      Contains("--set") && Contains("contact.stiffness") && Contains("restitution, duration"));
  REQUIRE_THROWS_AS(build(good, {"contact.restitution"}), SceneError);
  REQUIRE_THROWS_WITH(build(good, {"contact.restitution"}),
                      Contains("'contact.restitution'") && Contains("expected key.path=value"));
  REQUIRE_THROWS_WITH(build(good, {"=0.3"}), Contains("'=0.3'") && Contains("expected key.path=value"));
  // A --set value is validated like a file value.
  REQUIRE_THROWS_WITH(build(good, {"contact.restitution=2"}), Contains("contact.restitution") && Contains("value 2") && Contains("(0, 1]"));
}

TEST_CASE("scene errors: a --set bare word is a text key's value, though it reads as a number or boolean", "[scene][errors]") {
  // A bare word is a string (--set output.file=run.h5), but --set scene.name=2024 was the integer 2024, refused.
  const Scene scene = Scene::from_string(good, "s.toml", {"scene.name=2024", "output.file=1e5", "scene.description=true"});
  CHECK(scene.text("scene.name") == "2024");
  CHECK(scene.text("output.file") == "1e5");
  CHECK(scene.text("scene.description") == "true");
  REQUIRE_THROWS_WITH(build(good, {"particles.layout=3"}),
                      Contains("particles.layout: value \"3\" is not allowed: allowed string, one of lattice, random, list, file"));
  // A number key still reads the number, and refuses the bare word.
  REQUIRE_THROWS_WITH(build(good, {"contact.restitution=high"}), Contains("contact.restitution: expected a number, got \"high\""));
}

TEST_CASE("scene errors: exact calibration refuses a restitution it cannot realise", "[scene][errors]") {
  REQUIRE_THROWS_AS(build(good, {"contact.calibration=\"exact\"", "contact.restitution=0.1"}), SceneError);
  REQUIRE_THROWS_WITH(build(good, {"contact.calibration=\"exact\"", "contact.restitution=0.1"}),
                      Contains("contact.restitution") && Contains("0.1") && Contains("(0.135335, 1]"));
  REQUIRE_NOTHROW(build(good, {"contact.calibration=\"exact\"", "contact.restitution=0.14"}));
}

TEST_CASE("scene errors: all problems of a scene are listed at once", "[scene][errors]") {
  REQUIRE_THROWS_WITH(build(good, {"contact.restitution=2", "particles.seed=-3"}),
                      Contains("2 problems") && Contains("contact.restitution") && Contains("particles.seed"));
  // The overrides' own problems (unknown key, no '=') join the scene's.
  REQUIRE_THROWS_WITH(build(with("restitution = 0.5", "restitutoin = 0.5"), {"contact.stiffness=3", "contact.duration"}),
                      Contains("3 problems") && Contains("--set: unknown key 'contact.stiffness'") &&
                          Contains("'contact.duration': expected key.path=value") && Contains("unknown key 'contact.restitutoin'"));
}

TEST_CASE("scene errors: a --set integer beyond 64 bits is out of range, with the range", "[scene][errors]") {
  // TOML cannot hold it, so it was read as the string "99999999999999999999999" ("expected an integer").
  REQUIRE_THROWS_WITH(build(good, {"particles.count=99999999999999999999999"}),
                      Contains("particles.count: value 99999999999999999999999 is out of range") &&
                          Contains("allowed integer in [1, 1000000000]"));
  REQUIRE_THROWS_WITH(build(good, {"particles.seed=-99999999999999999999999"}),
                      Contains("particles.seed: value -99999999999999999999999 is out of range"));
  // Not an integer literal at all: still a wrong type.
  REQUIRE_THROWS_WITH(build(good, {"particles.count=007"}), Contains("particles.count") && Contains("expected an integer"));
}

TEST_CASE("scene errors: a --set real beyond a double's range is named as such", "[scene][errors]") {
  // TOML cannot hold 1e-400: it was read as a string ("expected a number, got \"1e-400\"").
  REQUIRE_THROWS_WITH(build(good, {"time.dt=1e-400"}),
                      Contains("time.dt: value 1e-400 is beyond a double's range") && Contains("allowed number in (0, inf)"));
  REQUIRE_THROWS_WITH(build(good, {"contact.restitution=-1e999"}), Contains("contact.restitution: value -1e999 is beyond"));
  REQUIRE_THROWS_WITH(build(good, {"time.dt=1e-4x"}), Contains("time.dt") && Contains("expected a number"));
}

TEST_CASE("scene errors: a section written as a key, and a key written as a section, are named", "[scene][errors]") {
  // `box = 4` was "unknown key 'box'", followed by a list of sections that includes box.
  REQUIRE_THROWS_WITH(build("box = 4\n" + good),
                      Contains("'box' is a section, not a key: write its keys under [box] (got box = 4)"));
  // The same by --set, not "unknown key 'box'".
  std::string set_section = "no error";
  try {
    build(good, {"box=4"});
  } catch (const std::exception& e) {
    set_section = e.what();
  }
  CHECK_THAT(set_section, Contains("--set: 'box' is a section, not a key") && Contains("--set box.KEY=value") &&
                              Contains("periodic") && !Contains("unknown key"));
  const std::string table_key = build_error(with("count = 27", "[particles.count]\nn = 27"));
  CHECK_THAT(table_key, Contains("particles.count: expected an integer") && !Contains("unknown section"));
}

TEST_CASE("scene errors: a folder as particles.file is named as a folder", "[scene][errors]") {
  const auto folder = std::filesystem::temp_directory_path();
  REQUIRE_THROWS_WITH(build(good_uncounted, {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", folder.string())}),
                      Contains("particles.file") && Contains("is a folder"));
}

TEST_CASE("scene errors: a contact duration without a finite, nonzero stiffness names contact.duration", "[scene][errors]") {
  // k_n = m* C / t_c^2 underflowed to 0 (contacts that do not push) or overflowed to inf, and the run went on.
  REQUIRE_THROWS_WITH(build(good, {"contact.duration=1e200", "time.dt=0.01"}),
                      Contains("contact.duration: value 1e+200") && Contains("k_n = 0"));
  REQUIRE_THROWS_WITH(build(good, {"contact.duration=1e-300"}), Contains("contact.duration: value 1e-300") &&
                                                                   Contains("k_n = inf") && Contains("t_c within about"));
  REQUIRE_NOTHROW(build(good, {"contact.duration=1e-100"}));
}

TEST_CASE("scene errors: a skin too thick for the periodic box names neighbours.skin", "[scene][errors]") {
  // The box fits the grains: the given skin was blamed on box.lengths.
  REQUIRE_THROWS_WITH(build(good, {"neighbours.skin=1.5"}),
                      Contains("neighbours.skin: value 1.5 is too thick for periodic axis 0") && !Contains("box.lengths"));
  REQUIRE_NOTHROW(build(good, {"neighbours.skin=0.5"}));
}

TEST_CASE("scene errors: a lattice too dense for its given box names box.lengths", "[scene][errors]") {
  // The box comes from box.lengths: the message must not name the solid fraction.
  const std::string boxed = with("solid_fraction = 0.2", "diameter = 5.0\n[box]\nlengths = [1.0, 1.0, 1.0]");
  REQUIRE_THROWS_WITH(build(boxed), Contains("box.lengths") && Contains("lattice spacing 0.3333") &&
                                        Contains("largest diameter 5") && !Contains("solid_fraction"));
  REQUIRE_THROWS_WITH(build(with("solid_fraction = 0.2", "solid_fraction = 0.9")),
                      Contains("particles.solid_fraction") && Contains("lower the solid fraction"));
}

TEST_CASE("scene errors: a kinetic energy whose total overflows names particles.kinetic_energy", "[scene][errors]") {
  // Unrefused, it surfaces as a non-finite velocity at the first step, naming no key.
  const std::string hot = with("solid_fraction = 0.2", "solid_fraction = 0.2\nvelocity = \"gaussian\"");
  REQUIRE_THROWS_WITH(build(hot, {"particles.kinetic_energy=1e308"}),
                      Contains("particles.kinetic_energy") && Contains("value 1e+308") && Contains("27 particles"));
  build(hot, {"particles.kinetic_energy=1e300"});   // large but finite: accepted
}

TEST_CASE("scene errors: given velocities whose kinetic energy overflows name the key, or the file and line", "[scene][errors]") {
  // The run once "completed" with kinetic_energy inf.
  const std::vector<std::string> two = {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[2,0,0]]",
                                        "box.periodic=false", "particles.velocity=\"list\""};
  auto plus = [&](std::string extra) { auto v = two; v.push_back(std::move(extra)); return v; };
  REQUIRE_THROWS_WITH(build(good_uncounted, plus("particles.velocities=[[0,0,0],[1e160,0,0]]")),
                      Contains("particles.velocities: row 1") && Contains("1e+160") && Contains("overflow a double"));
  REQUIRE_NOTHROW(build(good_uncounted, plus("particles.velocities=[[0,0,0],[1e150,0,0]]")));   // large, finite energy
  auto spun = plus("particles.velocities=[[0,0,0],[0,0,0]]");
  spun.push_back("particles.angular_velocities=[[0,0,0],[0,1e200,0]]");
  REQUIRE_THROWS_WITH(build(good_uncounted, spun), Contains("particles.angular_velocities: row 1") && Contains("overflow a double"));
  const auto path = std::filesystem::temp_directory_path() / "grains-fast-rows.txt";
  {
    std::ofstream f(path);
    f << "# x y z diameter mass vx vy vz\n0 0 0 1 1 0 0 0\n2 0 0 1 1 0 -1e160 0\n";
  }
  REQUIRE_THROWS_WITH(build(good_uncounted, {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                   "box.periodic=false"}),
                      Contains("particles.file") && Contains("grains-fast-rows.txt:3") && Contains("overflow a double"));
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: given particles at the same position are named, deep overlaps are warned about", "[scene][errors]") {
  // Both ran with no word: coincident particles failed with a non-finite force naming no key, deeply overlapping
  // ones flew apart.
  const std::vector<std::string> list = {"particles.layout=\"list\"", "box.periodic=false"};
  auto plus = [&](std::string extra) { auto v = list; v.push_back(std::move(extra)); return v; };
  REQUIRE_THROWS_WITH(build(good_uncounted, plus("particles.positions=[[0,0,0],[3,0,0],[3,0,0]]")),
                      Contains("particles.positions: particle 1 (row 1) and particle 2 (row 2) are at the same position"));
  const auto deep = Simulation::create(Scene::from_string(good_uncounted, "bad.toml", plus("particles.positions=[[0,0,0],[0.1,0,0],[5,0,0],[5.5,0,0]]")));
  REQUIRE(deep->warnings().size() == 1);
  CHECK_THAT(deep->warnings()[0], Contains("particles.positions: 2 pair(s) of particles overlap") &&
                                      Contains("contact.overlap_limit") && Contains("particle 0 (row 0) and particle 1 (row 1)") &&
                                      Contains("by 0.9 (1.8 min(R_i, R_j))"));
  // Within the limit (0.1 R): no warning.
  CHECK(Simulation::create(Scene::from_string(good_uncounted, "ok.toml", plus("particles.positions=[[0,0,0],[0.96,0,0]]")))->warnings().empty());
  // Across a periodic boundary too, and from a file, naming its lines.
  const auto path = std::filesystem::temp_directory_path() / "grains-overlapping-rows.txt";
  {
    std::ofstream f(path);
    f << "# x y z diameter mass\n0.1 1 1 1 1\n\n3.9 1 1 1 1\n2 2 2 1 1\n";
  }
  const std::vector<std::string> file = {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                         "box.lengths=[4.0, 4.0, 4.0]", "box.periodic=true"};
  const auto wrapped = Simulation::create(Scene::from_string(good_uncounted, "bad.toml", file));
  REQUIRE(wrapped->warnings().size() == 2);   // the scene's solid fraction, which box.lengths replaces, and the overlap
  CHECK_THAT(wrapped->warnings()[0], Contains("particles.solid_fraction = 0.2 is not used") && Contains("box.lengths"));
  CHECK_THAT(wrapped->warnings()[1], Contains("particles.file: 1 pair(s)") && Contains("grains-overlapping-rows.txt:2)") &&
                                         Contains("grains-overlapping-rows.txt:4)") && Contains("by 0.8 (1.6"));
  {
    std::ofstream f(path);
    f << "0 0 0 1 1\n2 2 2 1 1\n0 0 0 1 1\n";
  }
  REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("particles.file: particle 0") && Contains("grains-overlapping-rows.txt:1)") &&
                                             Contains("grains-overlapping-rows.txt:3)") && Contains("same position (0, 0, 0)"));
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: a key given where the scene does not read it names the value and the setting it needs",
          "[scene][errors]") {
  // Each was once ignored silently: the run went on with the defaults the user believed replaced.
  REQUIRE_THROWS_WITH(build(good, {"particles.diameter_min=0.4"}),
                      Contains("particles.diameter_min: value 0.4 is not used with particles.size_distribution = "
                               "\"constant\": it needs particles.size_distribution = \"uniform\""));
  REQUIRE_THROWS_WITH(build(with("count = 27", "count = 27\ndiameter_max = 0.9")),
                      Contains("particles.diameter_max: value 0.9 is not used with particles.size_distribution"));
  REQUIRE_NOTHROW(build(good, {"particles.size_distribution=\"uniform\"", "particles.diameter_min=0.8"}));

  REQUIRE_THROWS_WITH(build(good, {"particles.kinetic_energy=100"}),
                      Contains("particles.kinetic_energy: value 100 is not used with particles.velocity = \"zero\": it "
                               "needs particles.velocity = \"gaussian\""));
  REQUIRE_THROWS_WITH(build(good, {"particles.velocity=\"zero\"", "particles.kinetic_energy=2.5"}),
                      Contains("particles.kinetic_energy: value 2.5") && Contains("particles.velocity = \"zero\""));
  REQUIRE_NOTHROW(build(good, {"particles.velocity=\"gaussian\"", "particles.kinetic_energy=100"}));

  // The moduli come from the adhesive network's stiffness, straining the periodic cell: no B without them.
  REQUIRE_THROWS_WITH(build(good, {"analysis.elastic_moduli=true"}),
                      Contains("analysis.elastic_moduli: value true is not used with adhesion.enabled = false: it needs "
                               "adhesion.enabled = true"));
  REQUIRE_THROWS_WITH(build(good, {"analysis.elastic_moduli=true", "adhesion.enabled=true", "box.periodic=false",
                                   "box.lengths=[4.2, 4.2, 4.2]"}),
                      Contains("analysis.elastic_moduli: value true is not used with box.periodic = false: it needs "
                               "box.periodic = true"));
  REQUIRE_NOTHROW(build(good, {"analysis.elastic_moduli=false"}));   // asks for nothing
  const std::string adhesive = with("restitution = 0.5\nduration = 0.05", "");   // the linear law's calibration
  REQUIRE_NOTHROW(build(adhesive, {"analysis.elastic_moduli=true", "adhesion.enabled=true"}));

  // A module's keys without the module: adhesion, self-gravity, friction and rolling without contacts or
  // adhesion, the linear law's calibration under the adhesive law, the aggregation analysis without gravity.
  REQUIRE_THROWS_WITH(build(good, {"adhesion.force=2"}),
                      Contains("adhesion.force: value 2 is not used with adhesion.enabled = false: it needs "
                               "adhesion.enabled = true"));
  REQUIRE_THROWS_WITH(build(good, {"analysis.zero_force=1e-3"}),
                      Contains("analysis.zero_force: value 0.001 is not used with adhesion.enabled = false"));
  REQUIRE_THROWS_WITH(build(good, {"gravity.softening=0.2", "gravity.solver=\"tree\""}),
                      Contains("gravity.softening: value 0.2 is not used with gravity.enabled = false: it needs "
                               "gravity.enabled = true") &&
                          Contains("gravity.solver: value \"tree\" is not used with gravity.enabled = false"));
  REQUIRE_THROWS_WITH(build(good, {"analysis.every=10"}),
                      Contains("analysis.every: value 10 is not used with gravity.enabled = false"));
  REQUIRE_THROWS_WITH(build(good, {"adhesion.enabled=true"}),
                      Contains("contact.restitution: value 0.5 is not used with adhesion.enabled = true: it needs "
                               "adhesion.enabled = false") &&
                          Contains("contact.duration: value 0.05 is not used with adhesion.enabled = true"));
  REQUIRE_THROWS_WITH(build(adhesive, {"rolling.stiffness_ratio=1e-3"}),
                      Contains("rolling.stiffness_ratio: value 0.001 is not used with adhesion.enabled = false"));
  REQUIRE_THROWS_WITH(build(adhesive, {"contact.enabled=false", "friction.coefficient=0.3", "time.dt=0.01"}),
                      Contains("friction.coefficient: value 0.3 is not used with contact.enabled = false: it needs "
                               "contact.enabled = true"));
  REQUIRE_NOTHROW(build(adhesive, {"adhesion.enabled=true", "adhesion.force=2", "rolling.coefficient=0.005",
                                   "rolling.stiffness_ratio=1e-3", "analysis.zero_force=1e-3"}));
  REQUIRE_NOTHROW(build(good, {"box.periodic=false", "box.lengths=[4.2, 4.2, 4.2]", "gravity.enabled=true",
                               "gravity.softening=0.2", "analysis.every=10"}));
  // A count where the particles are listed (or read from a file) was ignored without a word.
  REQUIRE_THROWS_WITH(build(good, {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[2,0,0]]", "box.periodic=false"}),
                      Contains("particles.count: value 27, but particles.positions lists 2 particles: give 2 or "
                               "leave the count out"));
  REQUIRE_NOTHROW(build(good, {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[2,0,0]]", "box.periodic=false",
                               "particles.count=2"}));
  // A softening length whose square overflows gave non-finite forces, blamed on the initial state.
  REQUIRE_THROWS_WITH(build(good, {"box.periodic=false", "box.lengths=[4.2, 4.2, 4.2]", "gravity.enabled=true",
                                   "gravity.softening=1e160"}),
                      Contains("gravity.softening: value 1e+160 makes the softening length") && Contains("must not exceed 1e100"));

  // The barostat's keys without the barostat, cell.enabled absent or false.
  REQUIRE_THROWS_WITH(build(good, {"cell.pressure_final=2", "cell.ramp_duration=10"}),
                      Contains("cell.pressure_final: value 2 is not used with cell.enabled = false: it needs "
                               "cell.enabled = true") &&
                          Contains("cell.ramp_duration: value 10 is not used with cell.enabled = false"));
  REQUIRE_THROWS_WITH(build(good + "[cell]\nenabled = false\npressure = 0.5\n"),
                      Contains("cell.pressure: value 0.5 is not used with cell.enabled = false"));
  REQUIRE_THROWS_WITH(build(good, {"cell.restart_cvode_every_step=true"}),
                      Contains("cell.restart_cvode_every_step: value true is not used with cell.enabled = false"));
  REQUIRE_NOTHROW(build(good, {"cell.enabled=false"}));
  REQUIRE_NOTHROW(build(good, {"cell.enabled=true", "cell.force_unit=1", "cell.pressure=0.5", "cell.pressure_final=2",
                               "cell.ramp_duration=10"}));

  // Each of these would be accepted without a word: the tree's opening angle with direct
  // summation, a programme without a cell, one diameter for drawn sizes.
  const std::vector<std::string> open_gravity = {"box.periodic=false", "box.lengths=[4.2, 4.2, 4.2]", "gravity.enabled=true"};
  auto plus = [&](std::string extra) { auto v = open_gravity; v.push_back(std::move(extra)); return v; };
  REQUIRE_THROWS_WITH(build(good, plus("gravity.opening_angle=1.2")),
                      Contains("gravity.opening_angle: value 1.2 is not used with gravity.solver = \"direct\": it needs "
                               "gravity.solver = \"tree\""));
  REQUIRE_NOTHROW(build(good, {"box.periodic=false", "box.lengths=[4.2, 4.2, 4.2]", "gravity.enabled=true",
                               "gravity.solver=\"tree\"", "gravity.opening_angle=1.2"}));
  REQUIRE_THROWS_WITH(build(good, {"programme.stage_budget=5"}),
                      Contains("programme.stage_budget: value 5 is not used with cell.enabled = false: it needs "
                               "cell.enabled = true"));
  REQUIRE_THROWS_WITH(build(good, {"particles.size_distribution=\"uniform\"", "particles.diameter_min=0.5",
                                   "particles.diameter=0.7"}),
                      Contains("particles.diameter: value 0.7 is not used with particles.size_distribution = \"uniform\""));
}

TEST_CASE("scene errors: the quench's rolling dashpot without the consolidation law is refused", "[scene][errors]") {
  // The programme sets it to 0 under the linear law: programme.quench_damping = 0.5 was ignored without a word.
  REQUIRE_THROWS_WITH(build(good, {"cell.enabled=true", "programme.quench_damping=0.5"}),
                      Contains("programme.quench_damping: value 0.5 is not used with adhesion.enabled = false: it needs "
                               "adhesion.enabled = true"));
  REQUIRE_NOTHROW(build(good, {"cell.enabled=true", "cell.force_unit=1", "programme.quench_drag=0.5"}));   // any law
}

TEST_CASE("scene errors: a cell without adhesion names its force unit", "[scene][errors][units]") {
  // It was 1 by default, a force in whatever units the scene is written: the same scene with forces x 1e-15
  // asked each contact for 1e11 times its clamped force, and CVODE failed.
  REQUIRE_THROWS_WITH(build(good, {"cell.enabled=true", "cell.pressure=0.01"}),
                      Contains("cell.force_unit: missing: without adhesion, give the force unit of P* in the scene's "
                               "units, a value > 0") && Contains("or 0 (P* = P a^(D-2) / k_n)"));
  REQUIRE_NOTHROW(build(good, {"cell.enabled=true", "cell.force_unit=1", "cell.pressure=0.01"}));
  REQUIRE_NOTHROW(build(good, {"cell.enabled=true", "cell.force_unit=0", "cell.pressure=0.01"}));
  // A subnormal unit overflows P* and the time unit to inf, which would reach the outputs.
  REQUIRE_THROWS_WITH(build(good, {"cell.enabled=true", "cell.force_unit=1e-320", "cell.pressure=0.01"}),
                      Contains("cell.force_unit: value 9.99989e-321 as the force unit of P* is below the smallest normal "
                               "double") && Contains("allowed 0 (cohesionless) or at least 2.22507e-308"));
}

TEST_CASE("scene errors: a key another given key replaces is warned about, not refused, and not resolved", "[scene][errors]") {
  // An override cannot remove the scene's own key, so refusing would forbid --set time.dt on a scene that
  // gives steps per contact (and the FMUs' hosts the same); instead the warning names both, and grains check's
  // resolved scene leaves the replaced key out.
  const Scene scene = Scene::from_string(good, "s.toml", {"time.steps_per_contact=20", "time.dt=0.001",
                                                          "particles.density=5", "particles.mass=2", "box.lengths=[6, 6, 6]"});
  const auto sim = Simulation::create(scene);
  const auto& w = sim->warnings();
  auto warned = [&](const std::string& text) {
    return std::any_of(w.begin(), w.end(), [&](const std::string& m) { return m.find(text) != std::string::npos; });
  };
  CHECK(warned("time.steps_per_contact = 20 is not used: time.dt = 0.001 is given and takes its place"));
  CHECK(warned("particles.density = 5 is not used: particles.mass = 2 is given"));
  CHECK(warned("particles.solid_fraction = 0.2 is not used: box.lengths = [ 6, 6, 6 ] is given"));
  const std::string resolved = scene.resolved_toml();
  for (const char* replaced : {"steps_per_contact", "density", "solid_fraction"}) CHECK(resolved.find(replaced) == std::string::npos);
  CHECK(sim->dt() == 0.001);
  CHECK(sim->particles().mass[0] == 2.0);
  // The resolved scene builds alike, without the warnings.
  CHECK(Simulation::create(Scene::from_string(resolved, "resolved.toml"))->warnings().empty());
}

TEST_CASE("scene errors: drawn or listed velocities in place of a particle file's velocity columns are warned about",
          "[scene][errors]") {
  // velocity = "gaussian" replaced the file's columns without a word; "zero" (the default) takes them.
  const auto path = std::filesystem::temp_directory_path() / "grains-moving-rows.txt";
  {
    std::ofstream f(path);
    f << "0 0 0 1 1 0.5 0 0\n3 0 0 1 1 -0.5 0 0\n";
  }
  const std::vector<std::string> file = {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                         "box.periodic=false"};
  const auto kept = Simulation::create(Scene::from_string(good_uncounted, "s.toml", file));
  CHECK(kept->warnings().empty());
  CHECK(kept->particles().velocity[0] == 0.5);
  auto drawn = file;
  drawn.push_back("particles.velocity=\"gaussian\"");
  const auto replaced = Simulation::create(Scene::from_string(good_uncounted, "s.toml", drawn));
  REQUIRE(replaced->warnings().size() == 1);
  CHECK_THAT(replaced->warnings()[0], Contains("the velocity columns of particles.file") && Contains("grains-moving-rows.txt") &&
                                          Contains("particles.velocity = \"gaussian\" takes their place"));
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: a particle file's spin columns spin the grains, in one place only", "[scene][errors]") {
  // A spinning body of many grains takes its spins from its file, not only from the scene's text, one row per grain.
  const auto path = std::filesystem::temp_directory_path() / "grains-spinning-rows.txt";
  {
    std::ofstream f(path);
    f << "# x y z diameter mass vx vy vz wx wy wz\n0 0 0 1 1 0.5 0 0 0 0 2\n3 0 0 1 1 -0.5 0 0 1 0 0\n";
  }
  const std::vector<std::string> file = {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                         "box.periodic=false"};
  const auto sim = Simulation::create(Scene::from_string(good_uncounted, "s.toml", file));
  CHECK(sim->particles().velocity[3] == -0.5);   // flat: x y z of each particle in turn
  CHECK(sim->particles().angular_velocity[2] == 2.0);
  CHECK(sim->particles().angular_velocity[3] == 1.0);
  auto twice = file;
  twice.push_back("particles.angular_velocities=[[0,0,1],[0,0,1]]");
  REQUIRE_THROWS_WITH(build(good_uncounted, twice), Contains("particles.angular_velocities") && Contains("gives spins too") &&
                                                          Contains("in one place"));
  {
    std::ofstream f(path);
    f << "0 0 0 1 1 0.5 0 0 0 0 2 9\n";   // 12 columns: none of the forms
  }
  REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("12 columns; expected 5 (x.. diameter mass), 8 (with velocity) or "
                                                            "11 (with velocity and spin wx wy wz)"));
  {
    std::ofstream f(path);
    f << "0 0 0 1 1 0 0 0 1e200 0 0\n";   // a spin whose energy overflows, named by its line
  }
  REQUIRE_THROWS_WITH(build(good_uncounted, file), Contains("grains-spinning-rows.txt:1") && Contains("rotational energy"));
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: a wrong type is told the allowed values too", "[scene][errors]") {
  // An integer key said its range; a number, string or array key said only the type it expected.
  REQUIRE_THROWS_WITH(build(good, {"contact.restitution=\"high\""}),
                      Contains("contact.restitution: expected a number, got \"high\": allowed number in (0, 1]"));
  REQUIRE_THROWS_WITH(build(with("layout = \"lattice\"", "layout = 3")),
                      Contains("particles.layout: expected a string, got 3: allowed string, one of lattice, random, list, file"));
  REQUIRE_THROWS_WITH(build(good, {"box.lengths=4"}),
                      Contains("box.lengths: expected an array of numbers, got 4: allowed array of numbers in (0, inf)"));
  REQUIRE_THROWS_WITH(build(good, {"box.lengths=[4, \"4\", 4]"}),
                      Contains("box.lengths: element 1 is \"4\", expected a number: allowed array of numbers in (0, inf)"));
  // A key without bounds still takes finite numbers only, and says so (it said "allowed array of numbers").
  REQUIRE_THROWS_WITH(build(good, {"box.lower=[inf, 0, 0]"}),
                      Contains("box.lower: element 0 = inf is out of range: allowed array of numbers in (-inf, inf)"));
}

TEST_CASE("scene errors: a number TOML cannot hold, written in the scene file, names its key and the range", "[scene][errors]") {
  // The scene file's 2^63 or 1e400 was a bare "TOML syntax error" naming neither the key nor what it allows.
  CHECK_THAT(build_error(with("count = 27", "count = 99999999999999999999")),
             Contains("bad.toml:6: particles.count: value 99999999999999999999 is out of range: allowed integer in [1, 1000000000]"));
  CHECK_THAT(build_error(with("count = 27", "count = -99999999999999999999  # comment")),
             Contains("particles.count: value -99999999999999999999 is out of range"));
  CHECK_THAT(build_error(with("duration = 0.05", "duration = 1e-400")),
             Contains("bad.toml:10: contact.duration: value 1e-400 is beyond a double's range") &&
                 Contains("allowed number in (0, inf)"));
  CHECK_THAT(build_error(good + "[box]\nlengths = [4, 1e999, 4]\n"),
             Contains("box.lengths: value 1e999 is beyond a double's range"));
  CHECK_THAT(build_error(with("duration = 0.05", "duration = 9223372036854775808")),
             Contains("contact.duration: value 9223372036854775808 is too long for a TOML integer: write it with an exponent"));
  // The same through --set, and a syntax error that is not a number stays one.
  REQUIRE_THROWS_WITH(build(good, {"contact.duration=9223372036854775808"}), Contains("too long for a TOML integer"));
  CHECK_THAT(build_error(good + "[box]\nunknown = 1e999\n"), Contains("TOML syntax error"));
}

TEST_CASE("scene errors: a particle file's columns and listed sizes or masses replace the size and mass keys, with a warning",
          "[scene][errors]") {
  // particles.mass, density, diameter and the size distribution beside a particle file (or beside listed
  // diameters and masses) were ignored without a word, and grains check's resolved scene listed them as read.
  const auto path = std::filesystem::temp_directory_path() / "grains-replacing-rows.txt";
  {
    std::ofstream f(path);
    f << "0 0 0 1 2\n3 0 0 1 2\n";
  }
  const Scene from_file = Scene::from_string(
      good_uncounted, "s.toml", {"particles.layout=\"file\"", fmt::format("particles.file=\"{}\"", path.string()),
                                 "box.periodic=false", "particles.mass=5", "particles.density=3",
                                 "particles.size_distribution=\"uniform\"", "particles.diameter_max=0.7"});
  const auto sim = Simulation::create(from_file);
  const auto& w = sim->warnings();
  auto warned = [&](const std::string& text) {
    return std::any_of(w.begin(), w.end(), [&](const std::string& m) { return m.find(text) != std::string::npos; });
  };
  for (const char* key : {"particles.mass = 5", "particles.density = 3", "particles.size_distribution = \"uniform\"",
                          "particles.diameter_max = 0.7"})
    CHECK(warned(fmt::format("{} is not used: particles.file = \"{}\" is given and takes its place", key, path.string())));
  CHECK(sim->particles().mass[0] == 2.0);
  const std::string resolved = from_file.resolved_toml();
  for (const char* replaced : {"mass =", "density", "diameter", "size_distribution"}) CHECK(resolved.find(replaced) == std::string::npos);

  const Scene listed = Scene::from_string(
      good_uncounted, "s.toml", {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[3,0,0]]", "box.periodic=false",
                                 "particles.diameters=[1, 0.8]", "particles.masses=[1, 2]", "particles.diameter=0.5",
                                 "particles.mass=5"});
  const auto listed_sim = Simulation::create(listed);
  CHECK_THAT(fmt::format("{}", fmt::join(listed_sim->warnings(), "\n")),
             Contains("particles.diameter = 0.5 is not used: particles.diameters = [ 1, 0.8 ] is given") &&
                 Contains("particles.mass = 5 is not used: particles.masses = [ 1, 2 ] is given"));
  CHECK(listed_sim->particles().mass[1] == 2.0);
  std::filesystem::remove(path);
}

TEST_CASE("scene errors: sizes, masses and solid fractions the engine cannot hold are refused naming the key", "[scene][errors]") {
  // The schema said (0, inf) for sizes and masses, but the engine refused those beyond [1e-100, 1e100] and
  // [1e-150, 1e150]: the reference now gives these ranges.
  REQUIRE_THROWS_WITH(build(good, {"particles.diameter=1e-101"}),
                      Contains("particles.diameter: value 1e-101 is out of range: allowed number in [1e-100, 1e+100]"));
  REQUIRE_THROWS_WITH(build(good, {"particles.mass=1e151"}),
                      Contains("particles.mass: value 1e+151 is out of range: allowed number in [1e-150, 1e+150]"));
  REQUIRE_NOTHROW(build(good, {"particles.diameter=1e-100", "particles.mass=1"}));
  // A solid fraction in (0, 1) whose box volume overflows ran into a non-finite position at the first step.
  REQUIRE_THROWS_WITH(build(good, {"particles.solid_fraction=1e-309"}),
                      Contains("particles.solid_fraction: value 1e-309 makes the box's volume") && Contains("overflow"));
}

TEST_CASE("scene errors: defaults are never refused as unread, and the resolved scene lists only the keys it reads",
          "[scene][errors]") {
  REQUIRE_NOTHROW(build(good));
  // resolved_toml() writes every key the scene reads, defaults included (grains check prints it, a checkpoint
  // stores it), and leaves out the defaults it does not read: it builds as it is.
  const std::string resolved = Scene::from_string(good, "good.toml").resolved_toml();
  CHECK(resolved.find("kinetic_energy") == std::string::npos);
  CHECK(resolved.find("diameter_min") == std::string::npos);
  CHECK(resolved.find("restitution") != std::string::npos);
  REQUIRE_NOTHROW(build(resolved));
  // A stored scene of an earlier build listed every key: resume accepts it.
  Scene stored = Scene::from_string(resolved, "stored");
  stored.set_value("particles.kinetic_energy", "1.5");
  REQUIRE_THROWS_WITH(Scene(stored).validate(), Contains("particles.kinetic_energy: value 1.5 is not used"));
  stored.accept_unread_keys();
  REQUIRE_NOTHROW(Simulation::create(stored));
}

TEST_CASE("scene errors: an integer just past its bound is refused, not rounded onto it", "[scene][errors]") {
  // As a double 9200000000000000001 is 9.2e18, the bound itself.
  REQUIRE_NOTHROW(build(good, {"particles.seed=9200000000000000000"}));
  REQUIRE_THROWS_WITH(build(good, {"particles.seed=9200000000000000001"}),
                      Contains("particles.seed") && Contains("9200000000000000001 is out of range"));
  REQUIRE_THROWS_WITH(build(good, {"output.observables_every=0"}), Contains("output.observables_every") && Contains("out of range"));
}

TEST_CASE("scene errors: a spin of the wrong width names the form the dimension needs", "[scene][errors]") {
  const std::string pair = R"(
[scene]
dimension = 2
[particles]
layout = "list"
positions = [[1.0, 1.0], [3.0, 1.0]]
diameter = 1.0
mass = 1.0
angular_velocities = [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
[box]
lengths = [10.0, 10.0]
[contact]
restitution = 0.5
duration = 0.1
)";
  REQUIRE_THROWS_WITH(build(pair), Contains("particles.angular_velocities: row 0 has 3 components; a 2D scene needs 1 ([w]"));
}
