// AVX-512 build of the steady cohesive contacts (cohesive_contacts.hpp). Compiled for AVX-512
// whatever the build flags and without FMA contraction (engine/CMakeLists.txt). Every line mirrors an
// expression of contact_forces.hpp / adhesive_contact_law.hpp / contact_step.hpp, in the same order.
#include "interactions/cohesive_contacts.hpp"

#include <atomic>

#include "interactions/pair_avx512.hpp"

namespace grains::cohesive_contacts {
namespace {

using namespace pair_avx512;

template <bool Dense>
GRAINS_AVX512_PAIRS long evaluate8(const Input& in, const ImageShifts<2>& shifts, const std::uint32_t* rows, const std::uint32_t* pairs,
                                      const std::uint8_t* images, std::size_t q, __mmask8 live, const Output& out) {
  // The pairs' geometry; the steady contacts among them (touched at the last evaluation too). Loads take
  // every live lane, not only the steady ones, so they need not wait for the stamps: the other lanes'
  // contact results are never stored (Results8 gets zeros or a tail's force there).
  const Contacts8<2, Dense> c(rows, pairs, images, q, live, in.partner, shifts, in.position, in.radius, in.touched, in.evaluation,
                              in.slot_radius);
  const __m256i i = c.i, k = c.k, j = c.j, i2 = c.iD, j2 = c.jD;
  const std::uint32_t k0 = c.k0;
  const V rx = c.r[0], ry = c.r[1], d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
  __mmask8 m = c.steady;
  Results8& b = out.results[q / 8];   // q is a multiple of 8
  b.steady = m;
  // The lanes that interact: by the pair filter's test, d^2 < ((R_i + R_j) + tail)^2, over the shell's
  // entries; else the lanes are the filter's selection, every one interacting.
  __mmask8 interacting = live;
  if (out.interacting) {
    const V reach = add(Rsum, all(in.tail_reach));
    b.interacting = interacting = _mm512_mask_cmp_pd_mask(live, d2, mul(reach, reach), _CMP_LT_OQ);
  }
  // Open pairs within the attraction range (the pair loop's tail) and, over the shell, pairs that do not
  // interact: their results are stored too (below), so that the pair loop adds whole blocks without a branch
  // per pair.
  const __mmask8 tail = __mmask8(interacting & ~c.touching), quiet = __mmask8(live & ~interacting);

  const V d = _mm512_sqrt_pd(d2);
  const V inv_d = div(all(1.0), d);   // one division serves n, the spring's turn and the tail
  const V nx = mul(rx, inv_d), ny = mul(ry, inv_d);
  const V cn = per_entry<Dense>(in.damping, k, k0, live);
  const V dvx = sub(gather(in.velocity_predicted, j2, live), gather(in.velocity_predicted, i2, live));
  const V dvy = sub(gather(in.velocity_predicted + 1, j2, live), gather(in.velocity_predicted + 1, i2, live));
  V vn = add(mul(dvx, nx), mul(dvy, ny));
  V flow_x = _mm512_setzero_pd(), flow_y = _mm512_setzero_pd();
  if (in.affine) {
    flow_x = mul(all(in.strain_rate_x), rx), flow_y = mul(all(in.strain_rate_y), ry);
    vn = add(vn, add(mul(flow_x, nx), mul(flow_y, ny)));
  }

  // A contact parting within the step (its overlap less than the step's travel) goes to the portable code,
  // which keeps its parting charge (contact_step.hpp, parting): no steady contact here, its stamp as it was.
  const V overlap = sub(Rsum, d);
  const V travel = mul(vn, all(in.dt));
  if (const __mmask8 parts = _mm512_mask_cmp_pd_mask(m, travel, overlap, _CMP_GT_OQ)) {
    alignas(32) std::uint32_t entry[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(entry), k);
    for (unsigned l = parts; l; l &= l - 1)
      in.touched[Dense ? k0 + __builtin_ctz(l) : entry[__builtin_ctz(l)]] = in.evaluation - 1;
    m = __mmask8(m & ~parts);
    b.steady = m;
  }

  // Normal law (AdhesiveContactLaw::force with onset {1, 0}, no parting).
  const V limit = mul(all(in.overlap_limit), _mm512_min_pd(Rj, Ri));   // std::min(Ri, Rj)
  const __mmask8 clamped = _mm512_mask_cmp_pd_mask(m, overlap, limit, _CMP_GT_OQ);
  const V elastic = mul(all(in.k), _mm512_mask_blend_pd(clamped, overlap, limit));
  const V fn = sub(sub(elastic, all(in.attraction)), mul(cn, vn));

  // Friction (tangential_force, 2D): everything along t = z x n.
  const V half_overlap = mul(all(0.5), sub(Rsum, d));
  const V arm_i = sub(Ri, half_overlap), arm_j = sub(Rj, half_overlap);
  const V kt = all(in.friction_stiffness_ratio * in.k);
  const V ct = mul(all(in.friction_damping_ratio), cn);
  const V bound = mul(all(in.mu), in.elastic_bound ? elastic : fn);
  const V tx = neg(ny), ty = nx;   // t = (-n_y, n_x)
  const V wi = gather(in.angular_velocity, i, live), wj = gather(in.angular_velocity, j, live);
  const V hvx = sub(gather(in.velocity, j2, live), gather(in.velocity, i2, live));
  const V hvy = sub(gather(in.velocity + 1, j2, live), gather(in.velocity + 1, i2, live));
  // The relative velocity along the tangent of the step's middle, with the lever arms there (tangential_force).
  const V ux = in.affine ? add(hvx, mul(all(in.flow_factor_x), rx)) : add(hvx, _mm512_setzero_pd());
  const V uy = in.affine ? add(hvy, mul(all(in.flow_factor_y), ry)) : add(hvy, _mm512_setzero_pd());
  const V ut = add(mul(ux, tx), mul(uy, ty)), un = add(mul(ux, nx), mul(uy, ny));
  const V half_step = all(0.5 * in.dt);
  const V eps = mul(mul(half_step, ut), inv_d), d_mid = sub(d, mul(half_step, un));
  const V half_mid = mul(all(0.5), sub(Rsum, d_mid));
  const V arm_i_mid = sub(Ri, half_mid), arm_j_mid = sub(Rj, half_mid);
  const V vt = sub(sub(add(ut, mul(eps, un)), mul(wj, arm_j_mid)), mul(wi, arm_i_mid));
  V xi = add(per_entry<Dense>(in.tangential, k, k0, live), mul(vt, all(in.dt)));
  const V minus_kt = neg(kt);
  V ft = sub(mul(minus_kt, xi), mul(ct, vt));
  const __mmask8 slides = _mm512_mask_cmp_pd_mask(m, abs(ft), bound, _CMP_GT_OQ);
  if (slides) {   // cap the force; shorten the spring only if it alone passes the bound
    ft = _mm512_mask_blend_pd(slides, ft, copysign(bound, ft));
    const __mmask8 shortened = _mm512_mask_cmp_pd_mask(slides, abs(mul(kt, xi)), bound, _CMP_GT_OQ);
    xi = _mm512_mask_div_pd(xi, shortened, copysign(bound, xi), kt);
  }
  set_per_entry<Dense>(in.tangential, k, k0, m, xi);
  // The forces on j: a steady contact's, a tail's (AdhesiveContactLaw::tail(d - Rsum) * (1 / d) * r, as the pair
  // loop computes it), zero elsewhere. Zero torques and forces leave the sums they are added to as they were
  // (none of them is ever -0: they start at +0, and a sum is -0 only if both terms are).
  V fx = _mm512_maskz_mov_pd(m, add(mul(fn, nx), mul(ft, tx))), fy = _mm512_maskz_mov_pd(m, add(mul(fn, ny), mul(ft, ty)));
  if (tail) {
    const V gap = sub(d, Rsum);
    const V pull = mul(all(-in.attraction), sub(all(1.0), div(gap, all(in.range))));
    const V pull_d = mul(pull, inv_d);
    fx = _mm512_mask_mul_pd(fx, tail, pull_d, rx), fy = _mm512_mask_mul_pd(fy, tail, pull_d, ry);
  }
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(b.partner), j);
  _mm512_store_pd(b.torque_j, _mm512_maskz_mov_pd(m, mul(arm_j, ft)));
  _mm512_store_pd(b.torque_i, _mm512_maskz_mov_pd(m, mul(arm_i, ft)));
  _mm512_store_pd(b.fx, fx);
  _mm512_store_pd(b.fy, fy);
  _mm512_store_pd(b.rx, rx);
  _mm512_store_pd(b.ry, ry);
  b.ready = __mmask8(m | tail | quiet);

  // Rolling resistance (rolling_moment, 2D): a scalar spring, the bound a comparison of absolute values.
  if (in.rolling_angle) {
    const V spin = sub(wj, wi);
    V moment = _mm512_setzero_pd();
    if (in.rolling_stiffness > 0) {
      const V bound_r = mul(all(in.rolling_coefficient), elastic);
      V theta = add(per_entry<Dense>(in.rolling_angle, k, k0, live), mul(spin, all(in.dt)));
      const V minus_kr = all(-in.rolling_stiffness);
      moment = mul(minus_kr, theta);
      const __mmask8 rolls = _mm512_mask_cmp_pd_mask(m, abs(moment), bound_r, _CMP_GT_OQ);
      if (rolls) {
        moment = _mm512_mask_blend_pd(rolls, moment, copysign(bound_r, moment));
        theta = _mm512_mask_div_pd(theta, rolls, moment, minus_kr);
      }
      set_per_entry<Dense>(in.rolling_angle, k, k0, m, theta);
    }
    if (in.rolling_damping > 0) moment = sub(moment, mul(mul(mul(mul(all(in.rolling_damping), cn), Ri), Rj), spin));
    _mm512_store_pd(b.moment, _mm512_maskz_mov_pd(m, moment));
  }
  return __builtin_popcount(clamped & m);
}

std::atomic<long> dense_evaluations_{0};

}  // namespace

void note_dense_evaluation() { dense_evaluations_.fetch_add(1, std::memory_order_relaxed); }
long dense_evaluations() { return dense_evaluations_.load(); }

long evaluate_avx512(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                     std::size_t n, const Output& out) {
  const ImageShifts<2> shifts(in.shift);
  if (in.dense)
    return in_batches(n, [&](std::size_t q, __mmask8 lanes) { return evaluate8<true>(in, shifts, rows, pairs, images, q, lanes, out); });
  return in_batches(n, [&](std::size_t q, __mmask8 lanes) { return evaluate8<false>(in, shifts, rows, pairs, images, q, lanes, out); });
}

}  // namespace grains::cohesive_contacts
