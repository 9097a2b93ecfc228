// Elastic moduli of a contact network in an orthogonal periodic cell (consolidation paper section VI,
// physics.md section 9).
//
// Degrees of freedom: per grain D translations u and R rotations theta (R = 1 in 2D, 3 in 3D), and the
// D diagonal strains eps of the cell (positive = extension), order (D + R) N + D. A spring moves the
// contact point of j relative to that of i by
//   delta = u_j + theta_j x (-a_j n) - u_i - theta_i x (a_i n) + eps (*) r_ij
// (as the engine's tangential spring: lever arms a to the middle of the overlap) and turns j relative to
// i by phi = theta_j - theta_i; its energy is
//   1/2 [K_N (delta.n)^2 + K_T |delta_t|^2 + K_R |phi_perp|^2]
// (3D: phi_perp without the twist about n, which the rolling spring leaves free), and the stiffness
// matrix K is the Hessian of the sum. Only the contact stiffnesses enter, as in the paper: the
// geometric (prestress) terms F_N / d that the rotation of loaded springs adds are left out. Each is
// smaller than K_N by F_N / (K_N d), an overlap over a diameter (1e-5 at kappa = 1e5 and P* ~ 1), and
// with a distant bond's tail (F_N / d against -F0 / D0) by about D0 / a = 1e-3; but they act on the soft
// transverse modes: estimated at up to 1.5e-3 of G (100 type-2 disks at P* = 1) and 8e-4 in a cohesionless
// packing, B less.
//
// The grains relax at fixed strain: U = X eps with K_uu X = -K_u,eps, so the cell sees the condensed
// stiffness S = K_eps,eps + K_eps,u X (the inverse of the compliance obtained by solving K U = F_ext for
// unit stress increments, without inverting a compliance that is infinite along a mechanism), and
// C = S / V: sigma_a = C_ab eps_b (tension positive). Rattlers (no spring at all) and rotations no
// spring resists are removed; every other zero mode of K_uu (the packing's rigid translations, a grain
// rolling on a single frictional contact, a dangling chain) is orthogonal to the load, so K_uu is
// regularised: Jacobi-scaled to unit diagonal, shifted by 1e-12, factorised (sparse LDL^T) and the
// solution refined three times against the unshifted matrix.
#pragma once
#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/SparseCore>

#include "analysis/elastic_spring.hpp"

namespace grains {

template <int D> constexpr int rotations = D == 3 ? 3 : 1;

struct ElasticModuliOptions {
  double zero_force = 0;        // |F_N| <= zero_force carries no force (left out of Z2 and the Reuss estimate)
  bool keep_response = false;   // also return the response to unit stress increments
};

// The response to a unit compressive stress increment along one axis: the cell strain and every
// grain's displacement and rotation (zero for rattlers).
template <int D>
struct ElasticResponse {
  Vec<D> strain = Vec<D>::Zero();
  std::vector<Vec<D>> displacement;
  std::vector<Spin<D>> rotation;
};

template <int D>
struct ElasticModuli {
  using Matrix = Eigen::Matrix<double, D, D>;
  Matrix stiffness = Matrix::Zero();   // C: C_ab = d sigma_a / d eps_b over the cell's diagonal strains
  Matrix voigt = Matrix::Zero();       // C if every grain followed the strain affinely, without rotating
  // From C: B = sum_ab C_ab / D^2 (isotropic strain), G = (tr C - sum_ab C_ab / D) / (2 (D - 1)) (the
  // pure shears an orthogonal cell can apply); 2D with C11 = C22: B = (C11 + C12)/2, G = (C11 - C12)/2.
  double bulk = 0, shear = 0;
  double bulk_voigt = 0, shear_voigt = 0;   // the same from the Voigt stiffness: upper bounds of B and G
  // Reuss estimate from the static forces (sums over the interactions carrying force):
  //   B_R = (sum F_N |r|)^2 / (D^2 V sum [F_N^2 / K_N + F_T^2 / K_T + Gamma^2 / K_R]);
  // with Z2 = <F_N^2 + (K_N/K_T) F_T^2 + (K_N/K_R) Gamma^2> / <F_N>^2 it is the paper's
  // 27 z Phi K_N / (56 pi Z2) for 2D diameters uniform in [a/2, a] and uncorrelated forces.
  double bulk_reuss = 0, z2 = 0;
  int mechanisms = 0;       // strain directions the network does not resist (then B or G is 0 within round-off)
  int unstable_modes = 0;   // negative eigenvalues (distant bonds' negative stiffness): the moduli are then NaN
  int floppy_modes = 0;     // zero modes of the grains at fixed strain, rigid translations included
  std::size_t grains = 0;   // grains with at least one spring
  std::size_t dofs = 0;     // grain degrees of freedom kept
  std::array<ElasticResponse<D>, D> response;   // options.keep_response, and no mechanism or instability
};

// The full stiffness matrix, order (D + R) N + D: grain g's translations at (D + R) g, its rotation(s)
// next, the D cell strains last. Energy 1/2 q^T K q.
template <int D>
Eigen::SparseMatrix<double> stiffness_matrix(std::size_t grains, const std::vector<ElasticSpring<D>>& springs);

template <int D>
ElasticModuli<D> elastic_moduli(std::size_t grains, double volume, const std::vector<ElasticSpring<D>>& springs,
                                const ElasticModuliOptions& options = {});

extern template Eigen::SparseMatrix<double> stiffness_matrix<2>(std::size_t, const std::vector<ElasticSpring<2>>&);
extern template Eigen::SparseMatrix<double> stiffness_matrix<3>(std::size_t, const std::vector<ElasticSpring<3>>&);
extern template ElasticModuli<2> elastic_moduli<2>(std::size_t, double, const std::vector<ElasticSpring<2>>&,
                                                   const ElasticModuliOptions&);
extern template ElasticModuli<3> elastic_moduli<3>(std::size_t, double, const std::vector<ElasticSpring<3>>&,
                                                   const ElasticModuliOptions&);

}  // namespace grains
