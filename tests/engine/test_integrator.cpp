// The integrator's first half (core/integrator.hpp) on random particles: the velocity Verlet update
// and the velocity predictor against their formulas written out here, the previous forces cleared for
// the coming evaluation, the particles following a rescaled cell, and the largest move it measures
// (which decides when the neighbour list is rebuilt) against the list's reference positions, as they
// are and as the cell has carried them. And the kinetic stress the barostat reads while a kick is
// pending: bit for bit the kinetic stress after that kick.
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>

#include "analysis/stress.hpp"
#include "core/integrator.hpp"
#include "neighbours/neighbour_list.hpp"

using namespace grains;

namespace {

template <int D>
void first_half_case(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t N = 301;   // not a multiple of any vector width
  Particles<D> P;
  P.resize(N);
  Box<D> box;
  for (int a = 0; a < D; ++a) box.length[a] = 12.0, box.lower[a] = 0.0, box.periodic[a] = true;
  for (std::size_t i = 0; i < N; ++i) {
    P.set_mass_and_radius(i, 1.0 + 0.5 * (u(rng) + 1), 0.3 + 0.1 * u(rng));
    for (int a = 0; a < D; ++a) {
      P.position[i][a] = 6.0 + 5.5 * u(rng);
      P.velocity[i][a] = u(rng), P.force[i][a] = 3 * u(rng), P.force_prev[i][a] = 3 * u(rng);
    }
  }
  NeighbourList<D> nl;
  nl.configure(0.0, 0.4);
  nl.build(P.position, P.radius, box, 1);
  const Particles<D> before = P;
  const double h = 0.01;
  const auto reference = nl.reference(N);
  REQUIRE(reference.position);
  integrator_detail::DriftGeometry fixed;
  fixed.reference = reinterpret_cast<const double*>(reference.position);
  const auto sums = kick_drift_predict<D, false>(P, h, 0, N, fixed);
  double witness = 0, largest = 0;
  std::vector<Vec<D>> drifted(N);
  for (std::size_t i = 0; i < N; ++i) {
    for (int a = 0; a < D; ++a) {
      const double acc = P.inv_mass[i] * before.force[i][a], acc_prev = P.inv_mass[i] * before.force_prev[i][a];
      const double v = before.velocity[i][a] + 0.5 * h * acc;
      CHECK(P.velocity[i][a] == v);
      CHECK(P.position[i][a] == before.position[i][a] + h * v);
      CHECK(P.velocity_predicted[i][a] == v + 0.5 * h * (1.75 * acc - 0.75 * acc_prev));
      CHECK(P.force_prev[i][a] == 0.0);
      CHECK(P.force[i][a] == before.force[i][a]);
      witness += P.position[i][a];
    }
    drifted[i] = P.position[i];
    largest = std::max(largest, (P.position[i] - reference.position[i]).squaredNorm());
  }
  CHECK(sums.witness == Approx(witness).epsilon(1e-12));
  REQUIRE(sums.largest_move > 0);
  CHECK(sums.largest_move == largest);
  // Without the reference (no list) nothing is measured.
  P = before;
  CHECK(kick_drift_predict<D, false>(P, h, 0, N, integrator_detail::DriftGeometry{}).largest_move == 0.0);

  // A deforming cell: rescaled about its lower corner, the list told so; the particles follow it in the
  // same pass, their moves measured from the reference positions the cell has carried.
  Vec<D> scale;
  for (int a = 0; a < D; ++a) scale[a] = 1 + 1e-3 * (a + 1) * (a % 2 ? -1 : 1);
  Box<D> rescaled = box;
  rescaled.length = box.length.cwiseProduct(scale);
  nl.follow_cell(scale, rescaled);
  const auto carried = nl.reference(N);
  REQUIRE(carried.strain == scale);
  integrator_detail::DriftGeometry moving;
  moving.follow = true, moving.carried = true;
  moving.reference = reinterpret_cast<const double*>(carried.position);
  for (int a = 0; a < D; ++a)
    moving.lower[a] = box.lower[a], moving.scale[a] = scale[a], moving.reference_lower[a] = carried.lower[a],
    moving.strain[a] = carried.strain[a];
  P = before;
  const auto followed = kick_drift_predict<D, false>(P, h, 0, N, moving);
  largest = 0;
  for (std::size_t i = 0; i < N; ++i) {
    CHECK(P.position[i] == Vec<D>(box.lower + (drifted[i] - box.lower).cwiseProduct(scale)));
    const Vec<D> r = carried.lower + (carried.position[i] - carried.lower).cwiseProduct(carried.strain);
    largest = std::max(largest, (P.position[i] - r).squaredNorm());
  }
  REQUIRE(followed.largest_move > 0);
  CHECK(followed.largest_move == largest);
}

// The kinetic stress of the velocities a pending kick will give, summed in two runs as the step does
// around particles kicked early, equals kinetic_stress after the kick, bit for bit.
template <int D>
void pending_kinetic_stress_case(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t N = 203;
  Particles<D> P;
  P.resize(N);
  for (std::size_t i = 0; i < N; ++i) {
    P.set_mass_and_radius(i, 1.0 + 0.5 * (u(rng) + 1), 0.5);
    for (int a = 0; a < D; ++a) P.velocity[i][a] = u(rng), P.force[i][a] = 30 * u(rng);
  }
  PendingKick kick;
  kick.active = true, kick.h = 1e-3, kick.keep = 0.999;
  Eigen::Matrix<double, D, D> pending = Eigen::Matrix<double, D, D>::Zero();
  add_kinetic_stress<D>(P, 0, 77, &kick, pending);
  add_kinetic_stress<D>(P, 77, N, &kick, pending);
  kick_range<D, false>(P, kick.h, kick.keep, 0, N);
  const double volume = 1.7;
  const Tensor<D> after = kinetic_stress<D>(P, volume);
  const Tensor<D> before_kick = pending / volume;
  for (int r = 0; r < D; ++r)
    for (int c = 0; c < D; ++c) CHECK(before_kick(r, c) == after(r, c));
  // The sum itself, written out: sum m v v^T in particle order.
  Tensor<D> written = Tensor<D>::Zero();
  for (std::size_t i = 0; i < N; ++i)
    for (int c = 0; c < D; ++c)
      for (int r = 0; r < D; ++r) written(r, c) += (P.mass[i] * P.velocity[i][r]) * P.velocity[i][c];
  for (int r = 0; r < D; ++r)
    for (int c = 0; c < D; ++c) CHECK(written(r, c) / volume == after(r, c));
}

}  // namespace

TEST_CASE("integrator: the first half's update, prediction, cell following and measured move (2D and 3D)", "[integrator]") {
  for (unsigned seed : {1u, 2u, 3u}) {
    first_half_case<2>(seed);
    first_half_case<3>(seed);
  }
}

TEST_CASE("integrator: the kinetic stress of a pending kick is the kinetic stress after it (2D and 3D)", "[integrator]") {
  for (unsigned seed : {1u, 2u}) {
    pending_kinetic_stress_case<2>(seed);
    pending_kinetic_stress_case<3>(seed);
  }
}

namespace {
// The drift written for AVX2 (drift_2_avx2, drift_3_avx2) must write the bits of the loop the compilers
// vectorise (drift_2_compiled, drift_3_compiled), in every variant (a pending kick or not, following a cell
// or not, measuring the move from the reference positions as they are or as carried), over a number of
// particles that leaves one to the compiled loop. Its witness sums may differ in their last bits. The
// largest move is also compared over every window of four particles (one vector block), so that each lane
// of the written loop's per-particle sums decides the maximum somewhere.
template <int D>
void drift_written_for_avx2_case() {
  using namespace integrator_detail;
  const auto written = D == 2 ? drift_2_avx2 : drift_3_avx2;
  const auto compiled = D == 2 ? drift_2_compiled : drift_3_compiled;
  std::mt19937_64 rng(7 + D);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t n = 301;
  std::vector<double> mass(n), x(D * n), v(D * n), vp(D * n), f(D * n), f_prev(D * n), reference(D * n);
  for (double& m : mass) m = 1.5 + u(rng);
  for (auto* a : {&x, &v, &vp, &f, &f_prev, &reference})
    for (double& e : *a) e = 3 * u(rng);
  const PendingKick pending = [] {
    PendingKick k;
    k.h = 1.3e-3, k.keep = 0.999;
    return k;
  }();
  for (bool kick : {false, true})
    for (bool follow : {false, true})
      for (int measure : {0, 1, 2}) {
        DriftGeometry g;
        g.follow = follow;
        g.lower[0] = 0.25, g.lower[1] = -0.5, g.lower[2] = 0.75, g.scale[0] = 0.9993, g.scale[1] = 1.0011, g.scale[2] = 0.9998;
        g.reference = measure ? reference.data() : nullptr;
        g.carried = measure == 2;
        g.reference_lower[0] = 0.1, g.reference_lower[1] = 0.2, g.reference_lower[2] = -0.3;
        g.strain[0] = 0.998, g.strain[1] = 1.003, g.strain[2] = 1.001;
        const PendingKick* k = kick ? &pending : nullptr;
        auto x1 = x, v1 = v, vp1 = vp, fp1 = f_prev, x2 = x, v2 = v, vp2 = vp, fp2 = f_prev;
        const DriftSums a = written(n, 2e-3, mass.data(), x1.data(), v1.data(), vp1.data(), f.data(), fp1.data(), g, k);
        const DriftSums b = compiled(n, 2e-3, mass.data(), x2.data(), v2.data(), vp2.data(), f.data(), fp2.data(), g, k);
        INFO("D " << D << ", kick " << kick << ", follow " << follow << ", measure " << measure);
        CHECK(x1 == x2);
        CHECK(v1 == v2);
        CHECK(vp1 == vp2);
        CHECK(fp1 == fp2);
        CHECK(a.largest_move == b.largest_move);
        CHECK((measure == 0 || a.largest_move > 0));
        CHECK(a.witness == Approx(b.witness).epsilon(1e-12));
        CHECK(a.kick_witness == Approx(b.kick_witness).epsilon(1e-12));
        if (measure == 0) continue;
        int differing = 0;
        for (std::size_t i = 0; i + 4 <= n; ++i) {
          DriftGeometry window = g;
          window.reference += D * i;
          auto x3 = x, v3 = v, vp3 = vp, fp3 = f_prev, x4 = x, v4 = v, vp4 = vp, fp4 = f_prev;
          const std::size_t o = D * i;
          differing += written(4, 2e-3, mass.data() + i, x3.data() + o, v3.data() + o, vp3.data() + o, f.data() + o,
                               fp3.data() + o, window, k).largest_move !=
                       compiled(4, 2e-3, mass.data() + i, x4.data() + o, v4.data() + o, vp4.data() + o, f.data() + o,
                                fp4.data() + o, window, k).largest_move;
        }
        CHECK(differing == 0);
      }
}
}  // namespace

// drift_2 and drift_3 run the loops written for AVX2 wherever the processor has it.
TEST_CASE("integrator: the drift written for AVX2 writes the compiled loop's bits (2D and 3D)", "[integrator]") {
  if (!integrator_detail::has_avx2()) {
    WARN("this processor has no AVX2: the drift written for it is not tested");
    return;
  }
  drift_written_for_avx2_case<2>();
  drift_written_for_avx2_case<3>();
}

// The spheres' spin half kick written for AVX2 (half_kick_spin_3_avx2, run wherever the processor has it)
// writes the compiled loop's spins and cleared torques, with a pending kick or without, over a number of
// spheres that leaves one to the compiled loop.
TEST_CASE("integrator: the spin half kick written for AVX2 writes the compiled loop's bits", "[integrator]") {
  using namespace integrator_detail;
  if (!has_avx2()) {
    WARN("this processor has no AVX2: the spin half kick written for it is not tested");
    return;
  }
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t n = 301;
  std::vector<double> inverse_inertia(n), torque(3 * n), w(3 * n);
  for (double& i : inverse_inertia) i = 1.5 + u(rng);
  for (auto* a : {&torque, &w})
    for (double& e : *a) e = 3 * u(rng);
  PendingKick pending;
  pending.h = 1.3e-3, pending.keep = 0.999;
  const PendingKick* none = nullptr;
  for (const PendingKick* kick : {none, static_cast<const PendingKick*>(&pending)}) {
    auto w1 = w, w2 = w, t1 = torque, t2 = torque;
    const double a = half_kick_spin_3_avx2(n, 2e-3, inverse_inertia.data(), t1.data(), w1.data(), kick);
    const double b = half_kick_spin_3_compiled(n, 2e-3, inverse_inertia.data(), t2.data(), w2.data(), kick);
    INFO("pending kick " << (kick != nullptr));
    CHECK(w1 == w2);
    CHECK(t1 == t2);
    CHECK(std::all_of(t1.begin(), t1.end(), [](double t) { return t == 0; }));
    CHECK(a == Approx(b).epsilon(1e-12));
  }
}

// The 2D kinetic stress sum written for AVX2 (add_kinetic_stress_2_avx2, used wherever the processor has
// AVX2) must give the compiled loop's bits, with a pending kick (its second half applied first) or without,
// added onto a nonzero sum as the barostat's runs between early-kicked particles do.
TEST_CASE("integrator: the 2D kinetic stress written for AVX2 gives the compiled loop's bits", "[integrator]") {
  using namespace integrator_detail;
  if (!__builtin_cpu_supports("avx2")) {
    WARN("this processor has no AVX2: the 2D kinetic stress written for it is not tested");
    return;
  }
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t n = 257;
  std::vector<double> mass(n), inverse_mass(n), f(2 * n), v(2 * n);
  for (std::size_t i = 0; i < n; ++i) mass[i] = 1.5 + u(rng), inverse_mass[i] = 1 / mass[i];
  for (auto* a : {&f, &v})
    for (double& e : *a) e = 3 * u(rng);
  PendingKick pending;
  pending.h = 1.3e-3, pending.keep = 0.999;
  const PendingKick* none = nullptr;
  for (const PendingKick* kick : {none, static_cast<const PendingKick*>(&pending)}) {
    double a[4] = {0.25, -0.125, 0.0625, 2.0}, b[4] = {0.25, -0.125, 0.0625, 2.0};
    add_kinetic_stress_2_avx2(n, mass.data(), inverse_mass.data(), f.data(), v.data(), kick, a);
    add_kinetic_stress_2_compiled(n, mass.data(), inverse_mass.data(), f.data(), v.data(), kick, b);
    INFO("pending kick " << (kick != nullptr));
    for (int e = 0; e < 4; ++e) CHECK(a[e] == b[e]);
  }
}
