#include "interactions/gravity.hpp"
#include "interactions/gravity_direct.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>


namespace grains {

GravitySolver gravity_solver_from_string(const std::string& s) {
  if (s == "direct") return GravitySolver::direct;
  if (s == "tree") return GravitySolver::tree;
  throw std::invalid_argument("gravity.solver must be \"direct\" or \"tree\", not \"" + s + "\"");
}

namespace {

// Direct summation (gravity_direct.hpp) with the run-time chosen kernel.
template <int D>
std::vector<Vec<D>> direct_accelerations(const Particles<D>& P, double eps2, int threads) {
  std::vector<double> ax, ay, az;
  gravity_direct::accelerations(gravity_direct::fastest_isa(), gravity_direct::Columns(P), eps2, threads, ax, ay, az);
  std::vector<Vec<D>> out(P.size());
  for (std::size_t i = 0; i < P.size(); ++i) {
    out[i][0] = ax[i], out[i][1] = ay[i];
    if constexpr (D == 3) out[i][2] = az[i];
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Barnes-Hut tree: 2^D-ary, leaves of up to `leaf_size` particles, monopole + quadrupole nodes. A node is
// accepted for particle x if x is outside its cube and |x - com| > s / theta + |com - centre|
// (s = cube edge; the |com - centre| term is the usual guard against off-centre mass).
// ---------------------------------------------------------------------------------------------
template <int D>
class BarnesHut {
 public:
  static constexpr int kids = 1 << D;
  static constexpr int leaf_size = 8;
  static constexpr int max_depth = 48;

  BarnesHut(const Particles<D>& P, double theta) : theta_(theta) {
    const std::size_t n = P.size();
    order_.resize(n);
    for (std::size_t i = 0; i < n; ++i) order_[i] = int(i);
    Vec<D> lo = P.position[0], hi = P.position[0];
    for (const auto& x : P.position) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    const double half = 0.5 * (hi - lo).maxCoeff() * (1 + 1e-12) + 1e-300;
    const Vec<D> centre = 0.5 * (lo + hi);
    scratch_.resize(n);
    nodes_.reserve(2 * n / leaf_size + 16);
    build(P, 0, int(n), centre, half, 0);
    for (int a = 0; a < D; ++a) x_[a].resize(n);
    m_.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      for (int a = 0; a < D; ++a) x_[a][k] = P.position[order_[k]][a];
      m_[k] = P.mass[order_[k]];
    }
  }

  // Acceleration (without G) and potential per unit mass (without G, sign: -sum m/r) of every particle.
  void evaluate(double eps2, int threads, std::vector<Vec<D>>* acc, std::vector<double>* phi) const {
    const std::size_t n = order_.size();
    if (acc) acc->assign(n, Vec<D>::Zero());
    if (phi) phi->assign(n, 0.0);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
    for (std::size_t k = 0; k < n; ++k) {
      Vec<D> xi;
      for (int a = 0; a < D; ++a) xi[a] = x_[a][k];
      Vec<D> g = Vec<D>::Zero();
      double p = 0;
      std::array<int, max_depth * kids + 8> stack;
      int top = 0;
      stack[top++] = 0;
      while (top > 0) {
        const Node& nd = nodes_[stack[--top]];
        const Vec<D> r = nd.com - xi;
        const double d2 = r.squaredNorm();
        if (accept(nd, xi, d2)) {
          // Monopole + quadrupole of the softened kernel: with s = x - com and h = sqrt(s^2 + eps^2),
          // phi = -(M / h + s.Q.s / (2 h^5)), a = -M s / h^3 + Q s / h^5 - 5/2 (s.Q.s) s / h^7.
          const double inv = 1.0 / std::sqrt(d2 + eps2), inv2 = inv * inv, inv3 = inv * inv2, inv5 = inv3 * inv2;
          const Vec<D> Qs = nd.quad * r;
          const double sQs = r.dot(Qs);
          g += (nd.mass * inv3 + 2.5 * sQs * inv5 * inv2) * r - inv5 * Qs;   // r = com - x = -s
          p -= nd.mass * inv + 0.5 * sQs * inv5;
        } else if (nd.leaf) {
          for (int j = nd.begin; j < nd.end; ++j) {
            if (std::size_t(j) == k) continue;
            Vec<D> rj;
            for (int a = 0; a < D; ++a) rj[a] = x_[a][j] - xi[a];
            const double inv = 1.0 / std::sqrt(rj.squaredNorm() + eps2);
            g += (m_[j] * inv * inv * inv) * rj;
            p -= m_[j] * inv;
          }
        } else {
          for (int c = 0; c < kids; ++c)
            if (nd.child[c] >= 0) stack[top++] = nd.child[c];
        }
      }
      if (acc) (*acc)[order_[k]] = g;
      if (phi) (*phi)[order_[k]] = p;
    }
  }

  std::size_t node_count() const { return nodes_.size(); }

 private:
  struct Node {
    Vec<D> centre, com;
    double half = 0, mass = 0, offset = 0;   // offset = |com - centre|
    Eigen::Matrix<double, D, D> quad;        // sum m (3 d d^T - |d|^2 I), d = x - com
    std::array<int, kids> child;
    int begin = 0, end = 0;
    bool leaf = true;
  };

  bool accept(const Node& nd, const Vec<D>& x, double d2) const {
    if (theta_ <= 0) return false;
    if (nd.leaf && nd.end - nd.begin == 1) return false;   // a single particle: exact anyway
    bool inside = true;
    for (int a = 0; a < D; ++a) inside &= std::abs(x[a] - nd.centre[a]) <= nd.half;
    if (inside) return false;
    const double lim = 2 * nd.half / theta_ + nd.offset;
    return d2 > lim * lim;
  }

  int build(const Particles<D>& P, int begin, int end, const Vec<D>& centre, double half, int depth) {
    const int id = int(nodes_.size());
    nodes_.emplace_back();
    {
      Node& nd = nodes_[id];
      nd.centre = centre, nd.half = half, nd.begin = begin, nd.end = end;
      nd.child.fill(-1);
    }
    if (end - begin > leaf_size && depth < max_depth) {
      // Counting sort of [begin, end) by child cube.
      std::array<int, kids + 1> start{};
      auto code = [&](int i) {
        int c = 0;
        for (int a = 0; a < D; ++a) c |= (P.position[i][a] >= centre[a] ? 1 : 0) << a;
        return c;
      };
      for (int k = begin; k < end; ++k) ++start[code(order_[k]) + 1];
      for (int c = 0; c < kids; ++c) start[c + 1] += start[c];
      std::array<int, kids> fill{};
      for (int k = begin; k < end; ++k) {
        const int c = code(order_[k]);
        scratch_[begin + start[c] + fill[c]++] = order_[k];
      }
      std::copy(scratch_.begin() + begin, scratch_.begin() + end, order_.begin() + begin);
      nodes_[id].leaf = false;
      for (int c = 0; c < kids; ++c) {
        if (start[c + 1] == start[c]) continue;
        Vec<D> cc = centre;
        for (int a = 0; a < D; ++a) cc[a] += ((c >> a) & 1 ? 0.5 : -0.5) * half;
        const int child = build(P, begin + start[c], begin + start[c + 1], cc, 0.5 * half, depth + 1);
        nodes_[id].child[c] = child;
      }
    }
    // Monopole: mass and centre of mass of the particles below.
    Node& nd = nodes_[id];
    double mass = 0;
    Vec<D> mx = Vec<D>::Zero();
    for (int k = begin; k < end; ++k) {
      mass += P.mass[order_[k]];
      mx += P.mass[order_[k]] * P.position[order_[k]];
    }
    nd.mass = mass;
    nd.com = mass > 0 ? Vec<D>(mx / mass) : centre;
    nd.offset = (nd.com - centre).norm();
    nd.quad.setZero();
    for (int k = begin; k < end; ++k) {
      const Vec<D> d = P.position[order_[k]] - nd.com;
      nd.quad += P.mass[order_[k]] * (3 * d * d.transpose() - d.squaredNorm() * Eigen::Matrix<double, D, D>::Identity());
    }
    return id;
  }

  double theta_;
  std::vector<int> order_, scratch_;
  std::vector<Node> nodes_;
  std::array<std::vector<double>, D> x_;
  std::vector<double> m_;
};

}  // namespace

template <int D>
std::vector<Vec<D>> SoftenedGravity<D>::accelerations(const Particles<D>& P, GravitySolver solver, int threads) const {
  const double eps2 = eps_ * eps_;
  std::vector<Vec<D>> acc;
  if (P.size() == 0) return acc;
  if (solver == GravitySolver::direct) {
    acc = direct_accelerations<D>(P, eps2, threads);
  } else {
    BarnesHut<D> tree(P, theta_);
    tree.evaluate(eps2, threads, &acc, nullptr);
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
  BarnesHut<D> tree(P, theta_);
  std::vector<double> phi;
  tree.evaluate(eps2, threads, nullptr, &phi);
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
