// Softened Newtonian self-gravity (physics.md section 7), open boxes only.
// Force on i from j: G m_i m_j r_ij / (d^2 + eps^2)^{3/2}, eps = eps0 * R_min, with r_ij = x_j - x_i.
// Potential: W = -sum_{i<j} G m_i m_j / sqrt(d^2 + eps^2).
// Two solvers: `direct` (all pairs, O(N^2), the exact reference; gravity_direct.hpp: each pair once, in an
// order that does not depend on the thread count) and `tree` (gravity_tree.hpp: Barnes-Hut octree / quadtree,
// monopole + quadrupole cells, opening angle theta, one walk per group of nearby particles, rebuilt at every call).
// The module does not use the neighbour list (pair_range() = -1) and holds no state between steps.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "interactions/force_module.hpp"

namespace grains {

enum class GravitySolver { direct, tree };

GravitySolver gravity_solver_from_string(const std::string& s);   // "direct" | "tree"

template <int D>
class SoftenedGravity final : public ForceModule<D> {
 public:
  // eps: the absolute softening length (eps0 * R_min). theta: Barnes-Hut opening angle (tree only).
  SoftenedGravity(double G, double eps, GravitySolver solver, double theta = 0.5)
      : G_(G), eps_(eps), solver_(solver), theta_(theta) {}

  std::string name() const override { return "gravity"; }
  double pair_range() const override { return -1; }
  void add_forces(System<D>& s) override;
  // "gravity_potential_energy": direct double loop up to `direct_potential_limit` particles, tree above.
  void observe(const System<D>& s, std::vector<std::pair<std::string, double>>& out) const override;

  // The gravitational acceleration G sum_j m_j r_ij / (d^2 + eps^2)^{3/2} of every particle, by the
  // given solver (tests compare the solvers through this).
  std::vector<Vec<D>> accelerations(const Particles<D>& P, GravitySolver solver, int threads) const;
  // W by the given solver.
  double potential_energy(const Particles<D>& P, GravitySolver solver, int threads) const;

  double G() const { return G_; }
  void set_G(double G) { G_ = G; }   // a tunable parameter: the next force evaluation uses it
  double softening_length() const { return eps_; }
  double opening_angle() const { return theta_; }
  GravitySolver solver() const { return solver_; }
  static constexpr std::size_t direct_potential_limit = 20000;

 private:
  double G_, eps_;
  GravitySolver solver_;
  double theta_;
};

extern template class SoftenedGravity<2>;
extern template class SoftenedGravity<3>;

}  // namespace grains
