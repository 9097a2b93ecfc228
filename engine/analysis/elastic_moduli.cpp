#include "analysis/elastic_moduli.hpp"

#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>

namespace grains {
namespace {

template <int D> constexpr int block = D + rotations<D>;            // a grain's degrees of freedom
template <int D> constexpr int local_size = 2 * block<D> + D;       // [u_i, theta_i, u_j, theta_j, eps]

// The Hessian of one spring's energy over its local degrees of freedom, sum_k k_k g_k^T g_k over the
// rows g_k = d(stretch along e_k)/dq: the normal, the tangent(s) and, for rolling, the relative
// rotation about each tangent (2D: about z). Built row by row so that a normal spring leaves the
// rotations exactly untouched.
template <int D>
Eigen::Matrix<double, local_size<D>, local_size<D>> spring_stiffness(const ElasticSpring<D>& s) {
  constexpr int R = rotations<D>, B = block<D>, L = local_size<D>;
  using Row = Eigen::Matrix<double, 1, L>;
  const Vec<D> n = s.branch.normalized();
  // Stretch of the contact along unit vector e: e.(u_j - u_i + eps (*) r) - (a_i theta_i + a_j theta_j).(n x e).
  auto stretch = [&](const Vec<D>& e, bool tangent) {
    Row g = Row::Zero();
    g.template segment<D>(0) = -e.transpose();
    g.template segment<D>(B) = e.transpose();
    g.template segment<D>(2 * B) = e.cwiseProduct(s.branch).transpose();
    if (tangent) {   // the rotations move the contact point along a tangent only
      Spin<D> turn;
      if constexpr (D == 3) turn = n.cross(e);
      else turn[0] = n[0] * e[1] - n[1] * e[0];
      g.template segment<R>(D) = -s.arm_i * turn.transpose();
      g.template segment<R>(B + D) = -s.arm_j * turn.transpose();
    }
    return g;
  };
  auto turning = [&](const Spin<D>& axis) {   // rotation of j relative to i about `axis`
    Row g = Row::Zero();
    g.template segment<R>(D) = -axis.transpose();
    g.template segment<R>(B + D) = axis.transpose();
    return g;
  };
  std::vector<Vec<D>> tangents;
  if constexpr (D == 2) {
    tangents.push_back(Vec<2>(-n[1], n[0]));
  } else {
    const Vec<3> t1 = n.unitOrthogonal();
    tangents = {t1, n.cross(t1)};
  }
  Eigen::Matrix<double, L, L> K = s.normal * stretch(n, false).transpose() * stretch(n, false);
  for (const auto& t : tangents) {
    if (s.tangential != 0) {
      const Row g = stretch(t, true);
      K += s.tangential * g.transpose() * g;
    }
    if (s.rolling != 0) {
      Spin<D> axis;
      if constexpr (D == 3) axis = t;   // twisting about n is free
      else axis[0] = 1;
      const Row g = turning(axis);
      K += s.rolling * g.transpose() * g;
    }
  }
  return K;
}

// B = sum_ab C_ab / D^2, G = (tr C - sum_ab C_ab / D) / (2 (D - 1)).
template <int D>
std::pair<double, double> bulk_and_shear(const Eigen::Matrix<double, D, D>& C) {
  const double all = C.sum();
  return {all / (D * D), (C.trace() - all / D) / (2 * (D - 1))};
}

constexpr double shift = 1e-12;     // regularisation of the Jacobi-scaled grain block
constexpr double zero_mode = 1e-9;  // a scaled pivot (or strain eigenvalue, relative) below this is a zero mode

}  // namespace

template <int D>
Eigen::SparseMatrix<double> stiffness_matrix(std::size_t grains, const std::vector<ElasticSpring<D>>& springs) {
  constexpr int B = block<D>, L = local_size<D>;
  const Eigen::Index strain = Eigen::Index(B * grains);
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(springs.size() * L * L);
  for (const auto& s : springs) {
    const auto k = spring_stiffness<D>(s);
    Eigen::Index index[L];
    for (int a = 0; a < B; ++a) index[a] = B * Eigen::Index(s.i) + a, index[B + a] = B * Eigen::Index(s.j) + a;
    for (int a = 0; a < D; ++a) index[2 * B + a] = strain + a;
    for (int a = 0; a < L; ++a)
      for (int b = 0; b < L; ++b)
        if (k(a, b) != 0) entries.emplace_back(index[a], index[b], k(a, b));
  }
  Eigen::SparseMatrix<double> K(strain + D, strain + D);
  K.setFromTriplets(entries.begin(), entries.end());   // duplicates are summed
  return K;
}

template <int D>
ElasticModuli<D> elastic_moduli(std::size_t grains, double volume, const std::vector<ElasticSpring<D>>& springs,
                                const ElasticModuliOptions& options) {
  using Index = Eigen::Index;
  using Mat = Eigen::Matrix<double, D, D>;
  constexpr int B = block<D>;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ElasticModuli<D> out;

  // Reuss estimate and Z2 from the static forces.
  double count = 0, sum_f = 0, sum_z2 = 0, sum_fr = 0, sum_w = 0;
  for (const auto& s : springs) {
    if (std::abs(s.normal_force) <= options.zero_force || s.contact_stiffness <= 0) continue;
    const double kn = s.contact_stiffness, fn = s.normal_force;
    double w = fn * fn / kn;   // complementary energy per unit force scale, times 2
    if (s.tangential > 0) w += s.tangential_force * s.tangential_force / s.tangential;
    if (s.rolling > 0) w += s.rolling_moment * s.rolling_moment / s.rolling;
    count += 1, sum_f += fn, sum_z2 += kn * w, sum_fr += fn * s.branch.norm(), sum_w += w;
  }
  out.z2 = count > 0 ? (sum_z2 / count) / ((sum_f / count) * (sum_f / count)) : nan;
  out.bulk_reuss = sum_w > 0 ? sum_fr * sum_fr / (D * D * volume * sum_w) : nan;

  // Kept degrees of freedom: those some spring resists (a grain without springs is a rattler).
  const Eigen::SparseMatrix<double> K = stiffness_matrix<D>(grains, springs);
  const Index grain_dofs = Index(B * grains);
  const Eigen::VectorXd diagonal = K.diagonal();
  std::vector<Index> kept_index(grain_dofs, -1);
  std::vector<Index> kept;
  for (Index k = 0; k < grain_dofs; ++k)
    if (diagonal[k] != 0) kept_index[k] = Index(kept.size()), kept.push_back(k);
  const Index n = Index(kept.size());
  std::vector<char> in_network(grains, 0);
  for (const auto& s : springs) in_network[s.i] = in_network[s.j] = 1;
  for (char c : in_network) out.grains += c;
  out.dofs = std::size_t(n);

  // Split K into the grain block (Jacobi-scaled), the grain-strain coupling and the strain block.
  Eigen::VectorXd scale(n);
  for (Index k = 0; k < n; ++k) scale[k] = 1 / std::sqrt(std::abs(diagonal[kept[k]]));
  std::vector<Eigen::Triplet<double>> grain_entries;
  Eigen::MatrixXd coupling = Eigen::MatrixXd::Zero(n, D);   // K_u,eps (unscaled)
  Mat strain_block = Mat::Zero();
  for (Index col = 0; col < K.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(K, col); it; ++it) {
      const Index row = it.row();
      if (row < grain_dofs && col < grain_dofs)
        grain_entries.emplace_back(kept_index[row], kept_index[col], it.value() * scale[kept_index[row]] * scale[kept_index[col]]);
      else if (row < grain_dofs)
        coupling(kept_index[row], col - grain_dofs) = it.value();
      else if (col >= grain_dofs)
        strain_block(row - grain_dofs, col - grain_dofs) = it.value();
    }
  out.voigt = strain_block / volume;
  std::tie(out.bulk_voigt, out.shear_voigt) = bulk_and_shear<D>(out.voigt);

  // Relax the grains at fixed strain: K_uu X = -K_u,eps (scaled: A Y = -S K_u,eps, X = S Y).
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, D);
  if (n > 0) {
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(grain_entries.begin(), grain_entries.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
    ldlt.setShift(shift);
    ldlt.compute(A);
    if (ldlt.info() != Eigen::Success) {   // a pivot of exactly -shift: a negative mode, report, do not guess
      out.unstable_modes = 1;
      out.stiffness.setConstant(nan);
      out.bulk = out.shear = nan;
      return out;
    }
    // vectorD() returns a copy: taken once, not once a pivot (the loop was quadratic, 11 s at 1e5 disks).
    const Eigen::VectorXd pivots = ldlt.vectorD();
    for (Index k = 0; k < n; ++k) {
      if (pivots[k] < -zero_mode) ++out.unstable_modes;
      else if (pivots[k] < zero_mode) ++out.floppy_modes;
    }
    const Eigen::MatrixXd rhs = -(scale.asDiagonal() * coupling);
    Eigen::MatrixXd Y = ldlt.solve(rhs);
    for (int refine = 0; refine < 3; ++refine) Y += ldlt.solve(Eigen::MatrixXd(rhs - A * Y));
    X = scale.asDiagonal() * Y;
  }
  // Summed coefficient by coefficient: Eigen's blocked product would cut the long sum where the processor's
  // caches say, so that its last bits, and a loose network's near-zero moduli with them, depended on the
  // machine.
  Mat S = strain_block + coupling.transpose().lazyProduct(X);
  S = 0.5 * (S + S.transpose()).eval();

  // Zero and negative modes of the condensed stiffness, against the Voigt stiffness's scale.
  const Eigen::SelfAdjointEigenSolver<Mat> voigt_modes(strain_block), modes(S);
  const double reference = voigt_modes.eigenvalues().cwiseAbs().maxCoeff();
  for (int a = 0; a < D; ++a) {
    const double e = modes.eigenvalues()[a];
    if (e < -zero_mode * reference) ++out.unstable_modes;
    else if (e <= zero_mode * reference) ++out.mechanisms;
  }
  out.stiffness = S / volume;
  std::tie(out.bulk, out.shear) = bulk_and_shear<D>(out.stiffness);
  // Along a mechanism the network has no stiffness, and the condensation leaves round-off there, of either
  // sign (B = -2.6e-9 at loose stages whose Voigt scale is 1e4): such a B or G reads 0.
  if (out.mechanisms > 0)
    for (double* modulus : {&out.bulk, &out.shear})
      if (std::abs(*modulus) <= zero_mode * reference / volume) *modulus = 0;
  if (out.unstable_modes > 0) {   // not a stable state of the network: no elastic response to report
    out.stiffness.setConstant(nan);
    out.bulk = out.shear = nan;
    return out;
  }

  if (options.keep_response && out.mechanisms == 0) {
    const Mat compliance = S.inverse();
    for (int a = 0; a < D; ++a) {
      ElasticResponse<D>& r = out.response[a];
      r.strain = -volume * compliance.col(a);   // a compressive increment shortens the cell
      const Eigen::VectorXd u = X * r.strain;
      r.displacement.assign(grains, Vec<D>::Zero());
      r.rotation.assign(grains, Spin<D>::Zero());
      for (Index k = 0; k < n; ++k) {
        const Index g = kept[k] / B, c = kept[k] % B;
        if (c < D) r.displacement[g][c] = u[k];
        else r.rotation[g][c - D] = u[k];
      }
    }
  }
  return out;
}

template Eigen::SparseMatrix<double> stiffness_matrix<2>(std::size_t, const std::vector<ElasticSpring<2>>&);
template Eigen::SparseMatrix<double> stiffness_matrix<3>(std::size_t, const std::vector<ElasticSpring<3>>&);
template ElasticModuli<2> elastic_moduli<2>(std::size_t, double, const std::vector<ElasticSpring<2>>&,
                                            const ElasticModuliOptions&);
template ElasticModuli<3> elastic_moduli<3>(std::size_t, double, const std::vector<ElasticSpring<3>>&,
                                            const ElasticModuliOptions&);

}  // namespace grains
