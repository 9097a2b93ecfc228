// The batched kernel of the steady contacts of spheres (linear_contacts.hpp), written once for both vector
// widths: W is pair_avx2::Width4 or pair_avx512::Width8, their operations, masks and the batch's loads and
// stores (Contacts4, Contacts8). Every line mirrors an expression of contact_forces.hpp /
// linear_contact_law.hpp / contact_step.hpp, in the same order. Where a rare branch (a release charge, a
// spring sliding) takes some lanes, the others keep their value through a blend: one masked instruction at
// eight lanes, the operation on every lane at four.
//
// Included by one file per width (linear_contacts_avx2.cpp, linear_contacts_avx512.cpp), compiled without
// FMA contraction (engine/CMakeLists.txt), which first defines GRAINS_PAIR_KERNEL as that width's target
// attribute.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>

#include "interactions/linear_contacts.hpp"

#ifndef GRAINS_PAIR_KERNEL
#error "define GRAINS_PAIR_KERNEL as the width's target attribute before including this header"
#endif

namespace grains::linear_contacts {
namespace {

template <class W>
struct Kernel : W {
  using typename W::V, typename W::Mask;
  using W::add, W::sub, W::mul, W::div, W::sqrt, W::min, W::max, W::all, W::zero, W::neg;
  using W::blend, W::less, W::less_equal, W::greater, W::both, W::but_not, W::any, W::count;
  using Shifts = typename W::template Shifts<3>;
  using Contacts = typename W::template Contacts<3>;

  GRAINS_PAIR_KERNEL static long evaluate(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs,
                                          const std::uint8_t* images, std::size_t n, const Output& out) {
    const Shifts shifts(in.shift);
    long clamped = 0;
    for (std::size_t q = 0; q < n; q += W::lanes) clamped += batch(in, shifts, rows, pairs, images, q, n - q, out);
    return clamped;
  }

  GRAINS_PAIR_KERNEL static V dot(const V a[3], const V b[3]) { return add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2])); }
  // Eigen's cross product: (a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0).
  GRAINS_PAIR_KERNEL static void cross(const V a[3], const V b[3], V out[3]) {
    out[0] = sub(mul(a[1], b[2]), mul(a[2], b[1]));
    out[1] = sub(mul(a[2], b[0]), mul(a[0], b[2]));
    out[2] = sub(mul(a[0], b[1]), mul(a[1], b[0]));
  }
  GRAINS_PAIR_KERNEL static void scaled(V s, const V v[3], V out[3]) {
    for (int a = 0; a < 3; ++a) out[a] = mul(s, v[a]);
  }

  // The pairs q .. q + lanes - 1 (the first `left` of them live).
  GRAINS_PAIR_KERNEL static long batch(const Input& in, const Shifts& shifts, const std::uint32_t* rows, const std::uint32_t* pairs,
                                       const std::uint8_t* images, std::size_t q, std::size_t left, const Output& out) {
    // The pairs' geometry; the steady contacts among them (touched at the last evaluation too). Loads take
    // every live lane, not only the steady ones, so they need not wait for the stamps: the other lanes'
    // results are never read.
    const Contacts c(rows, pairs, images, q, left, in.partner, shifts, in.position, in.radius, in.touched, in.evaluation);
    const V* r = c.r;
    const V d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
    const Mask m = c.steady;
    Results8& b = out.results[q / 8];   // q is a multiple of 8, or of 4 for half a block
    c.set_bits(b.steady, m);
    if (!any(m)) return 0;

    const V d = sqrt(d2);
    const V n[3] = {div(r[0], d), div(r[1], d), div(r[2], d)};
    V vi[3], vj[3], dv[3];
    c.vector_at_i(in.velocity_predicted, vi), c.vector_at_j(in.velocity_predicted, vj);
    for (int a = 0; a < 3; ++a) dv[a] = sub(vj[a], vi[a]);
    V vn = add(add(mul(dv[0], n[0]), mul(dv[1], n[1])), mul(dv[2], n[2]));
    if (in.affine) {
      V flow[3];
      for (int a = 0; a < 3; ++a) flow[a] = mul(all(in.strain_rate[a]), r[a]);
      vn = add(vn, add(add(mul(flow[0], n[0]), mul(flow[1], n[1])), mul(flow[2], n[2])));
    }

    // LinearContactLaw::force (global k, c) for a steady contact: onset {1, 0}, then the release charge.
    const V overlap = sub(Rsum, d);
    const V limit = mul(all(in.overlap_limit), min(Rj, Ri));   // std::min(Ri, Rj)
    const Mask clamped = both(m, greater(overlap, limit));
    const V kn = all(in.k), cn = all(in.c);
    const V elastic = mul(kn, blend(clamped, overlap, limit));
    V f = sub(add(elastic, mul(kn, all(0.0))), mul(mul(cn, vn), all(1.0)));
    const Mask releasing = both(both(but_not(m, clamped), greater(f, zero())), greater(vn, zero()));
    if (any(releasing)) {
      const V mi = c.at_i(in.mass, releasing), mj = c.at_j(in.mass, releasing);
      const V mm = mul(mi, mj);
      const V fall = mul(all(in.dt), add(mul(mul(kn, vn), mm), mul(mul(cn, f), add(mi, mj))));
      if (const Mask charged = both(releasing, less(mul(f, mm), mul(all(2.0), fall))); any(charged)) {   // release_force(f, fall / mm)
        const V drop = blend(charged, all(1.0), div(fall, mm));
        const V sigma = blend(charged, zero(), div(f, drop));
        const Mask within = less_equal(sigma, all(1.0));
        const V rr = blend(within, sub(sigma, all(1.0)), sigma);
        const V weight = blend(within, sub(all(2.0), sigma), sigma);
        const V two_r_less_one = sub(mul(all(2.0), rr), all(1.0));
        const V charge = mul(div(mul(mul(drop, two_r_less_one), two_r_less_one), all(8.0)), weight);
        f = blend(charged, f, add(f, charge));
      }
    }
    f = max(f, zero());   // std::max(0.0, f)
    V force[3] = {mul(f, n[0]), mul(f, n[1]), mul(f, n[2])};
    // The springs take the cell's flow themselves (in.flow_factor).
    if (in.tangential) friction(in, c, m, n, elastic, f, d, force, b);
    c.store_partners(b.partner);
    for (int a = 0; a < 3; ++a) c.store(b.f[a], m, force[a]);
    for (int a = 0; a < 3; ++a) c.store(b.r[a], m, r[a]);
    return count(clamped);
  }

  // ContactForces::tangential_force (3D) on the steady lanes m: turns and advances the springs, caps them,
  // adds F_t to `force` (on j) and stores both torques. fn: the normal force, elastic: k_n delta_used.
  GRAINS_PAIR_KERNEL static void friction(const Input& in, const Contacts& c, Mask m, const V n[3], V elastic, V fn, V d, V force[3],
                                          Results8& b) {
    // Lever arms to the middle of the overlap.
    const V half_overlap = mul(all(0.5), sub(c.Rsum, d));
    const V arm_i = sub(c.Ri, half_overlap), arm_j = sub(c.Rj, half_overlap);
    const V kt = all(in.friction_stiffness), ct = all(in.friction_damping_ratio * in.c);
    const V bound = mul(all(in.mu), in.elastic_bound ? elastic : fn);
    V wi[3], wj[3], ui[3], uj[3];
    c.vector_at_i(in.angular_velocity, wi), c.vector_at_j(in.angular_velocity, wj);
    c.vector_at_i(in.velocity, ui), c.vector_at_j(in.velocity, uj);
    // The pair at the start and the middle of the step (ContactForces::spring_motion), from the half-step velocities.
    V hv[3], bfr[3], mid[3], nb[3], nm[3], flow_mid[3];
    for (int a = 0; a < 3; ++a) {
      hv[a] = sub(uj[a], ui[a]);
      bfr[a] = sub(in.affine ? div(c.r[a], all(in.scale[a])) : c.r[a], mul(all(in.dt), hv[a]));
      mid[a] = mul(all(0.5), add(bfr[a], c.r[a]));
    }
    const V d_mid = sqrt(dot(mid, mid));
    const V inverse_mid = div(all(1.0), d_mid), inverse_before = div(all(1.0), sqrt(dot(bfr, bfr)));
    for (int a = 0; a < 3; ++a) {
      nm[a] = mul(mid[a], inverse_mid), nb[a] = mul(bfr[a], inverse_before);
      flow_mid[a] = in.affine ? mul(all(in.flow_factor[a]), c.r[a]) : zero();
    }
    const V half_mid = mul(all(0.5), sub(c.Rsum, d_mid));
    const V arm_i_mid = sub(c.Ri, half_mid), arm_j_mid = sub(c.Rj, half_mid);
    // turn_into_tangent_plane(xi, n_before, n): the rotation that takes n_before to n, then the rounding's part along n off.
    V xi[3];
    c.vector_per_entry(in.tangential, xi);
    const V cosine_plus_one = add(all(1.0), dot(nb, n));
    const Mask turnable = greater(cosine_plus_one, all(spring_turnable));   // else projected only
    const V turn = blend(turnable, zero(), div(dot(xi, n), blend(turnable, all(1.0), cosine_plus_one)));
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
    if (const Mask slides = both(m, greater(mag2, mul(bound, bound))); any(slides)) {
      // Cap the force; shorten the spring only if it alone passes the bound.
      V mag = sqrt(mag2);
      if (const Mask overflows = both(slides, greater(mag2, all(std::numeric_limits<double>::max()))); any(overflows)) {
        V scaled_ft[3];   // as the portable code's length_from_square
        for (int a = 0; a < 3; ++a) scaled_ft[a] = mul(ft[a], all(overflow_rescale));
        mag = blend(overflows, mag, div(sqrt(dot(scaled_ft, scaled_ft)), all(overflow_rescale)));
      }
      const V cap = blend(slides, all(1.0), div(bound, blend(slides, all(1.0), mag)));
      for (int a = 0; a < 3; ++a) ft[a] = blend(slides, ft[a], mul(ft[a], cap));
      const V reach = blend(slides, all(1.0), div(bound, kt)), stretch2 = dot(xi, xi);
      if (const Mask shortened = both(slides, greater(stretch2, mul(reach, reach))); any(shortened)) {
        const V scale = blend(shortened, all(1.0), div(reach, blend(shortened, all(1.0), sqrt(stretch2))));
        for (int a = 0; a < 3; ++a) xi[a] = blend(shortened, xi[a], mul(xi[a], scale));
      }
    }
    c.set_vector_per_entry(in.tangential, m, xi);
    // Torques: (-R_j n) x F_t on j, (R_i n) x (-F_t) on i.
    V lever[3], minus_ft[3], torque[3];
    scaled(neg(arm_j), n, lever);
    cross(lever, ft, torque);
    for (int a = 0; a < 3; ++a) c.store(b.torque_j[a], m, torque[a]);
    for (int a = 0; a < 3; ++a) minus_ft[a] = neg(ft[a]);
    cross(lever_i, minus_ft, torque);
    for (int a = 0; a < 3; ++a) c.store(b.torque_i[a], m, torque[a]);
    for (int a = 0; a < 3; ++a) force[a] = add(force[a], ft[a]);
  }
};

}  // namespace
}  // namespace grains::linear_contacts
