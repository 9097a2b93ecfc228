// The scene of a small type-1 programme, the first stage only: `count` disks under the paper's type-1 law
// (Table I, mu = 0.5, no rolling resistance), shared by the quench and programme tests (the contact tests'
// packings: packing_scenes.hpp).
#pragma once
#include <fmt/format.h>

#include "io/scene.hpp"
#include "polydisperse_particles.hpp"

namespace grains {

inline Scene type1_packing(int count, int seed, double drag, double damping, long budget) {
  return Scene::from_string(polydisperse_particles(2, count, 0.36, seed, "density = 1.273239544735163\nvelocity = \"zero\"\n") + fmt::format(R"(
[box]
periodic = true
[contact]
overlap_limit = 0.5
[adhesion]
enabled = true
force = 1.0
range = 1e-3
stiffness = 1e5
restitution = 0.015
[friction]
coefficient = 0.5
[cell]
enabled = true
pressure = 0.01
contact_damping = 0.0
[programme]
preparation = "type1"
load = false
unload = false
stage_budget = {}
quench_drag = {}
quench_damping = {}
[run]
threads = 1
)", budget, drag, damping), "quench");
}

}  // namespace grains
