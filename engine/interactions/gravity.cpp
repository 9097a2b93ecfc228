#include "interactions/gravity.hpp"
#include "interactions/gravity_direct.hpp"
#include "interactions/gravity_tree.hpp"

#include <stdexcept>


namespace grains {

GravitySolver gravity_solver_from_string(const std::string& s) {
  if (s == "direct") return GravitySolver::direct;
  if (s == "tree") return GravitySolver::tree;
  throw std::invalid_argument("gravity.solver must be \"direct\" or \"tree\", not \"" + s + "\"");
}

namespace {

// Per-axis columns back to vectors.
template <int D>
std::vector<Vec<D>> vectors(const std::vector<double>& ax, const std::vector<double>& ay, const std::vector<double>& az) {
  std::vector<Vec<D>> out(ax.size());
  for (std::size_t i = 0; i < ax.size(); ++i) {
    out[i][0] = ax[i], out[i][1] = ay[i];
    if constexpr (D == 3) out[i][2] = az[i];
  }
  return out;
}

// Direct summation (gravity_direct.hpp) with the run-time chosen kernel.
template <int D>
std::vector<Vec<D>> direct_accelerations(const Particles<D>& P, double eps2, int threads) {
  std::vector<double> ax, ay, az;
  gravity_direct::accelerations(gravity_direct::fastest_isa(), gravity_direct::Columns(P), eps2, threads, ax, ay, az);
  return vectors<D>(ax, ay, az);
}

// Barnes-Hut tree (gravity_tree.hpp), rebuilt for every call, with the run-time chosen kernel.
template <int D>
std::vector<Vec<D>> tree_accelerations(const Particles<D>& P, double theta, double eps2, int threads) {
  std::vector<double> ax, ay, az;
  gravity_tree::Tree(P, theta, threads).evaluate(gravity_direct::fastest_isa(), eps2, threads, ax, ay, az, nullptr);
  return vectors<D>(ax, ay, az);
}

}  // namespace

template <int D>
std::vector<Vec<D>> SoftenedGravity<D>::accelerations(const Particles<D>& P, GravitySolver solver, int threads) const {
  const double eps2 = eps_ * eps_;
  std::vector<Vec<D>> acc;
  if (P.size() == 0) return acc;
  if (solver == GravitySolver::direct) {
    acc = direct_accelerations<D>(P, eps2, threads);
  } else {
    acc = tree_accelerations<D>(P, theta_, eps2, threads);
  }
  for (auto& a : acc) a *= G_;
  return acc;
}

template <int D>
double SoftenedGravity<D>::potential_energy(const Particles<D>& P, GravitySolver solver, int threads) const {
  const double eps2 = eps_ * eps_;
  if (P.size() < 2) return 0;
  if (solver == GravitySolver::direct)
    return G_ * gravity_direct::potential(gravity_direct::fastest_isa(), gravity_direct::Columns(P), eps2, threads);
  std::vector<double> ax, ay, az, phi;
  gravity_tree::Tree(P, theta_, threads).evaluate(gravity_direct::fastest_isa(), eps2, threads, ax, ay, az, &phi);
  double W = 0;
  for (std::size_t i = 0; i < P.size(); ++i) W += 0.5 * P.mass[i] * phi[i];
  return G_ * W;
}

template <int D>
void SoftenedGravity<D>::add_forces(System<D>& s) {
  auto& P = s.particles;
  const auto acc = accelerations(P, solver_, s.threads);
  for (std::size_t i = 0; i < P.size(); ++i) P.force[i] += P.mass[i] * acc[i];
}

template <int D>
void SoftenedGravity<D>::observe(const System<D>& s, std::vector<std::pair<std::string, double>>& out) const {
  const auto& P = s.particles;
  const GravitySolver how = P.size() > direct_potential_limit ? GravitySolver::tree : GravitySolver::direct;
  out.emplace_back("gravity_potential_energy", potential_energy(P, how, s.threads));
}

template class SoftenedGravity<2>;
template class SoftenedGravity<3>;

}  // namespace grains
