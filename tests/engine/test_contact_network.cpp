// Contact-network statistics on constructed configurations, directly and through the Simulation outputs.
#include <catch2/catch.hpp>
#include <cmath>

#include "adhesive_scene.hpp"
#include "analysis/contact_network.hpp"
#include "analysis/yielding_contacts.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;

TEST_CASE("contact network: coordination split, rattlers, distant bonds and force histogram", "[network]") {
  // Five grains: a compressive, a tensile and a zero-force contact, one distant bond; grain 4 is alone.
  const std::vector<NetworkInteraction> list = {
      {0, 1, -1e-5, 2.0}, {1, 2, -1e-5, -0.5}, {2, 3, 5e-4, -0.5}, {0, 2, -1e-5, 0.0}};
  ContactNetworkOptions opt;
  opt.zero_force = 1e-5;
  const ContactNetwork net = analyse_contact_network(5, list, opt);
  CHECK(net.contacts == 3);
  CHECK(net.distant_bonds == 1);
  CHECK(net.z == Approx(8.0 / 5));
  CHECK(net.z_plus == Approx(2.0 / 5));
  CHECK(net.z_minus == Approx(4.0 / 5));
  CHECK(net.z_zero == Approx(2.0 / 5));
  CHECK(net.rattler_fraction == Approx(1.0 / 5));   // grain 4 (grain 0 carries the compressive contact)
  CHECK(net.z_star == Approx(2.0));
  REQUIRE(net.histogram.size() == 21);
  CHECK(net.histogram[1] == 0.5);    // F / F0 = -0.5, twice, in [-0.5, 0)
  CHECK(net.histogram[2] == 0.25);   // 0 in [0, 0.5)
  CHECK(net.histogram[6] == 0.25);   // 2 in [2, 2.5)

  // Only zero-force interactions: every grain rattles, unless bonds hold (adhesion), where only a grain with no
  // interaction does.
  const auto idle = analyse_contact_network(2, {{0, 1, -1e-5, 1e-7}}, opt);
  CHECK(idle.rattler_fraction == 1.0);
  CHECK(std::isnan(idle.z_star));
  CHECK(idle.z_zero == 1.0);
  ContactNetworkOptions bonds = opt;
  bonds.bonds_hold = true;
  const auto held = analyse_contact_network(3, {{0, 1, -1e-5, 1e-7}}, bonds);
  CHECK(held.rattler_fraction == Approx(1.0 / 3));
  CHECK(held.z_star == Approx(1.0));
  CHECK(analyse_contact_network(5, list, bonds).rattler_fraction == Approx(1.0 / 5));   // grain 4 all the same
  // Forces beyond the top edge, and below the bottom one, land in the end bins.
  const auto wide = analyse_contact_network(2, {{0, 1, -1e-5, 50.0}, {0, 1, -1e-5, -3.0}}, opt);
  CHECK(wide.histogram[20] == 0.5);
  CHECK(wide.histogram[0] == 0.5);
}

TEST_CASE("contacts kept, lost and gained between two states", "[network]") {
  const auto before = contact_keys({{0, 1, -1e-5, 1}, {2, 1, -1e-5, 1}, {3, 4, 1e-4, -0.9}});   // (3,4) is not a contact
  const auto now = contact_keys({{1, 2, -1e-5, 1}, {2, 3, -1e-5, 1}, {4, 0, -1e-5, 1}});
  const auto ch = compare_contacts(before, now);
  CHECK(ch.kept == 1);
  CHECK(ch.lost == 1);
  CHECK(ch.gained == 2);
}

namespace {
// Four unit grains on the x axis: 0-1 overlapping by delta = F0 / K_N (the defaults' equilibrium overlap),
// 1-2 at a gap of half the attraction range D0, grain 3 far away.
ListedParticles chain_of_four() {
  const double delta = 1e-5, D0 = 1e-3;
  ListedParticles p;
  p.positions = {{0, 0}, {1 - delta, 0}, {2 - delta + 0.5 * D0, 0}, {10, 0}};
  p.velocities = {{0, 0}, {0, 0}, {0, 0}, {0, 0}};
  p.diameters = {1, 1, 1, 1};
  p.masses = {1, 1, 1, 1};
  return p;
}
}  // namespace

TEST_CASE("the Simulation reports the contact network of an adhesion scene", "[network][adhesion]") {
  // Grains 0-1 bonded at rest at the equilibrium overlap (zero force), 1-2 across half the attraction
  // range (tension F0 / 2), grain 3 far away.
  const ListedParticles p = chain_of_four();
  auto s = Simulation::create(Scene::from_string(adhesive_scene(2, p), "network"));
  CHECK(s->get("coordination") == Approx(1.0));
  CHECK(s->get("coordination_zero") == Approx(0.5));
  CHECK(s->get("coordination_tensile") == Approx(0.5));
  CHECK(s->get("coordination_compressive") == 0);
  // Grain 3 alone is a rattler: grain 0's bond at zero force still holds it (the paper's cohesive samples have none;
  // counting grain 0 too would give x0 = 0.5)
  CHECK(s->get("rattler_fraction") == Approx(0.25));
  CHECK(s->get("backbone_coordination") == Approx(4.0 / 3));
  CHECK(s->get("distant_bonds") == 1);
  // -0.5 F0 in [-0.5, 0); the zero force sits on the edge at 0, within round-off on either side.
  CHECK(s->get("force_histogram_01") >= 0.5);
  CHECK(s->get("force_histogram_01") + s->get("force_histogram_02") == 1.0);
  CHECK(s->get("force_histogram_00") + s->get("force_histogram_03") == 0.0);
  CHECK(s->get("contacts_kept") == 1);          // against the initial state
  // The bond pulls 2 onto 1: a contact is gained; a new mark makes the present the reference.
  s->step(0.5);
  CHECK(s->get("contacts_gained") == 1);
  CHECK(s->get("contacts_kept") == 1);
  s->set("network.mark", 1);
  CHECK(s->get("contacts_gained") == 0);
  CHECK(s->get("contacts_kept") == 2);
  // The reference is part of the state.
  const auto saved = s->save_state();
  auto t = Simulation::create(Scene::from_string(adhesive_scene(2, p), "network"));
  t->restore_state(saved);
  CHECK(t->get("contacts_kept") == 2);
  CHECK(t->get("network.mark") == 1);
}

TEST_CASE("the contact network carries the force the clamped law applies", "[network][adhesion]") {
  // Two unit disks overlapping by 1e-3 where the clamp holds the overlap at f_max R = 1e-4 * 0.5: the law applies
  // K_N 5e-5 - F0 = 4 F0, which the network must report, not the raw overlap's 99 F0.
  ListedParticles p;
  p.positions = {{0, 0}, {0.999, 0}};
  p.velocities = {{0, 0}, {0, 0}};
  p.diameters = {1, 1};
  p.masses = {1, 1};
  auto s = Simulation::create(Scene::from_string(adhesive_scene(2, p, "[contact]\noverlap_limit = 1e-4\n"), "clamped pair"));
  // bins of F0 / 2 from -F0: 4 F0 falls in bin 10
  CHECK(s->get("force_histogram_10") == 1.0);
  CHECK(s->get("force_histogram_20") == 0.0);
  CHECK(s->get("coordination_compressive") == Approx(1.0));
}

TEST_CASE("without an adhesion force a pair within D0 of contact is no distant bond", "[network][adhesion]") {
  // The same chain with F0 = 0 (the cohesionless reference): 0-1 in contact, 1-2 at a gap of D0 / 2, which
  // attracts nothing, so it must not count in z and z0 as a distant bond.
  auto s = Simulation::create(Scene::from_string(adhesive_scene(2, chain_of_four(), "force = 0.0\n"), "cohesionless network"));
  CHECK(s->get("distant_bonds") == 0);
  CHECK(s->get("coordination") == Approx(0.5));   // one contact among four grains
  CHECK(s->get("coordination_compressive") == Approx(0.5));
  CHECK(s->get("coordination_zero") == 0);
  CHECK(s->get("rattler_fraction") == Approx(0.5));
  CHECK(s->get("backbone_coordination") == Approx(1.0));
}

TEST_CASE("contacts at the friction and rolling bounds, counted from constructed springs", "[network]") {
  auto spring = [](double tangential_ratio, double rolling_ratio) {
    ElasticSpring<2> e;
    e.tangential = e.rolling = 1;
    e.tangential_bound = 0.5, e.rolling_bound = 0.005;
    e.tangential_force = tangential_ratio * e.tangential_bound, e.rolling_moment = rolling_ratio * e.rolling_bound;
    return e;
  };
  // At the bound to rounding (a contact that slid and stopped), just inside the tolerance, and inside the cone.
  const std::vector<ElasticSpring<2>> springs{spring(1.0, 0.5), spring(1 - 1e-7, 1.0), spring(0.999, 0.0)};
  const YieldingContacts y = yielding_contacts<2>(springs);
  CHECK(y.sliding == Approx(2.0 / 3.0));
  CHECK(y.rolling == Approx(1.0 / 3.0));
  // A distant bond has neither spring, and a contact without rolling resistance no rolling spring.
  ElasticSpring<2> bond;
  const YieldingContacts none = yielding_contacts<2>(std::vector<ElasticSpring<2>>{bond});
  CHECK(std::isnan(none.sliding));
  CHECK(std::isnan(none.rolling));
}

TEST_CASE("the Simulation reports contacts at their friction and rolling bounds", "[network][adhesion][rolling]") {
  // Two unit-mass grains bonded at rest at the equilibrium overlap F0 / K_N: no spring is loaded.
  ListedParticles p;
  p.positions = {{0, 0}, {1 - 1e-5, 0}};
  p.velocities = {{0, 0}, {0, 0}};
  p.diameters = {1, 1};
  p.masses = {1, 1};
  const std::string laws = "[friction]\ncoefficient = 0.5\n[rolling]\ncoefficient = 0.005\n";
  auto rest = Simulation::create(Scene::from_string(adhesive_scene(2, p, laws), "at rest"));
  CHECK(rest->get("contacts_at_friction_bound") == 0);
  CHECK(rest->get("contacts_at_rolling_bound") == 0);
  // Grain 1 spinning at 1 / T0: the tangential spring reaches mu F0 within 1e-5 T0 and the rolling spring
  // mu_R F0 within 5e-4 T0, while the friction slows the relative spin by about 4 / T0 per T0: both slide.
  auto spinning = Simulation::create(Scene::from_string(adhesive_scene(2, p, laws, "angular_velocities = [[0], [1]]"), "spinning"));
  spinning->step(0.01);
  CHECK(spinning->get("contacts_at_friction_bound") == 1);
  CHECK(spinning->get("contacts_at_rolling_bound") == 1);
  // Without friction and rolling resistance there is no spring to be at a bound.
  auto frictionless = Simulation::create(Scene::from_string(adhesive_scene(2, p), "frictionless"));
  CHECK(std::isnan(frictionless->get("contacts_at_friction_bound")));
  CHECK(std::isnan(frictionless->get("contacts_at_rolling_bound")));
}
