// AVX2 build of the steady contacts of spheres (linear_contacts.hpp), for processors without AVX-512: four
// pairs a vector, each batch filling half of a Results8. Compiled for AVX2 whatever the build flags and
// without FMA contraction (engine/CMakeLists.txt). It mirrors linear_contacts_avx512.cpp line by line
// (which mirrors contact_forces.hpp / linear_contact_law.hpp / contact_step.hpp), in the same order; where
// that one computes a root or quotient on some lanes only and keeps another value elsewhere, this one
// computes it on every lane and blends.
#include "interactions/linear_contacts.hpp"

#include "interactions/pair_avx2.hpp"

namespace grains::linear_contacts {
namespace {

using namespace pair_avx2;

GRAINS_AVX2_PAIRS inline V dot(const V a[3], const V b[3]) { return add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2])); }
// Eigen's cross product: (a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0).
GRAINS_AVX2_PAIRS inline void cross(const V a[3], const V b[3], V out[3]) {
  out[0] = sub(mul(a[1], b[2]), mul(a[2], b[1]));
  out[1] = sub(mul(a[2], b[0]), mul(a[0], b[2]));
  out[2] = sub(mul(a[0], b[1]), mul(a[1], b[0]));
}
GRAINS_AVX2_PAIRS inline void scaled(V s, const V v[3], V out[3]) {
  for (int a = 0; a < 3; ++a) out[a] = mul(s, v[a]);
}
// The lanes' 3-vectors a[3 idx + 0..2].
GRAINS_AVX2_PAIRS inline void gather3(const double* a, const Lanes4& idx3, V out[3]) {
  for (int c = 0; c < 3; ++c) out[c] = gather(a + c, idx3);
}

// ContactForces::tangential_force (3D) on the steady lanes m, as in linear_contacts_avx512.cpp.
GRAINS_AVX2_PAIRS void friction(const Input& in, const Contacts4<3>& c, V m, const V n[3], V elastic, V fn, V d,
                                V force[3], Results8& b, unsigned half) {
  const Lanes4 k3 = times(c.kl, 3), i3 = times(c.il, 3), j3 = times(c.jl, 3);
  // Lever arms to the middle of the overlap.
  const V half_overlap = mul(all(0.5), sub(c.Rsum, d));
  const V arm_i = sub(c.Ri, half_overlap), arm_j = sub(c.Rj, half_overlap);
  const V kt = all(in.friction_stiffness), ct = all(in.friction_damping_ratio * in.c);
  const V bound = mul(all(in.mu), in.elastic_bound ? elastic : fn);
  V wi[3], wj[3], ui[3], uj[3];
  gather3(in.angular_velocity, i3, wi), gather3(in.angular_velocity, j3, wj);
  gather3(in.velocity, i3, ui), gather3(in.velocity, j3, uj);
  // The pair at the start and the middle of the step (ContactForces::spring_motion), from the half-step velocities.
  V hv[3], bfr[3], mid[3], nb[3], nm[3], flow_mid[3];
  for (int a = 0; a < 3; ++a) {
    hv[a] = sub(uj[a], ui[a]);
    bfr[a] = sub(in.affine ? div(c.r[a], all(in.scale[a])) : c.r[a], mul(all(in.dt), hv[a]));
    mid[a] = mul(all(0.5), add(bfr[a], c.r[a]));
  }
  const V d_mid = _mm256_sqrt_pd(dot(mid, mid));
  const V inverse_mid = div(all(1.0), d_mid), inverse_before = div(all(1.0), _mm256_sqrt_pd(dot(bfr, bfr)));
  for (int a = 0; a < 3; ++a) {
    nm[a] = mul(mid[a], inverse_mid), nb[a] = mul(bfr[a], inverse_before);
    flow_mid[a] = in.affine ? mul(all(in.flow_factor[a]), c.r[a]) : zero();
  }
  const V half_mid = mul(all(0.5), sub(c.Rsum, d_mid));
  const V arm_i_mid = sub(c.Ri, half_mid), arm_j_mid = sub(c.Rj, half_mid);
  // turn_into_tangent_plane(xi, n_before, n): the rotation that takes n_before to n, then the rounding's part along n off.
  V xi[3];
  gather3(in.tangential, k3, xi);
  const V turn = div(dot(xi, n), add(all(1.0), dot(nb, n)));
  for (int a = 0; a < 3; ++a) xi[a] = sub(xi[a], mul(turn, add(nb[a], n[a])));
  const V along = dot(xi, n);
  for (int a = 0; a < 3; ++a) xi[a] = sub(xi[a], mul(along, n[a]));
  // vt = (v_j - w_j x (R_j n)) - (v_i + w_i x (R_i n)) + flow at the middle of the step, then its part in the
  // tangent plane there and (to rounding the same) in the current one.
  V lever_i[3], lever_j[3], lever_i_mid[3], lever_j_mid[3], spin_i[3], spin_j[3], vt[3];
  scaled(arm_i, n, lever_i), scaled(arm_j, n, lever_j);
  scaled(arm_i_mid, nm, lever_i_mid), scaled(arm_j_mid, nm, lever_j_mid);
  cross(wj, lever_j_mid, spin_j), cross(wi, lever_i_mid, spin_i);
  for (int a = 0; a < 3; ++a) vt[a] = add(sub(sub(uj[a], spin_j[a]), add(ui[a], spin_i[a])), flow_mid[a]);
  const V normal_mid = dot(vt, nm);
  for (int a = 0; a < 3; ++a) vt[a] = sub(vt[a], mul(normal_mid, nm[a]));
  const V normal = dot(vt, n);
  for (int a = 0; a < 3; ++a) vt[a] = sub(vt[a], mul(normal, n[a]));
  // The spring, the force and the Coulomb cap.
  const V minus_kt = neg(kt);
  V ft[3];
  for (int a = 0; a < 3; ++a) {
    xi[a] = add(xi[a], mul(vt[a], all(in.dt)));
    ft[a] = sub(mul(minus_kt, xi[a]), mul(ct, vt[a]));
  }
  const V mag2 = dot(ft, ft);
  const V slides = both(m, greater(mag2, mul(bound, bound)));
  if (bits(slides)) {   // cap the force; shorten the spring only if it alone passes the bound
    const V cap = blend(slides, all(1.0), div(bound, blend(slides, all(1.0), _mm256_sqrt_pd(mag2))));
    for (int a = 0; a < 3; ++a) ft[a] = blend(slides, ft[a], mul(ft[a], cap));
    const V reach = blend(slides, all(1.0), div(bound, kt)), stretch2 = dot(xi, xi);
    const V shortened = both(slides, greater(stretch2, mul(reach, reach)));
    if (bits(shortened)) {
      const V scale = blend(shortened, all(1.0), div(reach, blend(shortened, all(1.0), _mm256_sqrt_pd(stretch2))));
      for (int a = 0; a < 3; ++a) xi[a] = blend(shortened, xi[a], mul(xi[a], scale));
    }
  }
  alignas(32) double spring[3][4];
  for (int a = 0; a < 3; ++a) _mm256_store_pd(spring[a], xi[a]);
  for (unsigned lanes = bits(m); lanes; lanes &= lanes - 1) {
    const unsigned l = unsigned(__builtin_ctz(lanes));
    for (int a = 0; a < 3; ++a) in.tangential[k3.at[l] + a] = spring[a][l];
  }
  // Torques: (-R_j n) x F_t on j, (R_i n) x (-F_t) on i.
  V lever[3], minus_ft[3], torque[3];
  scaled(neg(arm_j), n, lever);
  cross(lever, ft, torque);
  for (int a = 0; a < 3; ++a) _mm256_store_pd(b.torque_j[a] + half, torque[a]);
  for (int a = 0; a < 3; ++a) minus_ft[a] = neg(ft[a]);
  cross(lever_i, minus_ft, torque);
  for (int a = 0; a < 3; ++a) _mm256_store_pd(b.torque_i[a] + half, torque[a]);
  for (int a = 0; a < 3; ++a) force[a] = add(force[a], ft[a]);
}

GRAINS_AVX2_PAIRS long evaluate4(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs,
                                 const std::uint8_t* images, std::size_t q, std::size_t left, const Output& out) {
  // The pairs' geometry; the steady contacts among them. Loads take every live lane, not only the steady
  // ones; the other lanes' results are stored too, and never read.
  const Contacts4<3> c(rows, pairs, images, q, left, in.partner, in.shift, in.position, in.radius, in.touched, in.evaluation);
  const V* r = c.r;
  const V d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
  const V m = widen(c.steady);
  const unsigned steady = bits(c.steady);
  Results8& b = out.results[q / 8];
  const unsigned half = q & 7;   // 0 or 4: the block's first or second half (the first one writes the bits)
  b.steady = std::uint8_t(half ? b.steady | steady << 4 : steady);
  if (!steady) return 0;

  const Lanes4 i3 = times(c.il, 3), j3 = times(c.jl, 3);
  const V d = _mm256_sqrt_pd(d2);
  const V n[3] = {div(r[0], d), div(r[1], d), div(r[2], d)};
  V vi[3], vj[3], dv[3];
  gather3(in.velocity_predicted, i3, vi), gather3(in.velocity_predicted, j3, vj);
  for (int a = 0; a < 3; ++a) dv[a] = sub(vj[a], vi[a]);
  V vn = add(add(mul(dv[0], n[0]), mul(dv[1], n[1])), mul(dv[2], n[2]));
  if (in.affine) {
    V flow[3];
    for (int a = 0; a < 3; ++a) flow[a] = mul(all(in.strain_rate[a]), r[a]);
    vn = add(vn, add(add(mul(flow[0], n[0]), mul(flow[1], n[1])), mul(flow[2], n[2])));
  }

  // LinearContactLaw::force (global k, c) for a steady contact: onset {1, 0}, then the release charge.
  const V overlap = sub(Rsum, d);
  const V limit = mul(all(in.overlap_limit), _mm256_min_pd(Rj, Ri));   // std::min(Ri, Rj)
  const V clamped = both(m, greater(overlap, limit));
  const V kn = all(in.k), cn = all(in.c);
  const V elastic = mul(kn, blend(clamped, overlap, limit));
  V f = sub(add(elastic, mul(kn, all(0.0))), mul(mul(cn, vn), all(1.0)));
  const V releasing = both(both(_mm256_andnot_pd(clamped, m), greater(f, zero())), greater(vn, zero()));
  if (bits(releasing)) {
    const V mi = gather(in.mass, c.il), mj = gather(in.mass, c.jl);
    const V mm = mul(mi, mj);
    const V fall = mul(all(in.dt), add(mul(mul(kn, vn), mm), mul(mul(cn, f), add(mi, mj))));
    const V charged = both(releasing, less(mul(f, mm), mul(all(2.0), fall)));
    if (bits(charged)) {   // release_force(f, fall / mm)
      const V drop = blend(charged, all(1.0), div(fall, mm));
      const V sigma = blend(charged, zero(), div(f, drop));
      const V within = _mm256_cmp_pd(sigma, all(1.0), _CMP_LE_OQ);
      const V rr = blend(within, sub(sigma, all(1.0)), sigma);
      const V weight = blend(within, sub(all(2.0), sigma), sigma);
      const V two_r_less_one = sub(mul(all(2.0), rr), all(1.0));
      const V charge = mul(div(mul(mul(drop, two_r_less_one), two_r_less_one), all(8.0)), weight);
      f = blend(charged, f, add(f, charge));
    }
  }
  f = _mm256_max_pd(f, zero());   // std::max(0.0, f)
  V force[3] = {mul(f, n[0]), mul(f, n[1]), mul(f, n[2])};
  if (in.tangential) friction(in, c, m, n, elastic, f, d, force, b, half);   // the springs take the cell's flow themselves (in.flow_factor)
  std::memcpy(b.partner + half, c.jl.at, sizeof c.jl.at);
  for (int a = 0; a < 3; ++a) _mm256_store_pd(b.f[a] + half, force[a]);
  for (int a = 0; a < 3; ++a) _mm256_store_pd(b.r[a] + half, r[a]);
  return __builtin_popcount(bits(clamped));
}

}  // namespace

long evaluate_avx2(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                   std::size_t n, const Output& out) {
  long clamped = 0;
  for (std::size_t q = 0; q < n; q += 4) clamped += evaluate4(in, rows, pairs, images, q, n - q, out);
  return clamped;
}

}  // namespace grains::linear_contacts
