// The batched kernel of the steady cohesive contacts (cohesive_contacts.hpp), written once for both vector
// widths: W is pair_avx2::Width4 or pair_avx512::Width8, their operations, masks and the batch's loads and
// stores (Contacts4, Contacts8). Every line mirrors an expression of contact_forces.hpp /
// adhesive_contact_law.hpp / contact_step.hpp, in the same order. Where a rare branch (a contact parting
// within the step, a spring sliding or rolling) takes some lanes, the others keep their value through a
// blend: one masked instruction at eight lanes, the operation on every lane at four.
//
// Included by one file per width (cohesive_contacts_avx2.cpp, cohesive_contacts_avx512.cpp), compiled
// without FMA contraction (engine/CMakeLists.txt), which first defines GRAINS_PAIR_KERNEL as that width's
// target attribute.
#pragma once
#include <cstddef>
#include <cstdint>

#include "interactions/cohesive_contacts.hpp"

#ifndef GRAINS_PAIR_KERNEL
#error "define GRAINS_PAIR_KERNEL as the width's target attribute before including this header"
#endif

namespace grains::cohesive_contacts {
namespace {

// CompletesTail: the kernel also evaluates the open pairs in the attraction's range (the pair loop's tail)
// and, over the shell, gives the pairs that do not interact zero results (Results8::ready), so that the
// pair loop adds whole blocks without a branch per pair; else it leaves both to the pair loop.
template <class W, bool CompletesTail>
struct Kernel : W {
  using typename W::V, typename W::Mask;
  using W::add, W::sub, W::mul, W::div, W::sqrt, W::min, W::all, W::zero, W::abs, W::neg, W::copysign;
  using W::blend, W::less, W::greater, W::both, W::either, W::but_not, W::any, W::count;
  using Shifts = typename W::template Shifts<2>;

  GRAINS_PAIR_KERNEL static long evaluate(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs,
                                          const std::uint8_t* images, std::size_t n, const Output& out) {
    const Shifts shifts(in.shift);
    if (!in.dense) return batches<false>(in, shifts, rows, pairs, images, n, out);
    if constexpr (W::lanes == 8)   // the velocities by plain loads: pair_filter::vector_loads
      if (in.vector_loads) return batches<true, true>(in, shifts, rows, pairs, images, n, out);
    return batches<true>(in, shifts, rows, pairs, images, n, out);
  }

  template <bool Dense, bool Loads = false>
  GRAINS_PAIR_KERNEL static long batches(const Input& in, const Shifts& shifts, const std::uint32_t* rows, const std::uint32_t* pairs,
                                         const std::uint8_t* images, std::size_t n, const Output& out) {
    long clamped = 0;
    for (std::size_t q = 0; q < n; q += W::lanes) clamped += batch<Dense, Loads>(in, shifts, rows, pairs, images, q, n - q, out);
    return clamped;
  }

  // A steady contact's result; with CompletesTail zero on the other lanes, which the pair loop adds as they are.
  GRAINS_PAIR_KERNEL static V steady_only(Mask m, V v) {
    if constexpr (CompletesTail) return blend(m, zero(), v);
    else return v;
  }

  // The pairs q .. q + lanes - 1 (the first `left` of them live). Inlined into the loop over the batches
  // (the AVX2 build measured faster so).
  template <bool Dense, bool Loads>
  [[gnu::always_inline]] GRAINS_PAIR_KERNEL static long batch(const Input& in, const Shifts& shifts, const std::uint32_t* rows,
                                                              const std::uint32_t* pairs, const std::uint8_t* images, std::size_t q,
                                                              std::size_t left, const Output& out) {
    // The pairs' geometry; the steady contacts among them (touched at the last evaluation too). Loads take
    // every live lane, not only the steady ones, so they need not wait for the stamps: the other lanes'
    // contact results are never read (with CompletesTail: zeros or a tail's force there).
    const typename W::template Contacts<2, Dense, Loads> c(rows, pairs, images, q, left, in.partner, shifts, in.position, in.radius,
                                                    in.touched, in.evaluation, in.slot_radius);
    const V rx = c.r[0], ry = c.r[1], d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
    Mask m = c.steady;
    Results8& b = out.results[q / 8];   // q is a multiple of 8, or of 4 for half a block
    c.set_bits(b.steady, m);
    // The lanes that interact: by the pair filter's test, d^2 < ((R_i + R_j) + tail)^2, over the shell's
    // entries; else the lanes are the filter's selection, every one interacting.
    Mask interacting = c.live;
    if (out.interacting) {
      const V reach = add(Rsum, all(in.tail_reach));
      interacting = both(c.live, less(d2, mul(reach, reach)));
      c.set_bits(b.interacting, interacting);
    }
    if constexpr (!CompletesTail) {   // the steady contacts only
      c.set_bits(b.ready, m);
      if (!any(m)) return 0;
    }
    // Open pairs within the attraction range and, over the shell, pairs that do not interact.
    const Mask tail = but_not(interacting, c.touching), quiet = but_not(c.live, interacting);

    const V d = sqrt(d2);
    const V inv_d = div(all(1.0), d);   // one division serves n, the spring's turn and the tail
    const V nx = mul(rx, inv_d), ny = mul(ry, inv_d);
    const V cn = c.per_entry(in.damping);
    V vi[2], vj[2];
    c.vector_at_i(in.velocity_predicted, vi), c.vector_at_j(in.velocity_predicted, vj);
    const V dvx = sub(vj[0], vi[0]), dvy = sub(vj[1], vi[1]);
    V vn = add(mul(dvx, nx), mul(dvy, ny));
    if (in.affine) {
      const V flow_x = mul(all(in.strain_rate_x), rx), flow_y = mul(all(in.strain_rate_y), ry);
      vn = add(vn, add(mul(flow_x, nx), mul(flow_y, ny)));
    }

    // A contact parting within the step (its overlap less than the step's travel) goes to the portable code,
    // which keeps its parting charge (contact_step.hpp, parting): no steady contact here, its stamp as it was.
    const V overlap = sub(Rsum, d);
    const V travel = mul(vn, all(in.dt));
    if (const Mask parts = both(m, greater(travel, overlap)); any(parts)) {
      c.set_entries(in.touched, parts, in.evaluation - 1);
      m = but_not(m, parts);
      c.set_bits(b.steady, m);
      if constexpr (!CompletesTail) c.set_bits(b.ready, m);
    }

    // Normal law (AdhesiveContactLaw::force with onset {1, 0}, no parting).
    const V limit = mul(all(in.overlap_limit), min(Rj, Ri));   // std::min(Ri, Rj)
    const Mask clamped = both(m, greater(overlap, limit));
    const V elastic = mul(all(in.k), blend(clamped, overlap, limit));
    const V fn = sub(sub(elastic, all(in.attraction)), mul(cn, vn));

    // Friction (tangential_force, 2D): everything along t = z x n.
    const V half_overlap = mul(all(0.5), sub(Rsum, d));
    const V arm_i = sub(Ri, half_overlap), arm_j = sub(Rj, half_overlap);
    const V kt = all(in.friction_stiffness_ratio * in.k);
    const V ct = mul(all(in.friction_damping_ratio), cn);
    const V bound = mul(all(in.mu), in.elastic_bound ? elastic : fn);
    const V tx = neg(ny), ty = nx;   // t = (-n_y, n_x)
    const V wi = c.at_i(in.angular_velocity, c.live), wj = c.at_j(in.angular_velocity, c.live);
    V ui[2], uj[2];
    c.vector_at_i(in.velocity, ui), c.vector_at_j(in.velocity, uj);
    const V hvx = sub(uj[0], ui[0]), hvy = sub(uj[1], ui[1]);
    // The relative velocity along the tangent of the step's middle, with the lever arms there (tangential_force).
    const V ux = in.affine ? add(hvx, mul(all(in.flow_factor_x), rx)) : add(hvx, zero());
    const V uy = in.affine ? add(hvy, mul(all(in.flow_factor_y), ry)) : add(hvy, zero());
    const V ut = add(mul(ux, tx), mul(uy, ty)), un = add(mul(ux, nx), mul(uy, ny));
    const V half_step = all(0.5 * in.dt);
    const V eps = mul(mul(half_step, ut), inv_d), d_mid = sub(d, mul(half_step, un));
    const V half_mid = mul(all(0.5), sub(Rsum, d_mid));
    const V arm_i_mid = sub(Ri, half_mid), arm_j_mid = sub(Rj, half_mid);
    const V vt = sub(sub(add(ut, mul(eps, un)), mul(wj, arm_j_mid)), mul(wi, arm_i_mid));
    const V xi_before = c.per_entry(in.tangential);
    V xi = add(xi_before, mul(vt, all(in.dt)));
    const V minus_kt = neg(kt);
    V ft = sub(mul(minus_kt, xi), mul(ct, vt));
    if (const Mask slides = both(m, greater(abs(ft), bound)); any(slides)) {
      // Cap the force; shorten the spring only if it alone passes the bound.
      ft = blend(slides, ft, copysign(bound, ft));
      const Mask shortened = both(slides, greater(abs(mul(kt, xi)), bound));
      xi = blend(shortened, xi, div(copysign(bound, xi), kt));
    }
    c.set_per_entry(in.tangential, m, xi, xi_before);
    // The forces on j: a steady contact's, with CompletesTail a tail's (AdhesiveContactLaw::tail(d - Rsum)
    // * (1 / d) * r, as the pair loop computes it) and zero elsewhere. Zero torques and forces leave the
    // sums they are added to as they were (none of them is ever -0: they start at +0, and a sum is -0 only
    // if both terms are).
    V fx = steady_only(m, add(mul(fn, nx), mul(ft, tx))), fy = steady_only(m, add(mul(fn, ny), mul(ft, ty)));
    if constexpr (CompletesTail) {
      if (any(tail)) {
        const V gap = sub(d, Rsum);
        const V pull = mul(all(-in.attraction), sub(all(1.0), div(gap, all(in.range))));
        const V pull_d = mul(pull, inv_d);
        fx = blend(tail, fx, mul(pull_d, rx)), fy = blend(tail, fy, mul(pull_d, ry));
      }
    }
    c.store_partners(b.partner);
    c.store(b.torque_j, steady_only(m, mul(arm_j, ft)));
    c.store(b.torque_i, steady_only(m, mul(arm_i, ft)));
    c.store(b.fx, fx);
    c.store(b.fy, fy);
    c.store(b.rx, rx);
    c.store(b.ry, ry);
    if constexpr (CompletesTail) c.set_bits(b.ready, either(m, either(tail, quiet)));

    // Rolling resistance (rolling_moment, 2D): a scalar spring, the bound a comparison of absolute values.
    if (in.rolling_angle) {
      const V spin = sub(wj, wi);
      V moment = zero();
      if (in.rolling_stiffness > 0) {
        const V bound_r = mul(all(in.rolling_coefficient), elastic);
        const V theta_before = c.per_entry(in.rolling_angle);
        V theta = add(theta_before, mul(spin, all(in.dt)));
        const V minus_kr = all(-in.rolling_stiffness);
        moment = mul(minus_kr, theta);
        if (const Mask rolls = both(m, greater(abs(moment), bound_r)); any(rolls)) {
          moment = blend(rolls, moment, copysign(bound_r, moment));
          theta = blend(rolls, theta, div(moment, minus_kr));
        }
        c.set_per_entry(in.rolling_angle, m, theta, theta_before);
      }
      if (in.rolling_damping > 0) moment = sub(moment, mul(mul(mul(mul(all(in.rolling_damping), cn), Ri), Rj), spin));
      c.store(b.moment, steady_only(m, moment));
    }
    return count(clamped);
  }
};

}  // namespace
}  // namespace grains::cohesive_contacts
