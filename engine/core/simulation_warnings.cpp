// Warnings of a scene that will run badly: time steps above what its springs, dashpots, speeds, orbits or
// coordinates resolve (said at set-up), a target pressure its clamped contacts cannot hold, and the energy
// check of gravity scenes (said while the outputs are computed).
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>

#include <fmt/format.h>

#include "core/softened_core.hpp"
#include "core/dashpot_stability.hpp"
#include "core/simulation_impl.hpp"

namespace grains {

// Damped-packing time-step rule (core/dashpot_stability.hpp): the lightest grain pressed on all sides,
// by 12 contacts in 3D or 6 in 2D, against neighbours of the next lightest mass or of the heaviest one. Along any
// axis its springs and dashpots add up to z / D of one contact's (cos^2 of the contact directions
// averages 1 / D), and the fastest mode moves neighbours against each other, which the pair's reduced
// mass m* carries: w^2 = (z k / D) / m* (equal masses: twice the rate of a grain between fixed walls;
// a light grain among heavy ones: m* -> its mass). Above the limit that mode grows (a dense aggregate of
// 1000 spheres at zeta = 0.9 kept 40 times the kinetic energy at 20 steps per contact that it kept at
// 100; an FCC crystal is tested against the rule).
template <int D>
void SimulationImpl<D>::warn_damped_packing_step(double tc) {
  const auto& m = sys_.particles.mass;
  if (m.empty() || !(kn_ > 0) || !(cn_ > 0)) return;
  std::vector<double> sorted = m;
  std::partial_sort(sorted.begin(), sorted.begin() + std::min<std::size_t>(2, sorted.size()), sorted.end());
  const double lightest = sorted[0];
  const double heaviest = *std::max_element(m.begin(), m.end());
  const double z = D == 3 ? 12 : 6, mstar_min = smallest_reduced_mass();
  double limit = std::numeric_limits<double>::infinity(), worst_zeta = 0;
  // its partners: the next lightest grain (its own mass in a monodisperse packing) and the heaviest
  for (double neighbour : {sorted.size() > 1 ? sorted[1] : sorted[0], heaviest}) {
    const double mstar = lightest * neighbour / (lightest + neighbour);
    const double k = kn_ * std::pow(mstar / mstar_min, pair_law_scaling_.first);
    const double c = cn_ * std::pow(mstar / mstar_min, pair_law_scaling_.second);
    const double K = z * k / D, C = z * c / D, w = std::sqrt(K / mstar), zeta = C / (2 * std::sqrt(K * mstar));
    if (const double h = predicted_dashpot_limit(zeta) / w; h < limit) limit = h, worst_zeta = zeta;
  }
  // One contact of the lightest pair alone: its spring's undamped frequency w0 = sqrt(k_n / m*) = sqrt(pi^2 + ln^2 e) / t_c
  // grows without bound as e -> 0 at a fixed t_c, which the t_c / 20 rule (on the damped half-period) does not
  // see. Measured against the clamped law's restitution, head-on: the error is 1e-3 to 2.5e-3 at w0 dt = 0.14-0.15
  // whatever e (1e-3, 1e-6, 1e-20), 2 % at 0.185, 5 % at 0.283 (e = 1e-6, 50 steps per contact), and past the stable
  // step, 0.28 / w0 here, it is garbage (e = 1e-20 at 50 steps: 0.028 against 0.136; 1e-100: 39 times the energy).
  // So the rule's resolution, pi / 20, is asked of w0 too. Said here: where it bites (e below about 0.2) this
  // packing limit is exceeded as well, and the packing's wording alone would hide that the collision is wrong.
  const double w0 = std::sqrt(kn_ / mstar_min), resolved = std::numbers::pi / 20 / w0;
  const double single = predicted_dashpot_limit(cn_ / (2 * std::sqrt(kn_ * mstar_min))) / w0;
  const std::string pair =
      dt_ > resolved ? fmt::format("; a binary collision of the lightest pair is off too: its spring's undamped frequency "
                                   "sqrt(k_n / m*) = {:.6g} (sqrt(pi^2 + ln^2 e) / t_c, which grows as e -> 0) is resolved as "
                                   "the t_c / 20 rule asks only below time.dt = pi / (20 w0) = {:.6g} (time.steps_per_contact "
                                   "{:.0f}); above it the realised restitution departs from the clamped law's{}",
                                   w0, resolved, std::ceil(tc / resolved),
                                   dt_ > single ? fmt::format(", and above {:.6g} (time.steps_per_contact {:.0f}) the collision "
                                                              "is unstable", single, std::ceil(tc / single))
                                                : std::string())
                     : std::string();
  if (dt_ > limit)
    warn(fmt::format("time.dt = {:.6g} exceeds {:.6g}, the largest step at which grains of the lightest mass ({:.6g}) "
                     "pressed by {} damped contacts each (damping ratio {:.3g} on their fastest mode) settle: above it the "
                     "dashpots' velocity prediction makes them oscillate with growing amplitude, and dense packings heat "
                     "up instead of settling (time.steps_per_contact {:.0f} or more, without time.dt, would keep below it){}",
                     dt_, limit, lightest, int(z), worst_zeta, std::ceil(tc / limit), pair));
}

namespace {
// 4 m / (c + sqrt(c^2 + 4 k m)), the root scaled by the larger term so that it neither overflows nor underflows
// (friction.damping_ratio takes c from 0 to 1e300). Not std::hypot: glibc 2.35 versioned it anew, and the FMUs
// must load with glibc 2.34 (std::hypot binds GLIBC_2.35).
double sticking_stable_step(double k, double c, double m) {
  const double s = 2 * std::sqrt(k) * std::sqrt(m), g = std::max(c, s);
  if (!(g > 0)) return std::numeric_limits<double>::infinity();
  if (std::isinf(g)) return 0;
  return 4 * m / (c + g * std::sqrt((c / g) * (c / g) + (s / g) * (s / g)));
}
}  // namespace

// The tangential spring and dashpot of a sticking contact (and the rolling ones) act on the half-step
// velocity: x += h v, v += h (-k x - c v) / m is stable only for k h^2 / m + 2 c h / m <= 4, i.e. h below
// 4 m / (c + sqrt(c^2 + 4 k m)). The time-step rule sees only the normal spring, and friction.stiffness_ratio
// and damping_ratio (rolling.stiffness_ratio) are open-ended: an oblique collision of two unit spheres at
// mu = 1e3 left with 1430 times its kinetic energy at k_t = 1e6 k_n, 1.9 times at c_t = 1e3 c_n, unwarned
// (it grows from k_t = 330 k_n at 50 steps per contact, where this bound says 289). The mass of the tangential
// mode is the pair's reduced mass with the grains' rotation: 1 / m_t = (1 + 1 / kappa) / m*, I = kappa m R^2
// (kappa = 2/5 spheres, 1/2 disks), the same with any contacts; the lightest pair is the fastest: kn_ and cn_ are
// its. The rolling mode's is warn_rolling_step's.
template <int D>
void SimulationImpl<D>::warn_sticking_spring_step(const Scene& scene, double tc) {
  const double kappa = D == 3 ? 0.4 : 0.5;
  const auto say = [&](const std::string& what, double limit, const std::string& mode) {
    if (!(dt_ > limit)) return;
    // Beyond a billion steps per contact no run reaches the bound: only the ratio can be lowered.
    const double steps = std::ceil(tc / limit);
    const std::string remedy = steps <= 1e9 ? fmt::format("lower the ratio or the step (time.steps_per_contact {:.0f} or more, "
                                                          "without time.dt)", steps)
                                            : fmt::format("lower the ratio (no practical step is below it: "
                                                          "time.steps_per_contact {:.3g} or more)", steps);
    warn(fmt::format("{}: time.dt = {:.6g} exceeds {:.6g}, the largest step at which {} are stable (the lightest pair; "
                     "the normal time-step rule does not see it): above it that motion grows every step and collisions "
                     "gain energy; {}", what, dt_, limit, mode, remedy));
  };
  if (scene.boolean("contact.enabled") && scene.real("friction.coefficient") > 0) {
    // (+ 0: c_n is -0 at e = 1, -2 m* ln e / t_c)
    const double kt = scene.real("friction.stiffness_ratio") * kn_, ct = scene.real("friction.damping_ratio") * cn_ + 0.0;
    say(fmt::format("friction.stiffness_ratio = {:.6g} (k_t = {:.6g}) with friction.damping_ratio = {:.6g} (c_t = {:.6g})",
                    scene.real("friction.stiffness_ratio"), kt, scene.real("friction.damping_ratio"), ct),
        sticking_stable_step(kt, ct, smallest_reduced_mass() / (1 + 1 / kappa)), "a sticking contact's tangential spring and dashpot");
  }
  if (rolling_ && (rolling_->stiffness > 0 || rolling_->damping > 0))
    warn_rolling_step(rolling_->damping,
                      rolling_->stiffness > 0
                          ? fmt::format("rolling.stiffness_ratio = {:.6g} (K_R = {:.6g}) with rolling.damping_ratio = {:.6g}",
                                        scene.real("rolling.stiffness_ratio"), rolling_->stiffness, rolling_->damping)
                          : fmt::format("rolling.damping_ratio = {:.6g} (no rolling spring: rolling.coefficient = 0)",
                                        rolling_->damping));
}

// The rolling spring and dashpot on a pair's relative spin (rule above): its dashpot c_r = beta c_n R_i R_j with the
// pair's c_n. A grain's spin feels the dashpots of all its contacts: for grain i among z_ij grains like j, each of which
// touches z_ji grains like i, the fastest mode's inertia is I* = 1 / (z_ij / I_i + z_ji / I_j), z the most such grains
// that fit around one (2D: floor(pi / asin(R_j / (R_i + R_j))), 6 for equal disks; 3D: the caps' area over the
// densest packing of circles, floor(2 / (1 - cos alpha) pi / sqrt(12)), 13 for equal spheres, where 12 fit). Cautious:
// the mode it bounds has alternating spins on every contact, which a lattice that is not bipartite lacks (a second
// review: the named beta was stable everywhere, 1.2-2.3 times below the measured limits). The worst pair is not the
// two smallest grains: a small grain against a large one has c_r / I_i larger by about R_large / R_small (a 200-disk
// packing of diameters 0.05-1 blows up at beta = 1, which a rule looking at the smallest pair only, one contact
// each, does not see). Each grain is paired with the few partners that could be worst for it:
// the two of the smallest inertia, the largest and the heaviest grain. Also checked when a host or the programme's
// quench sets beta (once per run, as the setting's own warning).
template <int D>
void SimulationImpl<D>::warn_rolling_step(double beta, const std::string& setting) const {
  const auto& P = sys_.particles;
  if (P.size() < 2 || rolling_step_warned_) return;
  const double K = rolling_->stiffness, mstar_min = smallest_reduced_mass();
  std::vector<std::size_t> partners(P.size());
  std::iota(partners.begin(), partners.end(), std::size_t(0));
  std::partial_sort(partners.begin(), partners.begin() + 2, partners.end(),
                    [&](std::size_t a, std::size_t b) { return P.inertia[a] < P.inertia[b]; });
  partners.resize(2);
  const auto largest = [&](const std::vector<double>& v) { return std::size_t(std::max_element(v.begin(), v.end()) - v.begin()); };
  partners.push_back(largest(P.radius)), partners.push_back(largest(P.mass));
  // Grains of radius `around` that fit about one of radius `centre`, touching it and not each other.
  const auto fit = [](double centre, double around) {
    const double half_angle = std::asin(around / (centre + around));
    // 3D: the caps' area times the densest packing of circles in a plane, pi / sqrt(12) (13 equal spheres, where 12 fit)
    return std::floor((D == 2 ? std::numbers::pi / half_angle : 2 / (1 - std::cos(half_angle)) * std::numbers::pi / std::sqrt(12.0)) *
                      (1 + 1e-12));   // 6 exactly
  };
  struct Worst {
    double step = std::numeric_limits<double>::infinity(), inertia = 0, dashpot_per_beta = 0, z = 0;
    std::size_t i = 0, j = 0;
  } worst;
  for (std::size_t i = 0; i < P.size(); ++i)
    for (const std::size_t j : partners) {
      if (i == j) continue;
      const double zij = fit(P.radius[i], P.radius[j]), zji = fit(P.radius[j], P.radius[i]);
      const double inertia = 1 / (zij / P.inertia[i] + zji / P.inertia[j]);
      const double mstar = P.mass[i] * P.mass[j] / (P.mass[i] + P.mass[j]);
      const double per_beta = cn_ * std::sqrt(mstar / mstar_min) * P.radius[i] * P.radius[j];
      const double step = sticking_stable_step(K, beta * per_beta, inertia);
      // Named by the grain whose spin the mode moves (the larger share of 1 / I*)
      if (step < worst.step)
        worst = zij / P.inertia[i] >= zji / P.inertia[j] ? Worst{step, inertia, per_beta, zij, i, j}
                                                        : Worst{step, inertia, per_beta, zji, j, i};
    }
  if (!(dt_ > worst.step)) return;
  rolling_step_warned_ = true;
  // k h^2 + 2 c h <= 4 I*: the largest beta this step holds (none when the spring alone exceeds it)
  const double beta_max = (2 * worst.inertia / dt_ - 0.5 * K * dt_) / worst.dashpot_per_beta;
  warn(fmt::format("{}: time.dt = {:.6g} exceeds {:.6g}, the largest step at which sticking contacts' rolling springs and "
                   "dashpots are stable about the worst grain (particle {}, radius {:.6g}, with up to {:.0f} contacts to "
                   "grains like particle {}, radius {:.6g}; the normal time-step rule does not see it): above it the "
                   "spins grow every step; {}",
                   setting, dt_, worst.step, worst.i, P.radius[worst.i], worst.z, worst.j, P.radius[worst.j],
                   beta_max > 0 ? fmt::format("keep the rolling dashpot's beta (rolling.damping_ratio, or "
                                              "programme.quench_damping where the programme's quench sets it) at or "
                                              "below {:.3g}, or lower the step", beta_max)
                                : std::string("lower rolling.stiffness_ratio or the step")));
}

// The cell's damping, eta_c (cell.damping_ratio) and the contacts' eta_a (cell.contact_damping), relaxes its strain
// rate in M_c / eta. CVODE's non-stiff (Adams) method must resolve that time: where it is far below the particle step
// it takes about 1.3 eta / M_c dt steps per particle step (measured, 200 disks, M_c = 30: 11 at cell.damping_ratio
// 1000, 21 at 2000, 103 at 1e4, where eta / M_c dt is 8.2, 16 and 82; about 0.5 without damping in a cycle, 1.2 % of its
// time), and fails beyond 100000 (a run at cell.contact_damping = 1e6 is 470 times slower). Warned once, where
// eta / M_c dt passes 10, and only while the cell moves: a held cell (a type-2 sample
// aggregating) runs no CVODE, and is checked when released.
constexpr double stiff_cell_damping = 10;
template <int D>
void SimulationImpl<D>::warn_stiff_cell_damping() {
  if (stiff_cell_damping_warned_ || !barostat_ || !cell_active_) return;
  const auto& p = barostat_->parameters();
  const Vec<D> eta = barostat_->contact_damping();
  const double contacts = eta.maxCoeff(), relaxations = (p.damping + contacts) / p.mass * dt_;
  if (!(relaxations > stiff_cell_damping)) return;
  stiff_cell_damping_warned_ = true;
  warn(fmt::format("cell damping: at t = {:.6g} (step {}) the cell's damping, eta_c = {:.6g} (cell.damping_ratio) and "
                   "eta_contacts = {:.6g} (cell.contact_damping), over cell.mass M_c = {:.6g} relaxes its strain rate {:.3g} "
                   "times within one particle step: CVODE resolves that with about 1.3 times as many steps per particle "
                   "step, slowing the run, and fails beyond 100000; lower {}, or raise cell.mass",
                   sys_.time, sys_.step, p.damping, contacts, p.mass, relaxations,
                   contacts > p.damping ? "cell.contact_damping" : "cell.damping_ratio"));
}

// Positions are doubles: far from the origin their spacing, |x| 2^-52, grows past the lengths the run resolves, and
// below it nothing moves. Two grains 1e16 radii out kept their speeds but never moved (an unchanged kinetic energy, no
// collision, nothing said); at 1e11 radii the collision's restitution was off by 4e-4, at 1e8 by 1e-6. Warned where
// the spacing passes a thousandth of the smallest such length: the contacts' overlaps (the clamp depth, taken at most
// a tenth of R_min: the gas scenes' overlap_limit = 1 set it at half a radius, and an elastic gas 1e12 out gained 0.9 %
// of its energy in 1e5 steps, 3e12 out 4.3 %), the softening length without contacts, and the grains' radius (gravity
// without contacts has no overlaps to compare with: an eccentric binary 1e12 out loses its angular momentum).
template <int D>
void SimulationImpl<D>::warn_coarse_coordinates(const Scene& scene, double rmin, bool contacts) {
  double far = 0;
  for (const auto& x : sys_.particles.position) far = std::max(far, x.cwiseAbs().maxCoeff());
  for (int a = 0; a < D; ++a)
    if (sys_.box.periodic[a])   // positions are wrapped into the box
      far = std::max({far, std::abs(sys_.box.lower[a]), std::abs(sys_.box.lower[a] + sys_.box.length[a])});
  const double spacing = std::nextafter(far, std::numeric_limits<double>::infinity()) - far;
  double length = rmin;
  std::string what = "the smallest radius R_min";
  if (const double f = contacts ? std::min(scene.real("contact.overlap_limit"), 0.1) : 0; f > 0 && f * rmin < length)
    length = f * rmin, what = fmt::format("the contacts' overlaps, min(contact.overlap_limit, 0.1) R_min");
  bool softening = false;   // the limit: then gravity.softening is the key to change (only without contacts, which
                            // keep centres a diameter apart)
  if (!contacts && scene.boolean("gravity.enabled"))
    if (const double eps = scene.real("gravity.softening") * rmin; eps > 0 && eps < length)
      length = eps, what = "the softening length gravity.softening R_min", softening = true;
  const std::string layout = scene.text("particles.layout");
  // What put the grains that far: their listed places, the box's corner, or its size (a box sized from a tiny
  // particles.solid_fraction is not an unset box.lower's doing).
  double corner = 0, size = 0;
  for (int a = 0; a < D; ++a)
    corner = std::max(corner, std::abs(sys_.box.lower[a])), size = std::max(size, sys_.box.length[a]);
  const bool placed = scene.has("box.lower") && corner >= size;
  const char* key = softening                  ? "gravity.softening"
                    : layout == "list"         ? "particles.positions"
                    : layout == "file"         ? "particles.file"
                    : placed                   ? "box.lower"
                    : scene.has("box.lengths") ? "box.lengths"
                                               : "particles.solid_fraction";
  if (spacing > 1e-3 * length)
    warn(fmt::format("{}: coordinates reach {:.6g}, where doubles are {:.3g} apart, more than 1e-3 of {} = {:.6g}: "
                     "lengths are resolved no finer than that, and moves below it are lost to rounding (grains 1e16 "
                     "radii out never moved); keep every coordinate below {:.3g} (a scene near the origin, and no larger){}",
                     key, far, spacing, what, length, length * 1e-3 * std::pow(2.0, 52),
                     softening ? ", or raise gravity.softening" : ""));
}

// Two of the fastest initial grains approaching head-on close 2 v_max dt in a step. Beyond the clamp depth
// f_max R_min their contact starts clamped, its onset unresolved, and a pair that closes more than its
// diameters in a step is never seen overlapping at all: two grains at 1e4 crossed through each other with
// their kinetic energy unchanged and nothing counted or warned. The time-step rule, from t_c alone, cannot
// see the speeds; the initial ones are known here (later ones, gravity's among them, the energy check watches).
template <int D>
void SimulationImpl<D>::warn_unresolved_approach(const Scene& scene, double rmin) {
  double vmax = 0;
  for (const auto& v : sys_.particles.velocity) vmax = std::max(vmax, v.norm());
  const double depth = scene.real("contact.overlap_limit") * rmin, closing = 2 * vmax * dt_;
  const std::string mode = scene.text("particles.velocity");
  const char* source = mode == "list" ? "particles.velocities" : mode == "gaussian" ? "particles.kinetic_energy" : "particles.file";
  if (closing > depth)
    warn(fmt::format("{}: the fastest initial grain moves at {:.6g}, so two such "
                     "grains approaching head-on close 2 v_max dt = {:.6g} in a step of time.dt = {:.6g}, more than the "
                     "clamp depth contact.overlap_limit R_min = {:.6g}: their contacts start beyond the clamp and pairs "
                     "closing faster than their diameters per step pass through each other unseen; keep time.dt below "
                     "{:.6g} (more time.steps_per_contact) or the speeds lower",
                     source, vmax, closing, dt_, depth, depth / (2 * vmax)));
}

// The gravity time-step rule (core/orbit_step_rule.hpp), set up from the scene and checked at its G. Kept: the
// softened-core check compares against it, and a host's gravity.G is checked against it (warn_orbit_step_at_G).
template <int D>
void SimulationImpl<D>::warn_gravity_step(const Scene& scene, double rmin, bool contacts) {
  std::vector<double> m = sys_.particles.mass;
  if (m.size() < 2) return;
  const double M = std::accumulate(m.begin(), m.end(), 0.0);
  std::partial_sort(m.begin(), m.begin() + 2, m.end(), std::greater<>());
  // kn_: the lightest pair's stiffness, the smallest one (per-pair calibration stiffens heavier pairs)
  orbit_rule_ = OrbitStepRule{m[0] + m[1], m[0], M, scene.real("gravity.softening") * rmin,
                              contacts ? kn_ * scene.real("contact.overlap_limit") * rmin : 0.0, rmin, contacts};
  const double G = scene.real("gravity.G");
  const auto rule = orbit_rule_->at(G);
  if (rule.orbit > 0 && dt_ > rule.step()) {
    orbit_rule_warned_ = true;
    warn(fmt::format("time.dt = {:.6g} exceeds T_orb / 20 = {:.6g} ({}): close gravitational encounters are resolved by "
                     "fewer than 20 steps", dt_, rule.step(), orbit_rule_terms(rule)));
  } else if (rule.orbit == 0 && !orbit_rule_->contacts) {
    // Unsoftened without contacts: nothing bounds the closest approach, and the rule has no step (the collapse scene
    // at softening 0 ends at Q = 2380, else said only by the energy check). With contacts the rule's
    // "cannot keep grains apart" compares the whole cloud's pull on one grain, the usual case, and the aggregation
    // scene at softening 0 ran sound (energy falling, overlaps 0.16 R): not warned.
    orbit_rule_warned_ = true;
    warn("gravity.softening = 0 with no contacts: grains may come arbitrarily close, where the orbit a step must resolve "
         "(T_orb / 20 at distance d) shortens without end, so no time.dt resolves close encounters (orbits that stay "
         "wide, as a binary's, are unaffected; the energy check watches the run); give gravity.softening > 0");
  }
}

// What the orbit rule's step comes from, for its warnings.
template <int D>
std::string SimulationImpl<D>::orbit_rule_terms(const OrbitStepRule::At& rule) const {
  const double capped = orbit_rule_->capped, pull = rule.pull;
  const std::string why =
      !orbit_rule_->contacts ? "no contacts"
      : rule.held            ? fmt::format("contacts keep grains apart: their capped force k_n delta_max = {:.6g} exceeds "
                                           "G m_max M / (2 R_min)^2 = {:.6g}", capped, pull)
                             : fmt::format("contacts cannot keep grains apart: their capped force k_n delta_max = {:.6g} is "
                                           "below G m_max M / (2 R_min)^2 = {:.6g}, so grains may pass through each other",
                                           capped, pull);
  return fmt::format("T_orb = {:.6g}: the circular orbit of the two heaviest particles at their closest approach d = {:.6g} "
                     "with softening eps = {:.6g}; {}", rule.orbit, rule.d, orbit_rule_->eps, why);
}

// A host's gravity.G (the tunable control) moves the orbit rule's step as 1 / sqrt(G), and a G whose pull the contacts
// cannot hold moves d to 0. A G at which time.dt (fixed for the run) exceeds it is warned about as the start-up's G would have
// been: without it a raised G went unsaid (the softened-core check compares cores with this rule at the same G, so it
// cannot see a step too coarse for the rule itself). Once per run, the start-up's warning included: a host steering G
// step by step would repeat it, and a G raised further only says the same again (part of the saved state).
template <int D>
void SimulationImpl<D>::warn_orbit_step_at_G(double G) {
  if (orbit_rule_warned_ || !orbit_rule_) return;
  const auto rule = orbit_rule_->at(G);
  if (!(rule.orbit > 0 && dt_ > rule.step())) return;
  orbit_rule_warned_ = true;
  // At this d the step is 1 / sqrt(G) times that at G = 1; a lower G only keeps d or raises it (contacts that hold
  // grains apart at G hold them at less), so at or below this G the step resolves the orbit.
  const double unit_step = softened_orbit_period(1.0, orbit_rule_->pair_mass, orbit_rule_->eps, rule.d) / 20;
  warn(fmt::format("gravity.G = {:.6g} (set at t = {:.6g}, step {}): time.dt = {:.6g} exceeds T_orb / 20 = {:.6g} at this G "
                   "({}): close gravitational encounters are resolved by fewer than 20 steps; time.dt is fixed for the run, "
                   "so keep gravity.G at or below {:.6g}, where the step resolves that orbit",
                   G, sys_.time, sys_.step, dt_, rule.step(), orbit_rule_terms(rule), std::pow(unit_step / dt_, 2)));
}

// A contact of the pressed packing carries about the pressure's force P a^(D-1); the clamp caps its elastic
// force at K_N f_max R_min (physics.md section 2), so a target at or above that cannot be held: the cell
// shrinks until the grains sit inside each other (64 disks at P* = 2e4, twice the cap, reached Phi = 1.13
// with overlaps past a radius and no warning) or it stops the run as too small. Warned, not refused: the
// force a contact takes depends on the packing, and collapse begins below the cap (one contact in a few
// carries several times the mean).
// Once per simulation: a programme or a host raising the pressure stage by stage would repeat it.
template <int D>
void SimulationImpl<D>::warn_pressure_beyond_clamp(const char* key, double reduced_pressure) {
  const double force = pressure_force(reduced_pressure);
  if (pressure_clamp_warned_ || force < clamp_force_) return;
  pressure_clamp_warned_ = true;
  warn(fmt::format("{} = {:.6g} asks each contact for about P a^(D-1) = {:.6g}, not below {:.6g}, the largest elastic "
                   "force a clamped contact gives (K_N contact.overlap_limit R_min): the packing cannot hold this pressure "
                   "and collapses into overlaps past the clamp; keep P* below {:.6g}, or raise the contacts' stiffness or "
                   "contact.overlap_limit", key, reduced_pressure, force, clamp_force_,
                   reduced_pressure * clamp_force_ / force));
}


// Energy check (physics.md section 3: nothing blows up silently). In a gravity scene with the aggregation's
// contact law (or none) nothing adds energy: springs store it, dashpots, friction and drag take it. So
// E = K + W + elastic (the contacts' stored energy: the clamped normal spring's potential, linear beyond the
// cap, and the tangential spring's) may only fall or stay, within the integrator's error; a rise is energy
// the integration makes, and a run that gains it ends hot (virial ratios above 1 from a cold dissipative
// cloud). Checked where the outputs are computed (the runner's observable times, a host's reads), so it
// costs nothing per step; warns once, when E exceeds its lowest value so far by more than energy_rise_limit
// of the energy scale max(K, |W|, |E_0|), E_0 the first value checked.
// The limit, 1 %, measured (the largest rise over a run, over the scale): the default aggregation scene
// (1000 grains, 3 t_ff) 0 at its records, 8e-12 recorded every 10 steps; elastic runs (e = 1, overlaps to
// 0.7 R) 1.4e-4; the collapse scene (no contacts) 3.6e-4; two grains passing through each other (k* = 10,
// 30 steps per contact) 0.97, and the aggregation scene at k* = 10, zeta = 0.02, 2.7 (first above 1 % at
// 0.34 t_ff). At k* = 100 the cloud's E rises 0.9-2.9 %: warned about, mildly, at most dampings.
// A host may hold G at 0: then nothing pulls, k* is NaN and t_ff means nothing to the checks' texts.
template <int D>
bool SimulationImpl<D>::gravity_pulls() const {
  return gravity_ && gravity_->G() > 0;
}

// The time of a check's warning: t, t / t_ff where gravity pulls, and the step.
template <int D>
std::string SimulationImpl<D>::warning_time() const {
  return gravity_pulls() ? fmt::format("t = {:.6g} ({:.3g} t_ff, step {})", sys_.time, sys_.time / free_fall_time_, sys_.step)
                         : fmt::format("t = {:.6g} (step {})", sys_.time, sys_.step);
}

constexpr double energy_rise_limit = 0.01;
template <int D>
void SimulationImpl<D>::check_energy(double kinetic) const {
  auto& o = observable_values_;
  auto& w = energy_watch_;
  const double W = o.at("gravity_potential_energy");
  const auto stored = o.find("elastic_energy");
  const double E = kinetic + W + (stored != o.end() ? stored->second : 0.0);
  if (w.warned || !std::isfinite(E)) return;
  if (!w.started) {
    w = {E, E, sys_.time, 1, 0};
    return;
  }
  if (E < w.minimum) {
    w.minimum = E, w.minimum_time = sys_.time;
    return;
  }
  const double scale = std::max({kinetic, std::abs(W), std::abs(w.first)}), rise = E - w.minimum;
  if (!(rise > energy_rise_limit * scale)) return;
  w.warned = 1;
  const bool pulling = gravity_pulls();   // else the contacts alone made the energy
  const std::string cause =
      kn_ > 0 && !pulling
          ? "a step too coarse for the contacts, or grains meeting with more energy than the clamped spring stores "
            "(G is 0 now): raise time.steps_per_contact or contact.overlap_limit"
      : kn_ > 0 ? fmt::format("contacts too soft for the gravitational load (k* = {:.3g}; largest overlap now {:.3g} R_min): "
                            "the capped contact force k_n delta_max cannot stop grains that gravity pulls together, they "
                            "pass through each other and the step misses the close encounter at the softening length; "
                            "raise k* (a shorter contact.duration) or contact.overlap_limit, or time.steps_per_contact",
                            o.at("normalised_stiffness"), o.count("max_overlap_ratio") ? o.at("max_overlap_ratio") : 0.0)
              : "a step too coarse for close encounters at the softening length: lower time.dt or raise gravity.softening";
  warn(fmt::format("energy check: at {} the total energy E = K + W + elastic = {:.6g} is "
                   "{:.6g} above its lowest value {:.6g} (at t = {:.6g}), {:.3g} % of the energy scale "
                   "max(K, |W|, |E_0|) = {:.6g} (the check's limit: {:g} %); nothing in this scene adds energy, so the "
                   "integration is making it and what follows (virial ratio, clusters) is an artefact. Likely cause: {}",
                   warning_time(), E, rise, w.minimum, w.minimum_time,
                   100 * rise / scale, scale, 100 * energy_rise_limit, cause));
}

// Pass-through check (physics.md section 3: nothing blows up silently). The capped contact force, k_n delta_max
// (physics.md section 2), cannot stop grains that gravity presses together harder than that: they sink into each
// other down to the softened centre, and the potential energy they release is taken by the dashpots, so E falls and
// the energy check stays quiet. A cloud of 2000 grains of diameters 0.5-1 at k* = 3000 (global calibration: k_n from
// the lightest pair) "aggregated" at 0.83 t_ff with overlaps of 1.6 radii, 737,119 clamped contact-steps and no
// warning. Warned once, where the outputs are computed, when an overlap exceeds the smaller grain's radius (its
// centre inside the other grain). Measured, the largest max_overlap_ratio of a run's records: the default aggregation
// scene 0.13; that cloud 1.6; the sweep's k* = 100 and 10 points (200 grains, zeta = 0.3) 2.0 and 1.99; k* = 1e3 0.26.
constexpr double pass_through_overlap = 1.0;
template <int D>
void SimulationImpl<D>::check_pass_through() const {
  const auto& o = observable_values_;
  const auto overlap = o.find("max_overlap_ratio");
  if (pass_through_warned_ || overlap == o.end() || !(overlap->second > pass_through_overlap)) return;
  pass_through_warned_ = true;
  const std::string what = fmt::format("contact check: at {} two grains overlap by {:.4g} times the smaller one's radius "
                                       "(max_overlap_ratio): they are passing through each other. The contact force "
                                       "stops growing at contact.overlap_limit times that radius, ", warning_time(), overlap->second);
  if (network_)   // the adhesive law (cohesionless F0 = 0 too): its stiffness is adhesion.stiffness, gravity or not
    warn(what + "which cannot stop grains that meet with more energy than the clamped spring stores or that the step "
                "misses: what follows is an artefact; raise adhesion.stiffness or contact.overlap_limit, or lower the "
                "grains' speeds");
  else if (gravity_pulls() && kn_ > 0)
    warn(what + fmt::format("which cannot hold grains that gravity presses together harder than that (k* = {:.3g}, from "
                            "the lightest pair's k_n and the mean grain's k_g) or that meet faster than the step resolves "
                            "(the start-up warning on unresolved approaches says so): the clusters, D_f and aggregation time "
                            "from here on are artefacts; raise k* (a shorter contact.duration), contact.overlap_limit or "
                            "time.steps_per_contact", o.at("normalised_stiffness")));
  // Without gravity too: a head-on pair at a contact time of 3 swaps sides, and a heavy pair under the lightest pair's
  // k_n passes through.
  else
    warn(what + "which cannot stop grains that meet with more energy than the clamped spring stores (the global "
                "calibration takes k_n from the lightest pair: heavier pairs meet it softer) or that the step misses: "
                "what follows is an artefact; raise the stiffness (a shorter contact.duration, or contact.calibration = "
                "\"per-pair\"), contact.overlap_limit or time.steps_per_contact");
}

// Softened-core check (physics.md section 3: nothing blows up silently). The orbit rule (core/orbit_step_rule.hpp)
// resolves the orbit of two grains within the softening length eps; where contacts cannot hold grains apart, many may
// sink within eps of each other, and a grain there orbits their mass M with period T = 2 pi sqrt(eps^3 / (G M))
// (core/softened_core.hpp). Warned once, where the outputs are computed, when time.dt exceeds T / 20, the
// rule's resolution, for the densest core of two grains or more found, and that core asks a finer step than the
// rule does at the G in effect (which has said so already otherwise, at the start-up or when a host set G). The
// aggregation sweep's k* = 10 point (1000 grains, zeta = 0.02) ends with every grain within eps, where the start-up
// rule asked 201 steps per contact: at 800 the energy check was quiet, yet N_c / N was 0.032 against 0.003 at 1600
// (docs/reproduction-aggregation.md).
template <int D>
void SimulationImpl<D>::check_softened_core() const {
  if (core_warned_ || !gravity_ || !(gravity_->softening_length() > 0) || !(gravity_->G() > 0)) return;
  const auto& P = sys_.particles;
  const double eps = gravity_->softening_length(), G = gravity_->G();
  const auto step_for = [&](double M) { return softened_orbit_period(G, M, eps) / 20; };
  const double total = std::accumulate(P.mass.begin(), P.mass.end(), 0.0), all = step_for(total);
  // No core can hold more than every grain: where time.dt resolves the orbits in a core of them all, no record can
  // warn, and the grid is skipped (the margin covers the core's sum, in another order, exceeding the total by its
  // rounding). The step falls as M grows, so the skip changes no warning.
  if (std::isfinite(total) && !(dt_ > step_for(total * (1 + 1e-6)))) return;
  const SoftenedCore core = densest_softened_core<D>(P.position, P.mass, eps);
  if (core.count < 2) return;   // no two grains within eps of each other
  const double resolved = step_for(core.mass), orbit = 20 * resolved;
  // The orbit rule at the G in effect (a host may have changed it since the start-up).
  const double rule_step = orbit_rule_ ? orbit_rule_->at(G).step() : 0.0;
  if (!(dt_ > resolved) || !(resolved < rule_step)) return;
  core_warned_ = true;
  // The core may go on growing: what every grain in it would ask (`all`), the bound a run that collapses whole needs.
  const auto in_steps_per_contact = [&](double step) {
    return contact_duration_ > 0 ? fmt::format(" (time.steps_per_contact {:.0f} or more)", std::ceil(contact_duration_ / step))
                                 : std::string();
  };
  warn(fmt::format("softened-core check: at t = {:.6g} ({:.3g} t_ff, step {}) {} grains of mass {:.6g} lie within the "
                   "softening length eps = {:.6g} of grain {}; a grain orbits that core in T = 2 pi sqrt(eps^3 / (G M)) = "
                   "{:.6g}, and time.dt = {:.6g} exceeds T / 20 = {:.6g}: the core's orbits are resolved by fewer than 20 "
                   "steps (the orbit rule, from two grains, asks time.dt <= {:.6g} at G = {:.6g}), so the collapse into "
                   "it, and the clusters from here on, are not resolved; keep time.dt at or below {:.6g}{} for this core, "
                   "and at or below {:.6g}{} should every grain sink into it",
                   sys_.time, sys_.time / free_fall_time_, sys_.step, core.count, core.mass, eps, core.centre, orbit, dt_,
                   resolved, rule_step, G, resolved, in_steps_per_contact(resolved), all, in_steps_per_contact(all)));
}

// This file's members, instantiated one by one: each of the Simulation's files instantiates its own
// (a whole-class instantiation may appear in only one file of a program).
#define GRAINS_SIMULATION_WARNINGS_MEMBERS(D) \
  template void SimulationImpl<D>::warn_damped_packing_step(double); \
  template void SimulationImpl<D>::warn_sticking_spring_step(const Scene&, double); \
  template void SimulationImpl<D>::warn_rolling_step(double, const std::string&) const; \
  template void SimulationImpl<D>::warn_coarse_coordinates(const Scene&, double, bool); \
  template void SimulationImpl<D>::warn_stiff_cell_damping(); \
  template void SimulationImpl<D>::warn_unresolved_approach(const Scene&, double); \
  template void SimulationImpl<D>::warn_gravity_step(const Scene&, double, bool); \
  template std::string SimulationImpl<D>::orbit_rule_terms(const OrbitStepRule::At&) const; \
  template void SimulationImpl<D>::warn_orbit_step_at_G(double); \
  template void SimulationImpl<D>::warn_pressure_beyond_clamp(const char*, double); \
  template bool SimulationImpl<D>::gravity_pulls() const; \
  template std::string SimulationImpl<D>::warning_time() const; \
  template void SimulationImpl<D>::check_energy(double) const; \
  template void SimulationImpl<D>::check_pass_through() const; \
  template void SimulationImpl<D>::check_softened_core() const;
GRAINS_SIMULATION_WARNINGS_MEMBERS(2)
GRAINS_SIMULATION_WARNINGS_MEMBERS(3)
#undef GRAINS_SIMULATION_WARNINGS_MEMBERS

}  // namespace grains
