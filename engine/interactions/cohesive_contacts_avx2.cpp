// AVX2 build of the steady cohesive contacts (cohesive_contacts.hpp), for processors without AVX-512: four
// pairs a vector, each batch filling half of a Results8. Compiled for AVX2 whatever the build flags and
// without FMA contraction (engine/CMakeLists.txt). It mirrors cohesive_contacts_avx512.cpp line by line
// (which mirrors contact_forces.hpp / adhesive_contact_law.hpp / contact_step.hpp), in the same order, so
// the forces, torques and springs are bit-identical to the portable pair loop's.
#include "interactions/cohesive_contacts.hpp"

#include "interactions/pair_avx2.hpp"

namespace grains::cohesive_contacts {
namespace {

using namespace pair_avx2;

template <bool Dense>
[[gnu::always_inline]] GRAINS_AVX2_PAIRS inline long evaluate4(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs,
                                 const std::uint8_t* images, std::size_t q, std::size_t left, const Output& out) {
  // The pairs' geometry; the steady contacts among them. Loads take every live lane, not only the steady
  // ones; the other lanes' results are stored too, and never read.
  const Contacts4<2, Dense> c(rows, pairs, images, q, left, in.partner, in.shift, in.position, in.radius, in.touched,
                              in.evaluation, in.slot_radius);
  const Lanes4 &i = c.il, &j = c.jl, &k = c.kl;
  const std::uint32_t k0 = c.k0;
  const V live = c.live, rx = c.r[0], ry = c.r[1], d2 = c.d2, Ri = c.Ri, Rj = c.Rj, Rsum = c.Rsum;
  V m = widen(c.steady);
  const unsigned steady = bits(c.steady);
  Results8& b = out.results[q / 8];
  const unsigned half = q & 7;   // 0 or 4: the block's first or second half (the first one writes the bits)
  b.steady = std::uint8_t(half ? b.steady | steady << 4 : steady);
  b.ready = b.steady;   // the steady contacts only (the pair loop evaluates the attraction's tail itself)
  if (out.interacting) {   // the pair filter's test: d^2 < ((R_i + R_j) + tail)^2
    const V reach = add(Rsum, all(in.tail_reach));
    const unsigned interacting = bits(both(live, less(d2, mul(reach, reach))));
    b.interacting = std::uint8_t(half ? b.interacting | interacting << 4 : interacting);
  }
  if (!steady) return 0;

  const V d = _mm256_sqrt_pd(d2);
  const V inv_d = div(all(1.0), d);   // one division serves n and the spring's turn
  const V nx = mul(rx, inv_d), ny = mul(ry, inv_d);
  const bool full = c.full;
  const V cn = per_entry<Dense>(in.damping, k, k0, live, full);
  V vxi, vyi, vxj, vyj;
  gather_pairs(in.velocity_predicted, i, vxi, vyi), gather_pairs(in.velocity_predicted, j, vxj, vyj);
  const V dvx = sub(vxj, vxi), dvy = sub(vyj, vyi);
  V vn = add(mul(dvx, nx), mul(dvy, ny));
  V flow_x = zero(), flow_y = zero();
  if (in.affine) {
    flow_x = mul(all(in.strain_rate_x), rx), flow_y = mul(all(in.strain_rate_y), ry);
    vn = add(vn, add(mul(flow_x, nx), mul(flow_y, ny)));
  }

  // A contact parting within the step (its overlap less than the step's travel) goes to the portable code,
  // which keeps its parting charge (contact_step.hpp, parting): no steady contact here, its stamp as it was.
  const V overlap = sub(Rsum, d);
  const V travel = mul(vn, all(in.dt));
  const V parting = both(m, greater(travel, overlap));
  if (const unsigned parts = bits(parting)) {
    for (unsigned l = parts; l; l &= l - 1)
      in.touched[Dense ? k0 + __builtin_ctz(l) : k.at[__builtin_ctz(l)]] = in.evaluation - 1;
    m = _mm256_andnot_pd(parting, m);
    b.steady = std::uint8_t(b.steady & ~(parts << half));
    b.ready = b.steady;
  }

  // Normal law (AdhesiveContactLaw::force with onset {1, 0}, no parting).
  const V limit = mul(all(in.overlap_limit), _mm256_min_pd(Rj, Ri));   // std::min(Ri, Rj)
  const V clamped = both(m, greater(overlap, limit));
  const V elastic = mul(all(in.k), blend(clamped, overlap, limit));
  const V fn = sub(sub(elastic, all(in.attraction)), mul(cn, vn));

  // Friction (tangential_force, 2D): everything along t = z x n.
  const V half_overlap = mul(all(0.5), sub(Rsum, d));
  const V arm_i = sub(Ri, half_overlap), arm_j = sub(Rj, half_overlap);
  const V kt = all(in.friction_stiffness_ratio * in.k);
  const V ct = mul(all(in.friction_damping_ratio), cn);
  const V bound = mul(all(in.mu), in.elastic_bound ? elastic : fn);
  const V tx = neg(ny), ty = nx;   // t = (-n_y, n_x)
  const V wi = gather(in.angular_velocity, i), wj = gather(in.angular_velocity, j);
  V uxi, uyi, uxj, uyj;
  gather_pairs(in.velocity, i, uxi, uyi), gather_pairs(in.velocity, j, uxj, uyj);
  const V hvx = sub(uxj, uxi), hvy = sub(uyj, uyi);
  // The relative velocity along the tangent of the step's middle, with the lever arms there (tangential_force).
  const V ux = in.affine ? add(hvx, mul(all(in.flow_factor_x), rx)) : add(hvx, zero());
  const V uy = in.affine ? add(hvy, mul(all(in.flow_factor_y), ry)) : add(hvy, zero());
  const V ut = add(mul(ux, tx), mul(uy, ty)), un = add(mul(ux, nx), mul(uy, ny));
  const V half_step = all(0.5 * in.dt);
  const V eps = mul(mul(half_step, ut), inv_d), d_mid = sub(d, mul(half_step, un));
  const V half_mid = mul(all(0.5), sub(Rsum, d_mid));
  const V arm_i_mid = sub(Ri, half_mid), arm_j_mid = sub(Rj, half_mid);
  const V vt = sub(sub(add(ut, mul(eps, un)), mul(wj, arm_j_mid)), mul(wi, arm_i_mid));
  const V xi_before = per_entry<Dense>(in.tangential, k, k0, live, full);
  V xi = add(xi_before, mul(vt, all(in.dt)));
  const V minus_kt = neg(kt);
  V ft = sub(mul(minus_kt, xi), mul(ct, vt));
  const V slides = both(m, greater(abs(ft), bound));
  if (bits(slides)) {   // cap the force; shorten the spring only if it alone passes the bound
    ft = blend(slides, ft, copysign(bound, ft));
    const V shortened = both(slides, greater(abs(mul(kt, xi)), bound));
    xi = blend(shortened, xi, div(copysign(bound, xi), kt));
  }
  set_per_entry<Dense>(in.tangential, k, k0, m, xi, xi_before, full);
  std::memcpy(b.partner + half, j.at, sizeof j.at);
  _mm256_store_pd(b.torque_j + half, mul(arm_j, ft));
  _mm256_store_pd(b.torque_i + half, mul(arm_i, ft));
  _mm256_store_pd(b.fx + half, add(mul(fn, nx), mul(ft, tx)));
  _mm256_store_pd(b.fy + half, add(mul(fn, ny), mul(ft, ty)));
  _mm256_store_pd(b.rx + half, rx);
  _mm256_store_pd(b.ry + half, ry);

  // Rolling resistance (rolling_moment, 2D): a scalar spring, the bound a comparison of absolute values.
  if (in.rolling_angle) {
    const V spin = sub(wj, wi);
    V moment = zero();
    if (in.rolling_stiffness > 0) {
      const V bound_r = mul(all(in.rolling_coefficient), elastic);
      const V theta_before = per_entry<Dense>(in.rolling_angle, k, k0, live, full);
      V theta = add(theta_before, mul(spin, all(in.dt)));
      const V minus_kr = all(-in.rolling_stiffness);
      moment = mul(minus_kr, theta);
      const V rolls = both(m, greater(abs(moment), bound_r));
      if (bits(rolls)) {
        moment = blend(rolls, moment, copysign(bound_r, moment));
        theta = blend(rolls, theta, div(moment, minus_kr));
      }
      set_per_entry<Dense>(in.rolling_angle, k, k0, m, theta, theta_before, full);
    }
    if (in.rolling_damping > 0) moment = sub(moment, mul(mul(mul(mul(all(in.rolling_damping), cn), Ri), Rj), spin));
    _mm256_store_pd(b.moment + half, moment);
  }
  return __builtin_popcount(bits(clamped));
}

template <bool Dense>
GRAINS_AVX2_PAIRS long evaluate_all(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                  std::size_t n, const Output& out) {
  long clamped = 0;
  for (std::size_t q = 0; q < n; q += 4) clamped += evaluate4<Dense>(in, rows, pairs, images, q, n - q, out);
  return clamped;
}

}  // namespace

long evaluate_avx2(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                   std::size_t n, const Output& out) {
  return in.dense ? evaluate_all<true>(in, rows, pairs, images, n, out) : evaluate_all<false>(in, rows, pairs, images, n, out);
}

}  // namespace grains::cohesive_contacts
