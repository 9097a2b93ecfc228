// Everything a force module may read or write during one step.
#pragma once
#include "core/box.hpp"
#include "core/particles.hpp"
#include "core/pending_kick.hpp"
#include "neighbours/neighbour_list.hpp"
#include "neighbours/shell_list.hpp"

namespace grains {

template <int D>
struct System {
  Particles<D> particles;
  Box<D> box;
  NeighbourList<D> neighbours;
  ShellList<D> shell;   // the listed pairs near contact, which the pair loops test (when built)
  double time = 0, dt = 0;   // dt: length of the step being taken (0 for the initial force evaluation)
  double first_step = 0;     // at the initial evaluation: the step to come, whose first half kick alone charges its forces
  long step = 0;
  int threads = 1;
  // Per-thread force/torque buffers, reused across steps: a pair loop's thread adds its own particles'
  // shares straight into the particles' arrays and those of partners beyond them into its slot (the last
  // thread has no partners beyond, and an empty slot).
  std::vector<std::vector<Vec<D>>> thread_force;
  std::vector<std::vector<Spin<D>>> thread_torque;
  // Contact virial W = sum over pairs of F_ij (x) r_ij (F_ij: force on j, r_ij = x_j - x_i): the contact
  // stress is W / V. Pair loops accumulate it only while want_virial is set (the barostat while the cell
  // moves, the stress observables after a run), so steps whose stress nobody reads pay nothing.
  bool want_virial = false;
  // While the cell deforms, particles ride the affine flow x_a -> lower_a + (x_a - lower_a) * cell_scale_a
  // over the step, and their stored velocities are relative to it. A pair's dashpots must still see
  // the relative velocity the flow imposes, strain_rate (*) r_ij (per axis, (dL/dt) / L at step end).
  bool affine_flow = false;
  Vec<D> strain_rate = Vec<D>::Zero();
  Vec<D> cell_scale = Vec<D>::Ones();   // L(t + dt) / L(t) of the step being taken
  Eigen::Matrix<double, D, D> virial = Eigen::Matrix<double, D, D>::Zero();
  // The last step's second half kick, while a run of steps defers it to the next step's first pass
  // (core/pending_kick.hpp). A module that changes a velocity or spin between steps (begin_step,
  // finish_step) first calls kick_early (core/integrator.hpp) on that particle.
  PendingKick pending_kick;
};

}  // namespace grains
