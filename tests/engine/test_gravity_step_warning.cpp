// The gravity time-step rule (physics.md section 3): a step above T_orb / 20, T_orb the circular orbit
// of the two heaviest particles at their closest approach, is warned about with both numbers. The closest
// approach is the contact distance 2 R_min only when the capped contact force k_n delta_max exceeds the pull
// of the whole mass at contact distance, G m_max M / (2 R_min)^2; otherwise (or without contacts) it is the
// softened centre, d = 0.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Matchers::Contains;

namespace {

// Three particles of masses 1, 3, 2 (the heaviest pair: 5; M = 6) and diameters 0.2, 0.1, 0.2 (R_min = 0.05);
// eps = 0.5 R_min = 0.025. The pull bound G m_max M / (2 R_min)^2 = 2 * 3 * 6 / 0.01 = 3600.
std::string scene(const std::string& contact, double dt) {
  return fmt::format(R"(
[particles]
layout = "list"
positions = [[0, 0, 0], [2, 0, 0], [0, 2, 0]]
diameters = [0.2, 0.1, 0.2]
masses = [1.0, 3.0, 2.0]
[box]
periodic = false
[contact]
{}
[gravity]
enabled = true
G = 2.0
softening = 0.5
[time]
dt = {:.17g}
[run]
threads = 1
)", contact, dt);
}

// The warnings that name the orbit.
std::vector<std::string> orbit_warnings(const Simulation& sim) {
  std::vector<std::string> found;
  for (const auto& w : sim.warnings())
    if (w.find("T_orb") != std::string::npos) found.push_back(w);
  return found;
}

}  // namespace

TEST_CASE("gravity step rule: warns past T_orb / 20 and names both numbers", "[gravity]") {
  const double pi = std::acos(-1.0), eps = 0.025, G = 2.0, M = 5.0;
  // Soft contacts (t_c = 1: k_n ~ 6.6, capped force ~ 0.03, far below 3600) cannot keep grains apart; stiff
  // ones (t_c = 1e-3: k_n ~ 6.6e6, capped force ~ 3.3e4) can. Their step, far above t_c / 20, also draws the
  // contact rules' warnings: only the orbit's is looked at.
  struct Case {
    const char* contact;
    double d;
    const char* why;
  };
  for (const Case& c : {Case{"enabled = false", 0.0, "no contacts"},
                        Case{"enabled = true\nduration = 1.0", 0.0, "cannot keep grains apart"},
                        Case{"enabled = true\nduration = 1e-3", 0.1, "contacts keep grains apart"}}) {
    const double orbit = 2 * pi * std::sqrt(std::pow(c.d * c.d + eps * eps, 1.5) / (G * M));
    INFO(c.contact << ": T_orb " << orbit);
    auto below = Simulation::create(Scene::from_string(scene(c.contact, orbit / 21), "below"));
    CHECK(orbit_warnings(*below).empty());
    auto past = Simulation::create(Scene::from_string(scene(c.contact, orbit / 19), "past"));
    const auto warned = orbit_warnings(*past);
    REQUIRE(warned.size() == 1);
    CHECK_THAT(warned[0], Contains(fmt::format("{:.6g}", orbit / 19)) && Contains(fmt::format("{:.6g}", orbit / 20)) &&
                              Contains(fmt::format("d = {:.6g}", c.d)) && Contains(c.why));
  }
  // The scene without contacts or with soft ones warns of nothing else.
  CHECK(Simulation::create(Scene::from_string(scene("enabled = false", 1e-4), "quiet"))->warnings().empty());
  CHECK(Simulation::create(Scene::from_string(scene("enabled = true\nduration = 1.0", 1e-4), "quiet"))->warnings().empty());
}

TEST_CASE("gravity step rule: unsoftened gravity without contacts is warned about, with contacts it is not",
          "[gravity]") {
  // With softening 0 the rule's closest approach d = 0 has no orbit to resolve, and a cloud whose grains meet at
  // softening 0 gains 101 % energy by step 200.
  const auto unsoftened = [](const std::string& contact) {
    std::string text = scene(contact, 1e-4);
    text.replace(text.find("softening = 0.5"), 15, "softening = 0.0");
    return Simulation::create(Scene::from_string(text, "unsoftened"));
  };
  const auto said = [](const Simulation& s) {
    long n = 0;
    for (const auto& w : s.warnings()) n += w.starts_with("gravity.softening = 0 with ");
    return n;
  };
  auto none = unsoftened("enabled = false"), soft = unsoftened("restitution = 0.5\nduration = 1.0");
  auto stiff = unsoftened("restitution = 0.5\nduration = 1e-3");
  CHECK(said(*none) == 1);
  CHECK_THAT(none->warnings().back(), Contains("with no contacts") && Contains("give gravity.softening > 0"));
  // With contacts, even ones the rule counts as not holding grains apart (the whole cloud's pull on one grain, the
  // usual case): the aggregation scene at softening 0 runs sound: not warned.
  CHECK(said(*soft) == 0);
  CHECK(said(*stiff) == 0);
}
