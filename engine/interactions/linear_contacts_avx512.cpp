// AVX-512 build of the steady contacts of spheres (linear_contacts.hpp). Compiled for AVX-512
// whatever the build flags and without FMA contraction (engine/CMakeLists.txt). Every line mirrors an
// expression of contact_forces.hpp / linear_contact_law.hpp / contact_step.hpp, in the same order.
#include "interactions/linear_contacts.hpp"

#include "interactions/pair_avx512.hpp"

namespace grains::linear_contacts {
namespace {

using namespace pair_avx512;

GRAINS_AVX512_PAIRS inline V dot(const V a[3], const V b[3]) { return add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2])); }
// Eigen's cross product: (a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0).
GRAINS_AVX512_PAIRS inline void cross(const V a[3], const V b[3], V out[3]) {
  out[0] = sub(mul(a[1], b[2]), mul(a[2], b[1]));
  out[1] = sub(mul(a[2], b[0]), mul(a[0], b[2]));
  out[2] = sub(mul(a[0], b[1]), mul(a[1], b[0]));
}
GRAINS_AVX512_PAIRS inline void scaled(V s, const V v[3], V out[3]) {
  for (int a = 0; a < 3; ++a) out[a] = mul(s, v[a]);
}

// ContactForces::tangential_force (3D) on the steady lanes m: turns and advances the springs, caps them,
// adds F_t to `force` (on j) and stores both torques. fn: the normal force, elastic: k_n delta_used.
// Loads take every live lane (see evaluate8).
GRAINS_AVX512_PAIRS void friction(const Input& in, const Contacts8<3>& c, __mmask8 live, __mmask8 m, const V n[3], V elastic, V fn, V d,
                                  V force[3], Results8& b) {
  const __m256i k3 = _mm256_mullo_epi32(c.k, _mm256_set1_epi32(3));
  // Lever arms to the middle of the overlap.
  const V half_overlap = mul(all(0.5), sub(c.Rsum, d));
  const V arm_i = sub(c.Ri, half_overlap), arm_j = sub(c.Rj, half_overlap);
  const V kt = all(in.friction_stiffness), ct = all(in.friction_damping_ratio * in.c);
  const V bound = mul(all(in.mu), in.elastic_bound ? elastic : fn);
  V wi[3], wj[3], ui[3], uj[3];
  for (int a = 0; a < 3; ++a) wi[a] = gather(in.angular_velocity + a, c.iD, live), wj[a] = gather(in.angular_velocity + a, c.jD, live);
  for (int a = 0; a < 3; ++a) ui[a] = gather(in.velocity + a, c.iD, live), uj[a] = gather(in.velocity + a, c.jD, live);
  // The pair at the start and the middle of the step (ContactForces::spring_motion), from the half-step velocities.
  V hv[3], bfr[3], mid[3], nb[3], nm[3], flow_mid[3];
  for (int a = 0; a < 3; ++a) {
    hv[a] = sub(uj[a], ui[a]);
    bfr[a] = sub(in.affine ? div(c.r[a], all(in.scale[a])) : c.r[a], mul(all(in.dt), hv[a]));
    mid[a] = mul(all(0.5), add(bfr[a], c.r[a]));
  }
  const V d_mid = _mm512_sqrt_pd(dot(mid, mid));
  const V inverse_mid = div(all(1.0), d_mid), inverse_before = div(all(1.0), _mm512_sqrt_pd(dot(bfr, bfr)));
  for (int a = 0; a < 3; ++a) {
    nm[a] = mul(mid[a], inverse_mid), nb[a] = mul(bfr[a], inverse_before);
    flow_mid[a] = in.affine ? mul(all(in.flow_factor[a]), c.r[a]) : _mm512_setzero_pd();
  }
  const V half_mid = mul(all(0.5), sub(c.Rsum, d_mid));
  const V arm_i_mid = sub(c.Ri, half_mid), arm_j_mid = sub(c.Rj, half_mid);
  // turn_into_tangent_plane(xi, n_before, n): the rotation that takes n_before to n, then the rounding's part along n off.
  V xi[3];
  for (int a = 0; a < 3; ++a) xi[a] = gather(in.tangential + a, k3, live);
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
  const __mmask8 slides = _mm512_mask_cmp_pd_mask(m, mag2, mul(bound, bound), _CMP_GT_OQ);
  if (slides) {   // cap the force; shorten the spring only if it alone passes the bound
    const V cap = _mm512_mask_div_pd(all(1.0), slides, bound, _mm512_mask_sqrt_pd(all(1.0), slides, mag2));
    for (int a = 0; a < 3; ++a) ft[a] = _mm512_mask_mul_pd(ft[a], slides, ft[a], cap);
    const V reach = _mm512_mask_div_pd(all(1.0), slides, bound, kt), stretch2 = dot(xi, xi);
    const __mmask8 shortened = _mm512_mask_cmp_pd_mask(slides, stretch2, mul(reach, reach), _CMP_GT_OQ);
    if (shortened) {
      const V scale = _mm512_mask_div_pd(all(1.0), shortened, reach, _mm512_mask_sqrt_pd(all(1.0), shortened, stretch2));
      for (int a = 0; a < 3; ++a) xi[a] = _mm512_mask_mul_pd(xi[a], shortened, xi[a], scale);
    }
  }
  for (int a = 0; a < 3; ++a) _mm512_mask_i32scatter_pd(in.tangential + a, m, k3, xi[a], 8);
  // Torques: (-R_j n) x F_t on j, (R_i n) x (-F_t) on i.
  V lever[3], minus_ft[3], torque[3];
  scaled(neg(arm_j), n, lever);
  cross(lever, ft, torque);
  for (int a = 0; a < 3; ++a) _mm512_mask_store_pd(b.torque_j[a], m, torque[a]);
  for (int a = 0; a < 3; ++a) minus_ft[a] = neg(ft[a]);
  cross(lever_i, minus_ft, torque);
  for (int a = 0; a < 3; ++a) _mm512_mask_store_pd(b.torque_i[a], m, torque[a]);
  for (int a = 0; a < 3; ++a) force[a] = add(force[a], ft[a]);
}

GRAINS_AVX512_PAIRS long evaluate8(const Input& in, const ImageShifts<3>& shifts, const std::uint32_t* rows, const std::uint32_t* pairs,
                                      const std::uint8_t* images, std::size_t q, __mmask8 live, const Output& out) {
  // The pairs' geometry; the steady contacts among them (touched at the last evaluation too). Loads take
  // every live lane, not only the steady ones, so they need not wait for the stamps: the other lanes'
  // results are never stored.
  const Contacts8<3> c(rows, pairs, images, q, live, in.partner, shifts, in.position, in.radius, in.touched, in.evaluation);
  const __m256i i = c.i, j = c.j, i3 = c.iD, j3 = c.jD;
  const V* r = c.r;
  const V d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
  const __mmask8 m = c.steady;
  Results8& b = out.results[q / 8];   // q is a multiple of 8
  b.steady = m;
  if (!m) return 0;

  const V d = _mm512_sqrt_pd(d2);
  const V n[3] = {div(r[0], d), div(r[1], d), div(r[2], d)};
  V dv[3];
  for (int a = 0; a < 3; ++a) dv[a] = sub(gather(in.velocity_predicted + a, j3, live), gather(in.velocity_predicted + a, i3, live));
  V vn = add(add(mul(dv[0], n[0]), mul(dv[1], n[1])), mul(dv[2], n[2]));
  if (in.affine) {
    V flow[3];
    for (int a = 0; a < 3; ++a) flow[a] = mul(all(in.strain_rate[a]), r[a]);
    vn = add(vn, add(add(mul(flow[0], n[0]), mul(flow[1], n[1])), mul(flow[2], n[2])));
  }

  // LinearContactLaw::force (global k, c) for a steady contact: onset {1, 0}, then the release charge.
  const V overlap = sub(Rsum, d);
  const V limit = mul(all(in.overlap_limit), _mm512_min_pd(Rj, Ri));   // std::min(Ri, Rj)
  const __mmask8 clamped = _mm512_mask_cmp_pd_mask(m, overlap, limit, _CMP_GT_OQ);
  const V kn = all(in.k), cn = all(in.c);
  const V elastic = mul(kn, _mm512_mask_blend_pd(clamped, overlap, limit));
  V f = sub(add(elastic, mul(kn, all(0.0))), mul(mul(cn, vn), all(1.0)));
  const __mmask8 releasing = _mm512_mask_cmp_pd_mask(m & ~clamped, f, all(0.0), _CMP_GT_OQ) &
                             _mm512_mask_cmp_pd_mask(m, vn, all(0.0), _CMP_GT_OQ);
  if (releasing) {
    const V mi = gather(in.mass, i, releasing), mj = gather(in.mass, j, releasing);
    const V mm = mul(mi, mj);
    const V fall = mul(all(in.dt), add(mul(mul(kn, vn), mm), mul(mul(cn, f), add(mi, mj))));
    const __mmask8 charged = _mm512_mask_cmp_pd_mask(releasing, mul(f, mm), mul(all(2.0), fall), _CMP_LT_OQ);
    if (charged) {   // release_force(f, fall / mm)
      const V drop = _mm512_mask_div_pd(all(1.0), charged, fall, mm);
      const V sigma = _mm512_mask_div_pd(all(0.0), charged, f, drop);
      const __mmask8 within = _mm512_cmp_pd_mask(sigma, all(1.0), _CMP_LE_OQ);
      const V rr = _mm512_mask_blend_pd(within, sub(sigma, all(1.0)), sigma);
      const V weight = _mm512_mask_blend_pd(within, sub(all(2.0), sigma), sigma);
      const V two_r_less_one = sub(mul(all(2.0), rr), all(1.0));
      const V charge = mul(div(mul(mul(drop, two_r_less_one), two_r_less_one), all(8.0)), weight);
      f = _mm512_mask_add_pd(f, charged, f, charge);
    }
  }
  f = _mm512_max_pd(f, all(0.0));   // std::max(0.0, f)
  V force[3] = {mul(f, n[0]), mul(f, n[1]), mul(f, n[2])};
  if (in.tangential) friction(in, c, live, m, n, elastic, f, d, force, b);   // the springs take the cell's flow themselves (in.flow_factor)
  _mm256_mask_storeu_epi32(b.partner, m, j);
  for (int a = 0; a < 3; ++a) _mm512_mask_store_pd(b.f[a], m, force[a]);
  for (int a = 0; a < 3; ++a) _mm512_mask_store_pd(b.r[a], m, r[a]);
  return __builtin_popcount(clamped & m);
}

}  // namespace

long evaluate_avx512(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                     std::size_t n, const Output& out) {
  const ImageShifts<3> shifts(in.shift);
  return in_batches(n, [&](std::size_t q, __mmask8 lanes) { return evaluate8(in, shifts, rows, pairs, images, q, lanes, out); });
}

}  // namespace grains::linear_contacts
