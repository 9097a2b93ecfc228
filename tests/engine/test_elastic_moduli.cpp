// Elastic moduli of contact networks: lattices against their closed forms, a disordered packing against
// the Voigt bound and a dense solve of the full system, and the response to unit stress increments
// applied to the engine's own pair loop.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "analysis/elastic_moduli.hpp"
#include "analysis/stress.hpp"
#include "core/simulation.hpp"
#include "core/system.hpp"
#include "interactions/adhesive_contact_law.hpp"
#include "interactions/contact_forces.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {

struct Stiffnesses {
  double normal = 0, tangential = 0, rolling = 0;
};

// Every pair whose surfaces are closer than `tolerance` in a periodic box (all pairs, nearest image),
// linearised with the given stiffnesses; lever arms to the middle of the overlap.
template <int D>
std::vector<ElasticSpring<D>> springs_of(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const Vec<D>& L,
                                         const Stiffnesses& k, double tolerance = 1e-9) {
  std::vector<ElasticSpring<D>> out;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) {
      Vec<D> r = x[j] - x[i];
      for (int a = 0; a < D; ++a) r[a] -= L[a] * std::round(r[a] / L[a]);
      const double gap = r.norm() - radius[i] - radius[j];
      if (gap >= tolerance) continue;
      ElasticSpring<D> s;
      s.i = std::uint32_t(i), s.j = std::uint32_t(j), s.branch = r;
      s.arm_i = radius[i] + 0.5 * gap, s.arm_j = radius[j] + 0.5 * gap;
      s.normal = k.normal, s.tangential = k.tangential, s.rolling = k.rolling;
      s.contact_stiffness = k.normal;
      out.push_back(s);
    }
  return out;
}

// A triangular lattice of touching disks of diameter l, nx by ny (ny even), rows along x.
struct Lattice2 {
  std::vector<Vec<2>> x;
  std::vector<double> radius;
  Vec<2> L;
};
Lattice2 triangular(int nx, int ny, double l) {
  Lattice2 t;
  const double h = std::sqrt(3.0) / 2 * l;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) t.x.emplace_back((i + 0.5 * (j % 2) + 0.25) * l, (j + 0.5) * h);
  t.radius.assign(t.x.size(), 0.5 * l);
  t.L = Vec<2>(nx * l, ny * h);
  return t;
}
// A square lattice of touching disks of diameter l turned by 45 degrees: m by m cells of side l sqrt(2),
// two disks each, so the cell's pure shear is the lattice's simple shear.
Lattice2 square_45(int m, double l) {
  Lattice2 t;
  const double c = std::sqrt(2.0) * l;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      t.x.emplace_back((i + 0.25) * c, (j + 0.25) * c);
      t.x.emplace_back((i + 0.75) * c, (j + 0.75) * c);
    }
  t.radius.assign(t.x.size(), 0.5 * l);
  t.L = Vec<2>(m * c, m * c);
  return t;
}

}  // namespace

TEST_CASE("triangular lattice: B and G in closed form, with and without tangential springs", "[moduli]") {
  // Every disk is a centre of inversion and of the lattice's mirrors, so the affine field is exact (no
  // relaxation, no rotation) and C = (1/V) sum_contacts r_a r_b [K_N n_a n_b + K_T (delta_ab - n_a n_b)].
  // Three contacts per disk at 0, 60 and 120 degrees, area sqrt(3)/2 l^2 per disk:
  //   C11 = C22 = (9 K_N + 3 K_T) / (4 sqrt 3), C12 = 3 (K_N - K_T) / (4 sqrt 3),
  //   B = (C11 + C12) / 2 = sqrt(3) K_N / 2, G = (C11 - C12) / 2 = sqrt(3) (K_N + K_T) / 4.
  const double kn = 1e5, l = 0.999;
  const auto t = triangular(6, 6, l);
  for (double kt : {0.0, kn, 0.3 * kn}) {
    const auto m = elastic_moduli<2>(t.x.size(), t.L.prod(), springs_of<2>(t.x, t.radius, t.L, {kn, kt, 0}));
    const double r3 = std::sqrt(3.0);
    CHECK(m.bulk == Approx(r3 * kn / 2).epsilon(1e-10));
    CHECK(m.shear == Approx(r3 * (kn + kt) / 4).epsilon(1e-10));
    CHECK(m.stiffness(0, 0) == Approx((9 * kn + 3 * kt) / (4 * r3)).epsilon(1e-10));
    CHECK(m.stiffness(1, 1) == Approx((9 * kn + 3 * kt) / (4 * r3)).epsilon(1e-10));
    CHECK(m.stiffness(0, 1) == Approx(3 * (kn - kt) / (4 * r3)).epsilon(1e-10).margin(1e-10 * kn));
    // The affine field is exact: Voigt = the moduli.
    CHECK(m.bulk_voigt == Approx(m.bulk).epsilon(1e-10));
    CHECK(m.shear_voigt == Approx(m.shear).epsilon(1e-10));
    CHECK(m.mechanisms == 0);
    CHECK(m.unstable_modes == 0);
    CHECK(m.floppy_modes == 2);   // the two translations of the whole lattice
    CHECK(m.grains == t.x.size());
    CHECK(m.dofs == t.x.size() * (kt > 0 ? 3 : 2));   // rotations only where a tangential spring holds them
  }
}

TEST_CASE("square lattice: a mechanism in shear with normal springs only, G = K_T / 2 with tangential springs", "[moduli]") {
  // Turned by 45 degrees, contacts along (1, 1) and (-1, 1), two per disk, area l^2 per disk; the affine
  // field is exact (centres of inversion, mirrors x -> -x), so C11 = C22 = (K_N + K_T) / 2,
  // C12 = (K_N - K_T) / 2: B = K_N / 2, G = K_T / 2.
  const double kn = 1e5, l = 1.0;
  const int m = 4;
  const auto t = square_45(m, l);
  SECTION("normal springs only: the cell's pure shear costs nothing") {
    const auto e = elastic_moduli<2>(t.x.size(), t.L.prod(), springs_of<2>(t.x, t.radius, t.L, {kn, 0, 0}));
    CHECK(e.bulk == Approx(kn / 2).epsilon(1e-10));
    CHECK(e.shear == 0);   // exactly: round-off along a mechanism is not a modulus
    CHECK(e.mechanisms == 1);
    CHECK(e.unstable_modes == 0);
    // Each of the m lines along (1, 1) and the m along (-1, 1) slides freely along itself.
    CHECK(e.floppy_modes == 2 * m);
  }
  SECTION("with tangential springs") {
    const double kt = 0.4 * kn;
    const auto e = elastic_moduli<2>(t.x.size(), t.L.prod(), springs_of<2>(t.x, t.radius, t.L, {kn, kt, 0}));
    CHECK(e.bulk == Approx(kn / 2).epsilon(1e-10));
    CHECK(e.shear == Approx(kt / 2).epsilon(1e-10));
    CHECK(e.mechanisms == 0);
    // The two translations, and the two sublattices turning the other way round like gears.
    CHECK(e.floppy_modes == 3);
  }
}

TEST_CASE("separate bonded dimers resist no strain: B and G are 0, not round-off of either sign", "[moduli]") {
  // Dimers of touching disks at random angles, far apart: each turns and moves freely with the cell, so the
  // condensed stiffness is zero up to the cancellation's round-off. The loosest stages of a type-2 sample (one
  // bonded cluster not yet spanning the cell) printed B = -2.6e-9 there.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(0, 2 * std::acos(-1.0));
  std::vector<Vec<2>> x;
  const int side = 5;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) {
      const Vec<2> c(5.0 * i + 2.5, 5.0 * j + 2.5), u(std::cos(angle(rng)), std::sin(angle(rng)));
      x.push_back(c - 0.4999 * u), x.push_back(c + 0.4999 * u);
    }
  const std::vector<double> radius(x.size(), 0.5);
  const Vec<2> L(5.0 * side, 5.0 * side);
  for (const double kt : {0.0, 0.4e5}) {
    const auto e = elastic_moduli<2>(x.size(), L.prod(), springs_of<2>(x, radius, L, {1e5, kt, 0}));
    REQUIRE(e.unstable_modes == 0);
    CHECK(e.mechanisms == 2);
    CHECK(e.bulk == 0);
    CHECK(e.shear == 0);
    CHECK(e.bulk_voigt > 0);
  }
}

TEST_CASE("FCC lattice: B and G in closed form", "[moduli]") {
  // Six contacts per sphere along (1, +-1, 0), (1, 0, +-1), (0, 1, +-1) / sqrt 2, volume l^3 / sqrt 2 per
  // sphere, affine field exact (centres of inversion, the three mirrors):
  //   C11 = sqrt(2) (K_N + K_T) / l, C12 = sqrt(2) (K_N - K_T) / (2 l),
  //   B = (C11 + 2 C12) / 3 = 2 sqrt(2) K_N / (3 l), G = (C11 - C12) / 2 = sqrt(2) (K_N + 3 K_T) / (4 l).
  const double kn = 1e5, l = 0.98, c = std::sqrt(2.0) * l;
  const int m = 3;
  std::vector<Vec<3>> x;
  const Vec<3> basis[4] = {{0, 0, 0}, {0, 0.5, 0.5}, {0.5, 0, 0.5}, {0.5, 0.5, 0}};
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < m; ++k)
        for (const auto& b : basis) x.push_back(c * (Vec<3>(i, j, k) + b + Vec<3>::Constant(0.1)));
  const std::vector<double> radius(x.size(), 0.5 * l);
  Vec<3> L = Vec<3>::Constant(m * c);
  for (double kt : {0.0, 0.5 * kn}) {
    const auto e = elastic_moduli<3>(x.size(), L.prod(), springs_of<3>(x, radius, L, {kn, kt, 0}));
    const double r2 = std::sqrt(2.0);
    CHECK(e.bulk == Approx(2 * r2 * kn / (3 * l)).epsilon(1e-10));
    CHECK(e.shear == Approx(r2 * (kn + 3 * kt) / (4 * l)).epsilon(1e-10));
    CHECK(e.stiffness(2, 2) == Approx(r2 * (kn + kt) / l).epsilon(1e-10));
    CHECK(e.stiffness(0, 2) == Approx(r2 * (kn - kt) / (2 * l)).epsilon(1e-10));
    CHECK(e.mechanisms == 0);
    CHECK(e.unstable_modes == 0);
  }
}

TEST_CASE("disordered packing: symmetric stiffness, B and G below Voigt, the dense full solve agrees", "[moduli]") {
  // A perturbed triangular arrangement of polydisperse disks; overlapping pairs are contacts. Not in
  // equilibrium (none is needed for the linear response), with rattlers and grains on one contact.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.12, 0.12), size(0.42, 0.58);
  auto t = triangular(8, 8, 1.0);
  for (auto& p : t.x) {   // drawn in sequence (y first, as GCC evaluated Vec<2>(jitter(rng), jitter(rng))): argument
    const double dy = jitter(rng), dx = jitter(rng);   // order is unspecified, clang drew x first: another packing,
    p += Vec<2>(dx, dy);                                // one with a mechanism
  }
  for (auto& r : t.radius) r = size(rng);
  const double kn = 1e5, kt = 0.7 * kn, kr = 1e-3 * kn;
  const auto springs = springs_of<2>(t.x, t.radius, t.L, {kn, kt, kr});
  const std::size_t N = t.x.size();
  const double V = t.L.prod();

  const Eigen::SparseMatrix<double> K = stiffness_matrix<2>(N, springs);
  REQUIRE(K.rows() == Eigen::Index(3 * N + 2));
  const Eigen::MatrixXd dense = Eigen::MatrixXd(K);
  CHECK((dense - dense.transpose()).norm() <= 1e-14 * dense.norm());

  ElasticModuliOptions opt;
  opt.keep_response = true;
  const auto e = elastic_moduli<2>(N, V, springs, opt);
  REQUIRE(e.mechanisms == 0);
  REQUIRE(e.unstable_modes == 0);
  CHECK(e.grains < N);   // rattlers were removed
  CHECK(e.bulk > 0);
  CHECK(e.shear > 0);
  CHECK(e.bulk <= e.bulk_voigt);
  CHECK(e.shear <= e.shear_voigt);
  CHECK(e.shear < 0.9 * e.shear_voigt);   // the disorder relaxes: not the affine answer
  // The Voigt bulk modulus is sum K_N |r|^2 / (4 V) (isotropic strain stretches every spring by |r| eps).
  double affine = 0;
  for (const auto& s : springs) affine += kn * s.branch.squaredNorm();
  CHECK(e.bulk_voigt == Approx(affine / (4 * V)).epsilon(1e-12));

  // The full system K q = F_ext for each unit compressive stress increment (F_ext = -V on that strain),
  // solved densely in the least-squares sense (its null space, rattlers included, carries no load).
  for (int a = 0; a < 2; ++a) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(K.rows());
    f[3 * N + a] = -V;
    const Eigen::VectorXd q = dense.completeOrthogonalDecomposition().solve(f);
    CHECK((dense * q - f).norm() <= 1e-9 * V);
    for (int b = 0; b < 2; ++b) CHECK(e.response[a].strain[b] == Approx(q[3 * N + b]).epsilon(1e-8));
  }
  // Compliance and stiffness are inverses.
  const Eigen::Matrix2d compliance = -(Eigen::Matrix2d() << e.response[0].strain, e.response[1].strain).finished();
  CHECK((e.stiffness * compliance - Eigen::Matrix2d::Identity()).norm() < 1e-9);
}

namespace {

template <int D>
using Adhesive = ContactForces<D, AdhesiveContactLaw, CoulombFriction, RollingResistance>;

// The engine's pair loop over disks at x in a periodic box: one evaluation there (every contact is
// then known to the loop, not in its first step, and its tangential and rolling springs are relaxed),
// then, if `u` is given, one more after the grains moved by `u`, turned by `w` and the cell strained
// by `strain` (per axis), fed as one step of length 1 at velocities u, w and strain rate `strain` so
// that the springs accumulate exactly that motion. Returns the system (forces, torques, virial).
template <int D>
System<D> evaluate(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const Vec<D>& L, Adhesive<D>& contacts,
                   const std::vector<Vec<D>>& u = {}, const std::vector<Spin<D>>& w = {}, const Vec<D>& strain = Vec<D>::Zero()) {
  System<D> s;
  const std::size_t N = x.size();
  s.particles.resize(N);
  s.box.length = L;
  s.box.periodic.fill(true);
  for (std::size_t i = 0; i < N; ++i) {
    s.particles.set_mass_and_radius(i, 1.0, radius[i]);
    s.particles.position[i] = s.box.wrap(x[i]);
  }
  s.neighbours.configure(contacts.pair_range(), 0.1, false);
  s.neighbours.build(s.particles.position, s.particles.radius, s.box, 1);
  contacts.after_rebuild(s.neighbours);
  s.want_virial = true;
  contacts.add_forces(s);
  if (u.empty()) return s;
  // The step, as the engine takes it: the cell and the particles' affine part, then their own motion.
  const Vec<D> scale = Vec<D>::Ones() + strain;
  s.box.length = L.cwiseProduct(scale);
  s.neighbours.follow_cell(scale, s.box);
  for (std::size_t i = 0; i < N; ++i) {
    s.particles.position[i] = s.particles.position[i].cwiseProduct(scale) + u[i];
    s.particles.velocity[i] = u[i], s.particles.angular_velocity[i] = w[i];
    s.particles.force[i].setZero(), s.particles.torque[i].setZero();
  }
  s.virial.setZero();
  s.dt = 1;
  s.affine_flow = true;
  s.strain_rate = strain;
  s.cell_scale = scale;
  contacts.add_forces(s);
  return s;
}

}  // namespace

TEST_CASE("unit stress increments applied through the engine's pair loop give the unit stress back", "[moduli]") {
  // A honeycomb of polydisperse disks (radii in [0.42, 0.58]) whose centres are then moved (Gauss-Newton,
  // least-norm steps) until every bond is at the adhesive law's rest overlap F0 / K_N: no prestress, so
  // the engine's stress change is the linear response of the stiffness matrix alone, and no symmetry
  // left, so the grains both shift and turn (a non-affine response with rotations).
  const double kn = 1e5, f0 = 1, d0 = 1e-3, delta0 = f0 / kn;
  const AdhesiveContactLaw law{kn, f0, d0, 0.0, 0.5};
  const int nx = 4, ny = 3;
  std::vector<Vec<2>> x;
  const Vec<2> site[4] = {{0, 0}, {0, 1}, {std::sqrt(3.0) / 2, 1.5}, {std::sqrt(3.0) / 2, 2.5}};
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      for (const auto& c : site) x.push_back(c + Vec<2>(std::sqrt(3.0) * i + 0.3, 3.0 * j + 0.2));
  const Vec<2> L(nx * std::sqrt(3.0), ny * 3.0);
  const std::size_t N = x.size();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> size(0.42, 0.58);
  std::vector<double> radius(N);
  for (auto& r : radius) r = size(rng);
  auto image = [&](Vec<2> r) {
    for (int a = 0; a < 2; ++a) r[a] -= L[a] * std::round(r[a] / L[a]);
    return r;
  };
  std::vector<std::pair<std::size_t, std::size_t>> bonds;
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t j = i + 1; j < N; ++j)
      if (image(x[j] - x[i]).norm() < 1.01) bonds.emplace_back(i, j);
  REQUIRE(bonds.size() == 3 * N / 2);
  for (int iteration = 0; iteration < 30; ++iteration) {
    Eigen::VectorXd c(bonds.size());
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(bonds.size(), 2 * N);
    for (std::size_t e = 0; e < bonds.size(); ++e) {
      const auto [i, j] = bonds[e];
      const Vec<2> r = image(x[j] - x[i]);
      c[e] = r.norm() - (radius[i] + radius[j] - delta0);
      J.block<1, 2>(e, 2 * j) = r.normalized().transpose();
      J.block<1, 2>(e, 2 * i) = -r.normalized().transpose();
    }
    if (c.cwiseAbs().maxCoeff() < 1e-14) break;
    const Eigen::VectorXd step = J.completeOrthogonalDecomposition().solve(c);
    for (std::size_t i = 0; i < N; ++i) x[i] -= step.segment<2>(2 * i);
  }
  const CoulombFriction friction{10.0, 0.3, 0.0, true};
  const RollingResistance rolling{0.05 * kn, 10.0};

  Adhesive<2> reference_contacts(law, friction, rolling);
  System<2> reference = evaluate(x, radius, L, reference_contacts);
  std::vector<ElasticSpring<2>> springs;
  reference_contacts.list_springs(reference, springs);
  REQUIRE(springs.size() == 3 * N / 2);
  for (const auto& s : springs) REQUIRE(std::abs(s.normal_force) < 1e-9 * f0);
  const double V = L.prod();
  const Tensor<2> sigma0 = contact_stress<2>(reference.virial, V);
  CHECK(sigma0.norm() < 1e-9 * f0);

  ElasticModuliOptions opt;
  opt.keep_response = true;
  const auto e = elastic_moduli<2>(N, V, springs, opt);
  REQUIRE(e.mechanisms == 0);
  REQUIRE(e.unstable_modes == 0);
  CHECK(e.shear < 0.95 * e.shear_voigt);   // the grains relax

  const double increment = 1e-3 * f0;   // small enough for the response to be linear to 1e-6
  for (int a = 0; a < 2; ++a) {
    const auto& r = e.response[a];
    std::vector<Vec<2>> u(N);
    std::vector<Spin<2>> w(N);
    double shift = 0, turn = 0;
    for (std::size_t i = 0; i < N; ++i) {
      u[i] = increment * r.displacement[i], w[i] = increment * r.rotation[i];
      shift = std::max(shift, u[i].norm()), turn = std::max(turn, std::abs(w[i][0]));
    }
    const Vec<2> strain = increment * r.strain;
    CHECK(shift > 1e-2 * strain.cwiseAbs().maxCoeff());   // non-affine displacements and rotations to check
    CHECK(turn > 1e-2 * strain.cwiseAbs().maxCoeff());
    Adhesive<2> contacts(law, friction, rolling);
    const System<2> moved = evaluate(x, radius, L, contacts, u, w, strain);
    const Tensor<2> sigma = contact_stress<2>(moved.virial, moved.box.volume());
    // Measured: 2.3e-8 and 1.8e-8 on the axis, 9.3e-9 and 3.6e-9 on the other, net forces 2.5e-7 and 2.2e-7,
    // torques 1.4e-9 and 2.2e-9 of the increment. The overlaps' round-off alone is of that order (K_N ulp(x) /
    // increment ~ 2e-7 per contact), so the bounds keep a factor 4-5 over what is measured.
    CHECK(sigma(a, a) / increment == Approx(1).epsilon(1e-7));
    CHECK(std::abs(sigma(1 - a, 1 - a)) / increment < 5e-8);
    // The grains are in equilibrium: net forces and torques vanish against the contact forces' scale.
    double force = 0, torque = 0;
    for (std::size_t i = 0; i < N; ++i)
      force = std::max(force, moved.particles.force[i].norm()), torque = std::max(torque, std::abs(moved.particles.torque[i][0]));
    WARN(fmt::format("unit stress increment on axis {}: stress error {:.3g}, other axis {:.3g}, net force {:.3g}, torque {:.3g} "
                     "of the increment", a, sigma(a, a) / increment - 1, sigma(1 - a, 1 - a) / increment, force / increment,
                     torque / increment));
    CHECK(force < 1e-6 * increment);
    CHECK(torque < 1e-8 * increment);
  }
}

TEST_CASE("unit stress increments applied through the engine's 3D pair loop give the unit stress back", "[moduli]") {
  // The 3D case of the test above: a diamond lattice (four bonds a grain) of polydisperse spheres (radii in
  // [0.42, 0.58]) moved until every bond is at the rest overlap F0 / K_N. Normal springs alone leave it floppy;
  // the tangential and rolling springs make it rigid, so the response shifts and turns the grains about all
  // three axes, and the rows of the stiffness matrix for the 3D tangential and rolling springs meet the
  // engine's 3D pair loop.
  const double kn = 1e5, f0 = 1, d0 = 1e-3, delta0 = f0 / kn;
  const AdhesiveContactLaw law{kn, f0, d0, 0.0, 0.5};
  const int m = 2;
  const double c = 4 / std::sqrt(3.0);   // the cubic cell of a diamond lattice whose bonds are 1 long
  std::vector<Vec<3>> x;
  const Vec<3> fcc[4] = {{0, 0, 0}, {0, 0.5, 0.5}, {0.5, 0, 0.5}, {0.5, 0.5, 0}};
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < m; ++k)
        for (const auto& b : fcc)
          for (const Vec<3>& shift : {Vec<3>(0.1, 0.2, 0.3), Vec<3>(0.35, 0.45, 0.55)})
            x.push_back(c * (Vec<3>(i, j, k) + b + shift));
  Vec<3> L = Vec<3>::Constant(m * c);
  const std::size_t N = x.size();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> size(0.42, 0.58);
  std::vector<double> radius(N);
  for (auto& r : radius) r = size(rng);
  auto image = [&](Vec<3> r) {
    for (int a = 0; a < 3; ++a) r[a] -= L[a] * std::round(r[a] / L[a]);
    return r;
  };
  std::vector<std::pair<std::size_t, std::size_t>> bonds;
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t j = i + 1; j < N; ++j)
      if (image(x[j] - x[i]).norm() < 1.01) bonds.emplace_back(i, j);
  REQUIRE(bonds.size() == 2 * N);
  // Gauss-Newton, least-norm steps, over the centres and the cell's lengths: with the cell held, the bonds'
  // lengths are not independent (the lattice carries a stress with no bond stretched, which fixes one combination).
  std::vector<Vec<3>> wraps;   // each bond's periodic image, in cell lengths
  for (const auto& [i, j] : bonds) wraps.push_back(((x[j] - x[i]).cwiseQuotient(L)).array().round().matrix());
  for (int iteration = 0; iteration < 30; ++iteration) {
    Eigen::VectorXd gap(bonds.size());
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(bonds.size(), 3 * N + 3);
    for (std::size_t e = 0; e < bonds.size(); ++e) {
      const auto [i, j] = bonds[e];
      const Vec<3> r = x[j] - x[i] - wraps[e].cwiseProduct(L), n = r.normalized();
      gap[e] = r.norm() - (radius[i] + radius[j] - delta0);
      J.block<1, 3>(e, 3 * j) = n.transpose(), J.block<1, 3>(e, 3 * i) = -n.transpose();
      J.block<1, 3>(e, 3 * N) = -wraps[e].cwiseProduct(n).transpose();
    }
    if (gap.cwiseAbs().maxCoeff() < 1e-14) break;
    const Eigen::VectorXd step = J.completeOrthogonalDecomposition().solve(gap);
    for (std::size_t i = 0; i < N; ++i) x[i] -= step.segment<3>(3 * i);
    L -= step.tail<3>();
  }
  const CoulombFriction friction{10.0, 0.3, 0.0, true};
  const RollingResistance rolling{0.05 * kn, 10.0};

  Adhesive<3> reference_contacts(law, friction, rolling);
  System<3> reference = evaluate(x, radius, L, reference_contacts);
  std::vector<ElasticSpring<3>> springs;
  reference_contacts.list_springs(reference, springs);
  REQUIRE(springs.size() == 2 * N);
  for (const auto& s : springs) REQUIRE(std::abs(s.normal_force) < 1e-9 * f0);
  const double V = L.prod();
  CHECK(contact_stress<3>(reference.virial, V).norm() < 1e-9 * f0);

  ElasticModuliOptions opt;
  opt.keep_response = true;
  const auto e = elastic_moduli<3>(N, V, springs, opt);
  REQUIRE(e.mechanisms == 0);
  REQUIRE(e.unstable_modes == 0);
  CHECK(e.shear < 0.95 * e.shear_voigt);
  double branches = 0;   // B_V = K_N sum d^2 / (D^2 V): the tangential springs do not change the volume
  for (const auto& s : springs) branches += s.branch.squaredNorm();
  CHECK(e.bulk_voigt == Approx(kn * branches / (9 * V)).epsilon(1e-12));

  const double increment = 1e-3 * f0;
  for (int a = 0; a < 3; ++a) {
    const auto& r = e.response[a];
    std::vector<Vec<3>> u(N);
    std::vector<Spin<3>> w(N);
    double shift = 0, turn = 0;
    for (std::size_t i = 0; i < N; ++i) {
      u[i] = increment * r.displacement[i], w[i] = increment * r.rotation[i];
      shift = std::max(shift, u[i].norm()), turn = std::max(turn, w[i].norm());
    }
    const Vec<3> strain = increment * r.strain;
    CHECK(shift > 1e-2 * strain.cwiseAbs().maxCoeff());
    CHECK(turn > 1e-2 * strain.cwiseAbs().maxCoeff());
    Adhesive<3> contacts(law, friction, rolling);
    const System<3> moved = evaluate(x, radius, L, contacts, u, w, strain);
    const Tensor<3> sigma = contact_stress<3>(moved.virial, moved.box.volume());
    double other = 0, force = 0, torque = 0;
    for (int b = 0; b < 3; ++b)
      if (b != a) other = std::max(other, std::abs(sigma(b, b)) / increment);
    for (std::size_t i = 0; i < N; ++i)
      force = std::max(force, moved.particles.force[i].norm()), torque = std::max(torque, moved.particles.torque[i].norm());
    // Measured: stress errors 6.1e-8, 6.3e-8, 5.9e-8 on the axis, at most 9.4e-9 on the others, net forces
    // 1.9e-7 to 2.0e-7, torques 1.4e-8 to 1.8e-8 of the increment; the bounds keep a factor 4-5.
    CHECK(sigma(a, a) / increment == Approx(1).epsilon(3e-7));
    CHECK(other < 5e-8);
    CHECK(force < 1e-6 * increment);
    CHECK(torque < 1e-7 * increment);
  }
}

TEST_CASE("the Simulation reports the moduli of a compressed lattice, Reuss exact", "[moduli][adhesion]") {
  // A triangular lattice of unit disks at spacing l = 1 - 3 delta0 with the adhesive law (K_N = 1e5,
  // F0 = 1): every contact carries F = K_N 3 delta0 - F0 = 2 F0 and no tangential force. B and G as
  // above; the force increments of an isotropic compression are proportional to the static forces, so
  // the Reuss estimate V P^2 / sum F^2 / K_N is exact (= B) and Z2 = 1.
  const double kn = 1e5, delta0 = 1 / kn, l = 1 - 3 * delta0, kt = 0.5 * kn;
  const auto t = triangular(6, 6, l);
  std::vector<std::string> rows;
  for (const auto& p : t.x) rows.push_back(fmt::format("[{:.17g}, {:.17g}]", p[0], p[1]));
  auto scene = [&](bool moduli) {
    return fmt::format(R"(
[scene]
dimension = 2
[particles]
layout = "list"
positions = [{}]
diameter = 1.0
[box]
periodic = true
lengths = [{:.17g}, {:.17g}]
[adhesion]
enabled = true
[friction]
coefficient = 0.5
stiffness_ratio = 0.5
[analysis]
elastic_moduli = {}
[run]
threads = 1
)", fmt::join(rows, ", "), t.L[0], t.L[1], moduli);
  };
  auto s = Simulation::create(Scene::from_string(scene(true), "lattice"));
  const double r3 = std::sqrt(3.0);
  CHECK(s->get("B") == Approx(r3 * kn / 2).epsilon(1e-10));
  CHECK(s->get("G") == Approx(r3 * (kn + kt) / 4).epsilon(1e-10));
  CHECK(s->get("C11") == Approx((9 * kn + 3 * kt) / (4 * r3)).epsilon(1e-10));
  CHECK(s->get("C22") == Approx((9 * kn + 3 * kt) / (4 * r3)).epsilon(1e-10));
  CHECK(s->get("C12") == Approx(3 * (kn - kt) / (4 * r3)).epsilon(1e-10));
  CHECK(s->get("B_Voigt") == Approx(r3 * kn / 2).epsilon(1e-10));
  CHECK(s->get("G_Voigt") == Approx(r3 * (kn + kt) / 4).epsilon(1e-10));
  CHECK(s->get("B_Reuss") == Approx(r3 * kn / 2).epsilon(1e-9));
  CHECK(s->get("Z2") == Approx(1).epsilon(1e-9));
  CHECK(s->get("moduli_mechanisms") == 0);
  CHECK(s->get("moduli_unstable_modes") == 0);
  // Off by default, and then not among the outputs.
  auto off = Simulation::create(Scene::from_string(scene(false), "lattice"));
  CHECK_THROWS_AS(off->index_of("B"), SimulationError);
}
