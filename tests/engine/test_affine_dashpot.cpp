// In a deforming cell, particle velocities are relative to the affine flow; the contact dashpots
// must still feel the flow's relative velocity strain_rate (*) r_ij, or a cell under compression
// squeezes its contacts without any damping.
#include <catch2/catch.hpp>

#include "analysis/stress.hpp"
#include "core/system.hpp"
#include "interactions/contact_forces.hpp"

using namespace grains;

TEST_CASE("a square lattice at rest in a compressing cell feels the dashpots of the affine flow", "[stress][barostat]") {
  const int n = 4;
  const double spacing = 0.98, diameter = 1.0, k = 1e4, c = 30.0, delta = diameter - spacing;
  const Vec<2> rate(-0.2, 0.05);   // (dL/dt) / L per axis: x compressing, y expanding
  for (bool friction_on : {false, true}) {
    System<2> s;
    s.particles.resize(n * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        s.particles.position[i * n + j] = Vec<2>((i + 0.5) * spacing, (j + 0.5) * spacing);
        s.particles.set_mass_and_radius(i * n + j, 1.0, 0.5 * diameter);
      }
    s.box.length = Vec<2>(n * spacing, n * spacing);
    s.box.periodic.fill(true);
    s.neighbours.configure(0.0, 0.1);
    s.neighbours.build(s.particles.position, s.particles.radius, s.box, 1);
    s.want_virial = true;
    s.affine_flow = true;
    s.strain_rate = rate;
    s.dt = 0;   // not a contact's first step: the overlap "before" equals the overlap now
    const LinearContactLaw<false> law{k, c, 1.0};
    if (friction_on) ContactForces<2, LinearContactLaw<false>, CoulombFriction>(law, {0.5, 1.0, 1.0, false}).add_forces(s);
    else ContactForces<2, LinearContactLaw<false>, NoFriction>(law, {}).add_forces(s);
    // Each axis-aligned contact has v_n = rate_a * spacing: F_n = k delta - c rate_a spacing;
    // stress_aa = F_n / spacing (one contact per particle per axis, area spacing^2 per particle).
    const Tensor<2> sigma = contact_stress<2>(s.virial, s.box.volume());
    for (int a = 0; a < 2; ++a) CHECK(sigma(a, a) == Approx((k * delta - c * rate[a] * spacing) / spacing).epsilon(1e-12));
    // The flow is normal to every contact of the lattice: no tangential force, no shear stress.
    CHECK(std::abs(sigma(0, 1)) < 1e-9 * sigma(0, 0));
    for (const auto& f : s.particles.force) CHECK(f.norm() < 1e-9 * k * delta);
  }
}
