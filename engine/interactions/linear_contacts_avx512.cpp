// AVX-512 build of the steady frictionless contacts (linear_contacts_avx512.hpp). Compiled for AVX-512
// whatever the build flags and without FMA contraction (engine/CMakeLists.txt). Every line mirrors an
// expression of contact_forces.hpp / linear_contact_law.hpp / contact_step.hpp, in the same order.
#include "interactions/linear_contacts_avx512.hpp"

#include "interactions/pair_avx512.hpp"

namespace grains::linear_contacts_avx512 {
namespace {

using namespace pair_avx512;

GRAINS_AVX512_PAIRS long evaluate8(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs,
                                      const std::uint8_t* images, std::size_t q, __mmask8 live, const Output& out) {
  // The pairs' geometry; the steady contacts among them (touched at the last evaluation too).
  const Contacts8<3> c(rows, pairs, images, q, live, in.partner, in.shift, in.position, in.radius, in.touched, in.evaluation);
  const __m256i i = c.i, j = c.j, i3 = c.iD, j3 = c.jD;
  const V* r = c.r;
  const V d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
  const __mmask8 m = c.steady;
  out.steady[q / 8] = m;   // q is a multiple of 8
  if (!m) return 0;

  const V d = _mm512_sqrt_pd(d2);
  const V n[3] = {div(r[0], d), div(r[1], d), div(r[2], d)};
  V dv[3];
  for (int a = 0; a < 3; ++a) dv[a] = sub(gather(in.velocity_predicted + a, j3, m), gather(in.velocity_predicted + a, i3, m));
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
  _mm512_mask_storeu_pd(out.fx + q, m, mul(f, n[0]));
  _mm512_mask_storeu_pd(out.fy + q, m, mul(f, n[1]));
  _mm512_mask_storeu_pd(out.fz + q, m, mul(f, n[2]));
  _mm512_mask_storeu_pd(out.rx + q, m, r[0]);
  _mm512_mask_storeu_pd(out.ry + q, m, r[1]);
  _mm512_mask_storeu_pd(out.rz + q, m, r[2]);
  return __builtin_popcount(clamped & m);
}

}  // namespace

long evaluate(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
              std::size_t n, const Output& out) {
  return in_batches(n, [&](std::size_t q, __mmask8 lanes) { return evaluate8(in, rows, pairs, images, q, lanes, out); });
}

}  // namespace grains::linear_contacts_avx512
