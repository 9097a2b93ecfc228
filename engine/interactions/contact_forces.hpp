// The pair loop, written once: every neighbour pair is evaluated with a normal law, an optional
// tangential (friction) law and optional rolling resistance; the compiler specialises the
// combination a scene uses, so a frictionless scene runs code with no friction in it.
// A normal law with an attractive tail (Law::has_tail) also acts on open pairs with gap below reach().
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <fmt/format.h>
#include <omp.h>

#include "core/integrator.hpp"
#include "core/thread_share.hpp"
#include "interactions/force_module.hpp"
#include "interactions/adhesive_contact_law.hpp"
#include "interactions/cohesive_contacts.hpp"
#include "interactions/friction.hpp"
#include "interactions/linear_contact_law.hpp"
#include "interactions/linear_contacts.hpp"
#include "interactions/pair_filter.hpp"
#include "interactions/rolling_resistance.hpp"

namespace grains {

// A touching pair's geometry where its springs need it (ContactForces::spring_motion): the normal at the
// step's start (3D: the springs turn from it to the current one), the distance and normal at the step's middle
// (where the half-step velocities are), and the cell's share of the pair's move over the step, as a velocity.
template <int D>
struct SpringMotion {
  double d_mid = 0;
  Vec<D> n_before, n_mid, flow_mid;
};

template <int D, class Law, class Friction, class Rolling = NoRolling>
class ContactForces final : public ForceModule<D> {
  static constexpr bool torques_ = Friction::enabled || Rolling::enabled;
  // Cohesive disks with friction (the consolidation scenes in 2D): steady contacts eight at a time where
  // the processor has AVX-512, four where it has AVX2 (cohesive_contacts.hpp).
  static constexpr bool batched_cohesive_ = D == 2 && std::is_same_v<Law, AdhesiveContactLaw> && Friction::enabled;
  // Spheres with one global (k_n, c_n), with or without friction (the gas scenes): the same,
  // linear_contacts.hpp.
  static constexpr bool batched_linear_ = D == 3 && std::is_same_v<Law, LinearContactLaw<false>> && !Rolling::enabled;
  // The tangential spring xi. 2D: a scalar along t = z x n; the tangent "plane" is a line that turns
  // with n, so the spring follows it for free (no projection, no square root) and keeps its length
  // exactly. 3D: a vector in the tangent plane. Spin<D> is exactly that (a 1-vector in 2D).
  using Spring = Spin<D>;

 public:
  ContactForces(Law law, Friction friction, Rolling rolling = {}) : law_(law), friction_(friction), rolling_(rolling) {}
  std::string name() const override {
    return std::string("contact") + (Friction::enabled ? "+friction" : "") + (Rolling::enabled ? "+rolling" : "");
  }
  double pair_range() const override { return law_.reach(); }
  bool applies_torques() const override { return torques_; }
  const Law& law() const { return law_; }
  Rolling& rolling() { return rolling_; }   // a host may retune the rolling dashpot between steps

  // The first-step stamps (touched_) and the springs follow the pairs that touched at the last
  // evaluation; every other pair starts afresh (holds_history), so no sorted rows are needed.
  void after_rebuild(const NeighbourList<D>& list) override {
    flush_slots();   // into the old list's entries, which match_previous then carries over
    const std::size_t pairs = list.pair_count();
    std::vector<std::uint32_t> touched(pairs, 0);
    std::vector<Spring> tangential(Friction::enabled ? pairs : 0, Spring::Zero());
    std::vector<Spin<D>> rolling_angle(Rolling::enabled ? pairs : 0, Spin<D>::Zero());
    list.match_previous([&](std::size_t old) { return holds_history(old); }, [&](std::size_t old, std::size_t k) {
      touched[k] = touched_[old];
      if constexpr (Friction::enabled) tangential[k] = tangential_[old];
      if constexpr (Rolling::enabled) rolling_angle[k] = rolling_angle_[old];
    });
    touched_.swap(touched), tangential_.swap(tangential), rolling_angle_.swap(rolling_angle);
  }

  void add_forces(System<D>& s) override {
    // A new list always comes through after_rebuild, which flushes the slots: live ones of another list
    // would be written back into the wrong entries.
    if (slots_.live && slots_.list_builds != s.neighbours.builds())
      throw std::logic_error("contact forces: the neighbour list was rebuilt without after_rebuild");
    if (++evaluation_ < 2) evaluation_ = 2;   // on wrap-around: stamps 0 (never) and 1 must never look recent
    for (const OnsetLag& o : active_)   // the dashpots see the velocities without the lag impulses
      kick_apart(s.particles, s.particles.velocity_predicted, o, o.n * (-o.lag / s.dt));
    touched_.resize(s.neighbours.pair_count(), 0);
    if constexpr (Friction::enabled) tangential_.resize(s.neighbours.pair_count(), Spring::Zero());
    if constexpr (Rolling::enabled) rolling_angle_.resize(s.neighbours.pair_count(), Spin<D>::Zero());
    if (s.want_virial) clamped_now_ = add_forces_and<true>(s);
    else clamped_now_ = add_forces_and<false>(s);
    clamped_total_ += clamped_now_;
    if constexpr (Law::has_tail) {   // this evaluation's parting charges, for the next one to check
      take_back_partings(s);
      charged_.clear();
      for (Gathered& g : gathered_)   // in thread order: deterministic
        charged_.insert(charged_.end(), g.parted.begin(), g.parted.end()), g.parted.clear();
    }
  }

  // Adds this loop's pair virial into s.virial (zeroed by whoever evaluates the forces).
  template <bool Virial>
  long add_forces_and(System<D>& s) {
    using Mat = Eigen::Matrix<double, D, D>;
    auto& P = s.particles;
    const std::size_t N = P.size();
    long clamped_now = 0;
    const int T = s.threads;
    gathered_.resize(T);
    // Set up once per evaluation, before the threads start (it may refresh damping_).
    std::optional<cohesive_contacts::Input> batched_cohesive;
    std::optional<linear_contacts::Input> batched_linear;
    const pair_filter::Isa isa = pair_filter::isa();
    if constexpr (batched_cohesive_)
      if (isa != pair_filter::Isa::portable) batched_cohesive = cohesive_batch_input(s);
    if constexpr (batched_linear_)
      if (isa != pair_filter::Isa::portable) batched_linear = linear_batch_input(s);
    // The cohesive kernel over the shell directly (note_selection) keeps the springs in the shell's slots.
    const bool direct = batched_cohesive_ && batched_cohesive && direct_ && s.shell.built();
    if (slots_.live && (!direct || slots_.shell_builds != s.shell.builds() || slots_.list_builds != s.neighbours.builds()))
      flush_slots();
    if (direct && !slots_.live) load_slots(s);
    history_ = direct ? History{slots_.touched.data(), slots_.tangential.data(), slots_.rolling_angle.data()}
                      : History{touched_.data(), tangential_.data(), rolling_angle_.data()};
    if (direct) {
      cohesive_contacts::note_dense_evaluation();
      const auto flat = [](auto& v) { return reinterpret_cast<double*>(v.data()); };
      batched_cohesive->dense = true, batched_cohesive->partner = s.shell.partner.data();
      batched_cohesive->damping = slots_.damping.data();
      batched_cohesive->touched = slots_.touched.data(), batched_cohesive->tangential = flat(slots_.tangential);
      batched_cohesive->slot_radius[0] = slots_.radius_i.data(), batched_cohesive->slot_radius[1] = slots_.radius_j.data();
      if constexpr (Rolling::enabled) batched_cohesive->rolling_angle = flat(slots_.rolling_angle);
    }
    const Batch batch{batched_cohesive ? &*batched_cohesive : nullptr, batched_linear ? &*batched_linear : nullptr, direct,
                      isa == pair_filter::Isa::avx512};
    if (T == 1) {
      clamped_now = loop<Virial, false>(s, 0, N, nullptr, nullptr, s.virial, gathered_[0], batch);
      note_selection(s);
    } else {
      share_rows(s);
      // One virial per thread, summed in thread order afterwards: deterministic for a thread count.
      std::vector<Mat> thread_virial(Virial ? T : 0, Mat::Zero());
#pragma omp parallel num_threads(T) reduction(+ : clamped_now)
      {
        // OpenMP may start fewer threads than T (a host's own parallel region around the step, OMP_THREAD_LIMIT,
        // OMP_DYNAMIC): each thread then takes several of the T shares, in the same order, so every row is evaluated
        // and the sums are those of T threads. (One share per thread left the last share's rows without their
        // contact forces: 27 contacts instead of 11 after 600 steps of the aggregation FMU under OMP_THREAD_LIMIT=1.)
        const int team = omp_get_num_threads();
        for (int t = omp_get_thread_num(); t < T; t += team) {
          Gathered& g = gathered_[t];
          for (const std::uint32_t j : g.far) g.far_seen[j] = 0;   // the last evaluation's, merged since
          g.far.clear();
          g.far_seen.resize(N, 0);
          Mat local = Mat::Zero();
          // Each share is a contiguous range of rows with about as much work as the others (share_rows):
          // a slab of space when the particles are numbered along a space-filling curve (initial_state), so
          // its partners are mostly its own particles too. It adds straight into
          // the forces and torques of its rows' particles, and into its own arrays (zero on entry) those of
          // partners beyond its rows, listing them; a pair is stored under its lower index, so no partner lies
          // before its rows.
          const std::size_t rb = shares_.bounds[std::size_t(t)], re = shares_.bounds[std::size_t(t) + 1];
          clamped_now += loop<Virial, true>(s, rb, re, s.thread_force[t].data(), s.thread_torque[t].data(), local, g, batch);
          if constexpr (Virial) thread_virial[t] = local;
        }
#pragma omp barrier
        // Each share adds the earlier shares' parts of its particles, in share order (deterministic
        // for a thread count), and zeroes what it read: the arrays are zero again for the next evaluation.
        for (int t = omp_get_thread_num(); t < T; t += team) {
          const std::size_t rb = shares_.bounds[std::size_t(t)], re = shares_.bounds[std::size_t(t) + 1];
          for (int u = 0; u < t; ++u)
            for (const std::uint32_t j : gathered_[u].far) {
              if (j < rb || j >= re) continue;
              P.force[j] += s.thread_force[u][j];
              s.thread_force[u][j].setZero();
              if constexpr (torques_) {
                P.torque[j] += s.thread_torque[u][j];
                s.thread_torque[u][j].setZero();
              }
            }
        }
      }
      if constexpr (Virial)
        for (const Mat& w : thread_virial) s.virial += w;
      note_selection(s);
    }
    return clamped_now;
  }

  // The threads' rows (row_bounds), set again when the list is rebuilt or restored or the thread count
  // changes: a function of the list alone, so results stay deterministic for a thread count. A crossing
  // pair counts twice: on 1400 cohesive disks under a moving cell, the first of two threads ran 35 % longer
  // in the pair loop than the second with the listed pairs split evenly, and the second spun at the barrier.
  void share_rows(const System<D>& s) {
    if (shares_.list_builds == s.neighbours.builds() && shares_.threads == s.threads) return;
    shares_.bounds = row_bounds(s.neighbours.start, s.neighbours.partner.data(), s.threads, 1);
    shares_.list_builds = s.neighbours.builds(), shares_.threads = s.threads;
  }

  // Where most pairs of the shell interact (a dense cohesive packing), the batched kernel runs over the
  // shell's entries directly and tests them itself: the filter's pass and its compaction cost more than
  // the open pairs the kernel then carries. Decided from the last evaluation's share (70 %: on the cohesive
  // bench disks 2 % less processor time than at 90 %, with the AVX-512 kernel and with the AVX2 one; 50 %
  // did not differ from 70 %); the results are the same either way, bit for bit.
  void note_selection(const System<D>& s) {
    std::size_t tested = 0, selected = 0;
    for (const Gathered& g : gathered_) tested += g.tested, selected += g.selected;
    direct_ = s.shell.built() && 10 * selected >= 7 * tested;
  }

  // The onset lag (contact_step.hpp) of a contact that began in the last step is made up in the next
  // one by a pair of opposite central impulses: the pair's relative velocity gains lag / h along n
  // before the step's drift and loses it after its kick, so the drift moves the pair apart by exactly
  // lag. Central impulses keep momentum and angular momentum exactly (the second acts along the pair's
  // new direction), and between steps no velocity carries them. The step's dashpots see the velocities
  // without them (the pair's true relative velocity).
  // Between steps, the step's second half kick may still be pending (core/pending_kick.hpp): the pair
  // is kicked first, so that its impulse comes after the kick, as it always has.
  void begin_step(System<D>& s, double h) override {
    active_.swap(pending_);
    pending_.clear();
    for (const OnsetLag& o : active_) {
      kick_early(s.particles, s.pending_kick, o.i), kick_early(s.particles, s.pending_kick, o.j);
      kick_apart(s.particles, s.particles.velocity, o, o.n * (o.lag / h));
    }
  }
  void finish_step(System<D>& s) override {
    auto& P = s.particles;
    for (const OnsetLag& o : active_) {
      kick_early(P, s.pending_kick, o.i), kick_early(P, s.pending_kick, o.j);
      const Vec<D> r = s.box.minimum_image(P.position[o.j] - P.position[o.i]);
      kick_apart(P, P.velocity, o, r * (-o.lag / (s.dt * r.norm())));
    }
    active_.clear();
    for (Gathered& g : gathered_) {   // in thread order: deterministic
      pending_.insert(pending_.end(), g.lags.begin(), g.lags.end());
      g.lags.clear();
    }
  }

  void observe(const System<D>& s, std::vector<std::pair<std::string, double>>& out) const override {
    flush_slots();
    const auto& P = s.particles;
    double elastic = 0, max_ratio = 0, adhesion = 0;
    long contacts = 0;
    each_listed_pair(s, [&](std::size_t i, std::uint32_t j, std::size_t k, const Vec<D>& r) {
        const double overlap = P.radius[i] + P.radius[j] - r.norm();
        if constexpr (Law::has_tail) adhesion += law_.adhesion_energy(-overlap);
        if (overlap <= 0) return;
        ++contacts;
        const double rmin = std::min(P.radius[i], P.radius[j]);
        const double limit = law_.overlap_limit * rmin;
        const double kn = law_.stiffness(P.mass[i], P.mass[j]);
        // The potential of the clamped spring: quadratic up to the limit, linear beyond.
        elastic += overlap <= limit ? 0.5 * kn * overlap * overlap : kn * limit * (overlap - 0.5 * limit);
        if constexpr (Friction::enabled)   // energy stored in the tangential spring
          if (holds_history(k)) elastic += 0.5 * friction_.stiffness_ratio * kn * tangential_[k].squaredNorm();
        if constexpr (Rolling::enabled)   // and in the rolling spring
          if (holds_history(k)) elastic += 0.5 * rolling_.stiffness * rolling_angle_[k].squaredNorm();
        max_ratio = std::max(max_ratio, overlap / rmin);
    });
    out.emplace_back("contacts", double(contacts));
    out.emplace_back("elastic_energy", elastic);
    if constexpr (Law::has_tail) out.emplace_back("adhesion_energy", adhesion);
    out.emplace_back("max_overlap_ratio", max_ratio);
    out.emplace_back("clamped_contacts", double(clamped_now_));
    out.emplace_back("clamped_contacts_total", double(clamped_total_));
  }

  void save(ByteWriter& w) const override {
    flush_slots();
    w.put(clamped_now_), w.put(clamped_total_);
    w.put(evaluation_), w.put_vector(touched_), w.put_vector(pending_);
    w.put_vector(tangential_);   // 2D: one double per pair (xi along z x n), 3D: three
    if constexpr (Rolling::enabled) w.put_vector(rolling_angle_);
    w.put_vector(charged_);
  }
  void load(ByteReader& r) override {
    damping_builds_ = -1;   // the restored list is another one, whatever its build count
    shares_.list_builds = -1;
    slots_.live = false;    // the restored springs are the list's
    clamped_now_ = r.get<long>(), clamped_total_ = r.get<long>();
    evaluation_ = r.get<std::uint32_t>(), r.get_vector(touched_), r.get_vector(pending_);
    r.get_vector(tangential_);
    if constexpr (Rolling::enabled) r.get_vector(rolling_angle_);
    r.get_vector(charged_);
  }
  void check_loaded(const System<D>& s) const override {
    const std::size_t pairs = s.neighbours.pair_count(), N = s.particles.size(), n = touched_.size();
    // The stamps follow the list once the forces were evaluated (before, none), and the springs the stamps.
    bool ok = (n == pairs || n == 0) && tangential_.size() == (Friction::enabled ? n : 0);
    if constexpr (Rolling::enabled) ok = ok && rolling_angle_.size() == n;
    for (const OnsetLag& o : pending_) ok = ok && o.i < N && o.j < N;
    for (const Parted& c : charged_) ok = ok && c.i < N && c.j < N && c.i != c.j;
    if (!ok) throw std::runtime_error("saved contact history does not fit the saved neighbour list");
  }

  // Interacting pairs (contacts and distant bonds: pairs that attract across a gap) with their static normal
  // force, for the contact-network analysis. A pair within D0 of contact is no bond where nothing attracts
  // (F0 = 0, the cohesionless reference): counting it put 0.4 on z there.
  void list_interactions(const System<D>& s, std::vector<NetworkInteraction>& out) const override {
    if constexpr (Law::has_tail) {
      const auto& P = s.particles;
      each_listed_pair(s, [&](std::size_t i, std::uint32_t j, std::size_t, const Vec<D>& r) {
        const double gap = r.norm() - P.radius[i] - P.radius[j];
        if (gap >= law_.reach()) return;
        const double force = law_.static_force(gap, std::min(P.radius[i], P.radius[j]));
        if (gap < 0 || force != 0) out.push_back({std::uint32_t(i), j, gap, force});
      });
    }
  }

  // The same pairs linearised, for the elastic moduli: K_N (a distant bond: the tail's -F0 / D0), K_T
  // and K_R in contact, lever arms to the middle of the overlap (as the tangential force uses), and the
  // static F_N, |F_T| = |k_t xi| and |Gamma| = |K_R theta_R|, with the bounds they slide at.
  void list_springs(const System<D>& s, std::vector<ElasticSpring<D>>& out) const override {
    flush_slots();
    if constexpr (Law::has_tail) {
      const auto& P = s.particles;
      each_listed_pair(s, [&](std::size_t i, std::uint32_t j, std::size_t k, const Vec<D>& r) {
          const double gap = r.norm() - P.radius[i] - P.radius[j], rmin = std::min(P.radius[i], P.radius[j]);
          if (gap >= law_.reach() || (gap >= 0 && law_.static_stiffness(gap) == 0)) return;
          ElasticSpring<D> e;
          e.i = std::uint32_t(i), e.j = j, e.branch = r;
          e.arm_i = P.radius[i] + 0.5 * gap, e.arm_j = P.radius[j] + 0.5 * gap;
          e.normal = law_.static_stiffness(gap);
          e.normal_force = law_.static_force(gap, rmin);
          e.contact_stiffness = law_.stiffness(P.mass[i], P.mass[j]);
          if (gap < 0) {
            const double elastic = law_.static_elastic(-gap, rmin);   // F_N^e, its overlap clamped (physics.md section 2)
            if constexpr (Friction::enabled) {
              e.tangential = friction_.stiffness_ratio * e.contact_stiffness;
              if (holds_history(k)) e.tangential_force = e.tangential * tangential_[k].norm();
              e.tangential_bound = friction_.mu * elastic;
            }
            if constexpr (Rolling::enabled) {
              e.rolling = rolling_.stiffness;
              if (holds_history(k)) e.rolling_moment = rolling_.stiffness * rolling_angle_[k].norm();
              e.rolling_bound = rolling_.coefficient * elastic;
            }
          }
          out.push_back(e);
      });
    }
  }

 private:
  // Whether pair k's springs are current: it touched at the last evaluation. The springs of a pair
  // that opened are not cleared when it opens (that would cost a pass over every listed pair) but
  // when it touches again (contact_force), so until then they hold stale values.
  bool holds_history(std::size_t k) const { return k < touched_.size() && touched_[k] == evaluation_; }

  // Visits every listed pair: its row i, partner j, list entry k and separation r = x_j - x_i (periodic
  // image included).
  template <class Visit>
  static void each_listed_pair(const System<D>& s, Visit visit) {
    const auto& P = s.particles;
    const auto& nl = s.neighbours;
    for (std::size_t i = 0; i + 1 < nl.start.size(); ++i)
      for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
        const std::uint32_t j = nl.partner[k];
        visit(i, j, std::size_t(k), Vec<D>(P.position[j] + nl.shift[nl.image[k]] - P.position[i]));
      }
  }

  // Rows are handled in blocks of this many, in two passes: the first gathers the pairs that
  // interact (touching, or within an attraction tail) without a branch, the second evaluates them.
  // The first (pair_filter.hpp) reads geometry only: open pairs' springs are left alone (see holds_history).
  // Most listed pairs are open, so the first pass is the hot one and stays small and tight; the
  // second runs the costly arithmetic of consecutive contacts back to back. Pairs are evaluated in
  // list order, as a single pass would.
  static constexpr std::size_t block_rows_ = 256;
  struct Shares {
    std::vector<std::size_t> bounds;
    long list_builds = -1;
    int threads = 0;
  } shares_;   // see share_rows
  bool direct_ = false;   // see note_selection
  // A contact's first step ended too deep by `lag` (contact_step.hpp, onset_lag), made up in the next step.
  struct OnsetLag {
    std::uint32_t i, j;
    double lag;
    Vec<D> n;   // unit vector from i to j at the evaluation
  };
  // A parting charge made at an evaluation (adhesive law), by the pair's particles.
  struct Parted {
    std::uint32_t i, j;
    double charge;   // normal force on the pair (positive = repulsive)
  };
  // The batched kernel's results, eight pairs to a block (see batched_cohesive_ and batched_linear_).
  using Results8 = std::conditional_t<batched_cohesive_, cohesive_contacts::Results8, linear_contacts::Results8>;
  struct Gathered {
    std::vector<std::uint32_t> row, pair;   // interacting pairs: the row (i) and the list entry (k)
    std::vector<std::uint8_t> image;        // ... and its periodic image
    std::vector<OnsetLag> lags;             // contacts that began this step, in list order
    std::vector<Parted> parted;             // parting charges made this evaluation
    std::vector<std::uint32_t> far;         // partners beyond the thread's rows it wrote forces for (several threads)
    std::vector<std::uint8_t> far_seen;     // per particle: listed in far
    // The batched kernel's results, eight pairs to a block.
    std::vector<Results8> results;
    std::size_t tested = 0, selected = 0;    // this evaluation: pairs tested, pairs that interact
  };

  // The batched kernel of this combination, if it has one and the processor runs it (else both null).
  struct Batch {
    const cohesive_contacts::Input* cohesive;
    const linear_contacts::Input* linear;
    bool direct;   // the cohesive kernel runs over the shell's slots (see slots_)
    bool avx512;   // the kernels' AVX-512 builds, else the AVX2 ones
  };

  // The batched kernels' views of the state (a fixed cell and a deforming one alike).
  linear_contacts::Input linear_batch_input(System<D>& s) {
    auto& P = s.particles;
    linear_contacts::Input in{};
    in.position = reinterpret_cast<const double*>(P.position.data()), in.radius = P.radius.data(), in.mass = P.mass.data();
    in.velocity_predicted = reinterpret_cast<const double*>(P.velocity_predicted.data());
    in.partner = s.neighbours.partner.data(), in.shift = reinterpret_cast<const Vec<3>*>(s.neighbours.shift.data());
    in.touched = touched_.data(), in.evaluation = evaluation_;
    in.k = law_.k, in.c = law_.c, in.overlap_limit = law_.overlap_limit, in.dt = s.dt;
    in.affine = s.affine_flow;
    for (int a = 0; a < D; ++a)
      in.strain_rate[a] = s.strain_rate[a], in.scale[a] = s.cell_scale[a], in.flow_factor[a] = flow_factor(s, a);
    if constexpr (Friction::enabled) {
      in.tangential = reinterpret_cast<double*>(tangential_.data());
      in.velocity = reinterpret_cast<const double*>(P.velocity.data());
      in.angular_velocity = reinterpret_cast<const double*>(P.angular_velocity.data());
      in.friction_stiffness = friction_.stiffness_ratio * law_.k, in.friction_damping_ratio = friction_.damping_ratio;
      in.mu = friction_.mu, in.elastic_bound = friction_.elastic_bound;
    }
    return in;
  }
  cohesive_contacts::Input cohesive_batch_input(System<D>& s) {
    auto& P = s.particles;
    const auto flat = [](auto& v) { return reinterpret_cast<double*>(v.data()); };
    const auto cflat = [](const auto& v) { return reinterpret_cast<const double*>(v.data()); };
    cohesive_contacts::Input in{};
    in.position = cflat(P.position), in.radius = P.radius.data();
    in.velocity_predicted = cflat(P.velocity_predicted), in.velocity = cflat(P.velocity);
    in.angular_velocity = cflat(P.angular_velocity);
    in.partner = s.neighbours.partner.data();
    in.shift = reinterpret_cast<const Vec<2>*>(s.neighbours.shift.data());
    if (damping_builds_ != s.neighbours.builds()) {   // c_n per list entry, a function of the masses only
      damping_.resize(s.neighbours.pair_count());
      for (std::size_t i = 0; i + 1 < s.neighbours.start.size(); ++i)
        for (auto k = s.neighbours.start[i]; k < s.neighbours.start[i + 1]; ++k)
          damping_[k] = law_.damping(P.mass[i], P.mass[s.neighbours.partner[k]]);
      damping_builds_ = s.neighbours.builds();
    }
    in.damping = damping_.data();
    in.touched = touched_.data(), in.evaluation = evaluation_;
    in.tangential = flat(tangential_);
    in.k = law_.k, in.attraction = law_.attraction, in.range = law_.range;
    in.overlap_limit = law_.overlap_limit, in.dt = s.dt;
    in.friction_stiffness_ratio = friction_.stiffness_ratio, in.friction_damping_ratio = friction_.damping_ratio;
    in.mu = friction_.mu, in.elastic_bound = friction_.elastic_bound;
    if constexpr (Rolling::enabled) {
      in.rolling_angle = flat(rolling_angle_);
      in.rolling_stiffness = rolling_.stiffness, in.rolling_coefficient = rolling_.coefficient;
      in.rolling_damping = rolling_.damping;
    }
    in.affine = s.affine_flow;
    in.strain_rate_x = s.strain_rate[0], in.strain_rate_y = s.strain_rate[1];
    in.flow_factor_x = flow_factor(s, 0), in.flow_factor_y = flow_factor(s, 1);
    in.tail_reach = law_.reach();
    in.vector_loads = pair_filter::vector_loads();
    return in;
  }

  // Adds dv to the pair's relative velocity in `v` (P.velocity or P.velocity_predicted), shared by the
  // masses so that momentum stays.
  static void kick_apart(const Particles<D>& P, std::vector<Vec<D>>& v, const OnsetLag& o, const Vec<D>& dv) {
    const double mi = P.mass[o.i], mj = P.mass[o.j];
    v[o.j] += (mi / (mi + mj)) * dv;
    v[o.i] -= (mj / (mi + mj)) * dv;
  }

  // The rows [row_begin, row_end): their particles' forces and torques go straight into the particles'
  // arrays, those of partners beyond row_end into far_force and far_torque, the partners listed in g.far.
  // Shared: other threads take other rows (else row_end is N, and no partner lies beyond it).
  template <bool Virial, bool Shared>
  long loop(System<D>& s, std::size_t row_begin, std::size_t row_end, Vec<D>* far_force, Spin<D>* far_torque,
            Eigen::Matrix<double, D, D>& virial, Gathered& g, const Batch& batch) {
    auto& P = s.particles;
    const auto& nl = s.neighbours;
    long clamped = 0;
    // The pair virial, summed here (in registers: plain doubles, which the compiler keeps there where it
    // kept an Eigen matrix in memory) and added to virial at the end.
    double w[D * D] = {};
    // Plain pointers: stores into the force arrays cannot then make the compiler reload them.
    Vec<D>* const force = P.force.data();
    Spin<D>* const torque = P.torque.data();
    // Where partner j's force and torque go (every partner's force is added, so force_of lists it).
    const auto force_of = [&](std::uint32_t j) {
      if (!Shared || j < row_end) return force;
      if (!g.far_seen[j]) g.far_seen[j] = 1, g.far.push_back(j);
      return far_force;
    };
    const auto torque_of = [&](std::uint32_t j) { return !Shared || j < row_end ? torque : far_torque; };
    const Vec<D>* const position = P.position.data();
    const double* const radius = P.radius.data();
    const Vec<D>* const shift = nl.shift.data();
    // The filter tests the shell's entries where it is built (neighbours/shell_list.hpp), else every
    // listed pair; either way it writes the list's entries k. law_.reach() is 0 without an attractive
    // tail: then exactly Rsum in the filter.
    const auto& shell = s.shell;
    const std::uint32_t* const start = shell.built() ? shell.start.data() : nl.start.data();
    const pair_filter::Geometry<D> geometry =
        shell.built() ? pair_filter::Geometry<D>{position, radius, shell.partner.data(), shell.owner.data(), shell.image.data(),
                                                 shift, law_.reach(), shell.entry.data()}
                      : pair_filter::Geometry<D>{position, radius, nl.partner.data(), nl.owner.data(), nl.image.data(), shift, law_.reach()};
    // The batched cohesive kernel over the shell's entries, without the filter (note_selection): the pairs
    // are then the shell's slots (their springs in slots_, their partners the shell's), else list entries.
    const bool direct = batch.direct;
    const std::uint32_t* const partner = direct ? shell.partner.data() : nl.partner.data();
    g.tested = g.selected = 0;
    for (std::size_t b = row_begin; b < row_end; b += block_rows_) {
      const std::size_t e = std::min(row_end, b + block_rows_);
      const std::size_t pairs = start[e] - start[b] + pair_filter::slack;
      g.tested += start[e] - start[b];
      const std::uint32_t* gathered_row;
      const std::uint32_t* gathered_pair;
      const std::uint8_t* gathered_image;
      std::size_t n;
      if (direct) {
        gathered_row = shell.owner.data() + start[b], gathered_pair = slots_.id.data() + start[b];
        gathered_image = shell.image.data() + start[b];
        n = start[e] - start[b];
      } else {
        if (g.pair.size() < pairs) g.row.resize(pairs), g.pair.resize(pairs), g.image.resize(pairs);
        n = pair_filter::gather<D>(geometry, start, b, e, g.row.data(), g.pair.data(), g.image.data());
        gathered_row = g.row.data(), gathered_pair = g.pair.data(), gathered_image = g.image.data();
        g.selected += n;
      }
      // Batched: the steady contacts evaluated first, their results (in blocks of eight pairs, Results8)
      // added below in list order.
      const Results8* batched = nullptr;
      if constexpr (batched_cohesive_ || batched_linear_) {
        if (batch.cohesive || batch.linear) {
          if (g.results.size() < n / 8 + 1) g.results.resize(n / 8 + 1);
          if constexpr (batched_cohesive_)
            clamped += (batch.avx512 ? cohesive_contacts::evaluate_avx512 : cohesive_contacts::evaluate_avx2)(
                *batch.cohesive, gathered_row, gathered_pair, gathered_image, n, {g.results.data(), direct});
          else
            clamped += (batch.avx512 ? linear_contacts::evaluate_avx512 : linear_contacts::evaluate_avx2)(
                *batch.linear, gathered_row, gathered_pair, gathered_image, n, {g.results.data()});
          batched = g.results.data();
        }
      }
      // The row particle's force and torque, and the virial, are summed in registers (the row's
      // force and torque added once per row): in memory, each addition waited for the last one's store.
      std::size_t i = row_end;   // no row yet
      double fi[D] = {};
      Spin<D> ti = Spin<D>::Zero();
      const auto next_row = [&](std::size_t row) {
        if (i != row_end) add_row(force, torque, i, fi, ti);
        i = row, ti.setZero();
        for (double& c : fi) c = 0;
      };
      // A pair's force f on j (r: from i to j) into the sums, as Eigen's fi -= f and w += f r^T would.
      const auto take = [&](std::uint32_t j, const Vec<D>& f, const Vec<D>& r) {
        force_of(j)[j] += f;
        for (int a = 0; a < D; ++a) fi[a] -= f[a];
        if constexpr (Virial)
          for (int b = 0; b < D; ++b)
            for (int a = 0; a < D; ++a) w[a + D * b] += f[a] * r[b];
      };
      // The lanes whose results the batched kernel completed: the cohesive kernels' `ready` ones (steady
      // contacts; from the AVX-512 kernel also the attraction's tail and, as zeros, the shell's pairs that do
      // not interact), the linear kernels' steady contacts.
      const auto ready = [](const auto& c) -> unsigned {
        if constexpr (batched_cohesive_) return c.ready;
        else return c.steady;
      };
      // A pair the batched kernel evaluated, as contact_force (or the tail below) would have applied it.
      const auto steady_contact = [&](const auto& c, unsigned l, std::size_t q) {   // c: a Results8
        if (gathered_row[q] != i) next_row(gathered_row[q]);
        const std::uint32_t j = c.partner[l];
        if constexpr (batched_cohesive_) {
          // j's torque through a local: one load and one store (through the array, the compiler
          // stored it after each operation, since the results could alias it).
          double& tj = torque_of(j)[j][0];
          double t = tj;
          t -= c.torque_j[l];
          ti[0] -= c.torque_i[l];
          if constexpr (Rolling::enabled) {
            t += c.moment[l];
            ti[0] -= c.moment[l];
          }
          tj = t;
          take(j, Vec<D>(c.fx[l], c.fy[l]), Vec<D>(c.rx[l], c.ry[l]));
        } else {
          if constexpr (Friction::enabled) {
            torque_of(j)[j] += Spin<D>(c.torque_j[0][l], c.torque_j[1][l], c.torque_j[2][l]);
            ti += Spin<D>(c.torque_i[0][l], c.torque_i[1][l], c.torque_i[2][l]);
          }
          take(j, Vec<D>(c.f[0][l], c.f[1][l], c.f[2][l]), Vec<D>(c.r[0][l], c.r[1][l], c.r[2][l]));
        }
      };
      for (std::size_t q = 0; q < n; ++q) {
        if constexpr (batched_cohesive_ || batched_linear_) {
          if (batched) {
            const Results8& c = batched[q >> 3];
            const unsigned l = q & 7;
            if (l == 0 && ready(c) == 0xFF) {   // eight pairs evaluated by the kernel: unrolled, every field at a fixed offset
#pragma GCC unroll 8
              for (unsigned m = 0; m < 8; ++m) steady_contact(c, m, q + m);
              q += 7;
              continue;
            }
            if (ready(c) >> l & 1) {
              steady_contact(c, l, q);
              continue;
            }
            if constexpr (batched_cohesive_)
              if (direct && !(c.interacting >> l & 1)) continue;   // the kernel ran over every entry of the shell
          }
        }
        if (gathered_row[q] != i) next_row(gathered_row[q]);
        const std::uint32_t k = gathered_pair[q], j = partner[k];
        const Vec<D> xi = position[i];
        const double Ri = radius[i];
        const Vec<D> r = position[j] + shift[gathered_image[q]] - xi;
        const double Rsum = Ri + radius[j];
        const double d2 = r.squaredNorm();
        if constexpr (Law::has_tail) {
          if (d2 >= Rsum * Rsum) {   // open pair within the attraction range: central force only
            const double d = std::sqrt(d2);
            const Vec<D> f = over_distance(law_.tail(d - Rsum), d) * r;
            take(j, f, r);   // attraction counts in the virial too
            continue;
          }
        }
        // Through a copy: ti, never address-taken, can then stay in a register on the batched path.
        Spin<D> ti_copy = ti;
        const Vec<D> f = contact_force(s, i, j, k, r, d2, Rsum, torque_of(j), ti_copy, clamped, g.lags, g.parted);   // on j
        ti = ti_copy;
        take(j, f, r);
      }
      if (i != row_end) add_row(force, torque, i, fi, ti);
      if constexpr (batched_cohesive_)
        if (direct)   // the interacting entries
          for (std::size_t q = 0; q < n; q += 8) g.selected += bits_set(batched[q >> 3].interacting);
    }
    if constexpr (Virial)
      for (int b = 0; b < D; ++b)
        for (int a = 0; a < D; ++a) virial(a, b) += w[a + D * b];
    return clamped;
  }

  // The bits set in a byte (the portable build has no popcount instruction).
  static unsigned bits_set(std::uint8_t b) {
    unsigned x = b - ((b >> 1) & 0x55u);
    x = (x & 0x33u) + ((x >> 2) & 0x33u);
    return (x + (x >> 4)) & 0x0Fu;
  }

  static void add_row(Vec<D>* force, Spin<D>* torque, std::size_t i, const double* fi, const Spin<D>& ti) {
    for (int a = 0; a < D; ++a) force[i][a] += fi[a];
    if constexpr (torques_) torque[i] += ti;
  }

  // The last evaluation's parting charges whose pairs still overlap: the parting did not come, so the charge
  // is taken back, now (contact_step.hpp, parting). Pairs that parted keep theirs.
  void take_back_partings(System<D>& s) const {
    auto& P = s.particles;
    for (const Parted& c : charged_) {
      const Vec<D> r = s.box.minimum_image(P.position[c.j] - P.position[c.i]);
      const double d = r.norm();
      if (!(d < P.radius[c.i] + P.radius[c.j])) continue;
      const Vec<D> f = (-c.charge / d) * r;   // on j
      P.force[c.j] += f, P.force[c.i] -= f;
      if (s.want_virial) s.virial += f * r.transpose();
    }
  }

  // A touching pair: the normal law, friction and rolling resistance; returns the force on j and adds
  // the torques (the one on i into ti, the row's sum). Flattened (the law, friction and rolling
  // inlined): their shared terms, such as the pair's damping coefficient, are then computed once and
  // kept in registers. Not inlined into the pair loop, whose hot path (the batched contacts) then keeps
  // its sums in registers: where the batched kernels run, only a contact's first step and a contact parting
  // within the step come here.
  [[gnu::flatten, gnu::noinline]] Vec<D> contact_force(const System<D>& s, std::size_t i, std::size_t j, std::size_t k, const Vec<D>& r,
                                         double d2, double Rsum, Spin<D>* torque, Spin<D>& ti, long& clamped,
                                         std::vector<OnsetLag>& lags, std::vector<Parted>& parted) {
    const auto& P = s.particles;
    const double dt = s.dt;
    const double Ri = P.radius[i], mi = P.mass[i];
    const double d = std::sqrt(d2);
    const Vec<D> n = unit(r, d);
    const double mj = P.mass[j], Rj = P.radius[j];
    // The pair's c_n, computed once (a root for the adhesive law): the stores into the springs and
    // torques below could alias the law's members, so the compiler would compute it again.
    const double cn = law_.damping(mi, mj);
    double vn = (P.velocity_predicted[j] - P.velocity_predicted[i]).dot(n);
    Vec<D> flow = Vec<D>::Zero();   // relative velocity of the affine flow (deforming cell only)
    if (s.affine_flow) {
      flow = s.strain_rate.cwiseProduct(r);
      vn += flow.dot(n);
    }
    // The contact's first step: the pair did not overlap at the previous evaluation (a per-pair
    // stamp; the sign of the overlap before the step is a matter of rounding on a step boundary).
    const bool first = history_.touched[k] + 1 != evaluation_;
    history_.touched[k] = evaluation_;
    // Its overlap before the step, for the sub-step onset: the step moved the positions by
    // dt * v(t + dt/2) exactly (then, in a deforming cell, scaled them with the cell).
    double before = 0;
    if (first) {
      // Springs start relaxed (an open pair's are stale, see holds_history).
      if constexpr (Friction::enabled) history_.tangential[k].setZero();
      if constexpr (Rolling::enabled) history_.rolling_angle[k].setZero();
      const Vec<D> moved = dt * (P.velocity[j] - P.velocity[i]);
      before = Rsum - (s.affine_flow ? Vec<D>(r.cwiseQuotient(s.cell_scale) - moved) : Vec<D>(r - moved)).norm();
    }
    ContactStep step{Rsum - d, before, vn, dt, first, s.first_step};
    if (first) {   // evaluated where the exact solution is; the pair gets there in the next step
      const double lag = onset_lag(step, cn * (mi + mj) / (mi * mj));
      if (lag > 0) {
        step.overlap -= lag, step.overlap_before -= lag;
        lags.push_back({std::uint32_t(i), std::uint32_t(j), lag, n});
      }
    }
    double elastic;
    bool was_clamped;
    const double fn = law_.force(step, mi, mj, cn, std::min(Ri, Rj), elastic, was_clamped);
    clamped += was_clamped;
    if constexpr (Law::has_tail)   // kept, to be taken back if the pair still overlaps at the next evaluation
      if (const double charge = law_.parting_charge(step, cn); charge != 0)
        parted.push_back({std::uint32_t(i), std::uint32_t(j), charge});
    Vec<D> f = fn * n;   // on j
    if constexpr (Friction::enabled || Rolling::enabled) {
      const SpringMotion<D> motion = spring_motion(s, r, P.velocity[j] - P.velocity[i]);
      if constexpr (Friction::enabled)
        f += tangential_force(P, i, j, k, n, d, motion, Rsum, Ri, Rj, mi, mj, fn, elastic, cn, dt, torque, ti);
      if constexpr (Rolling::enabled) rolling_moment(P, i, j, k, n, motion, elastic, cn, Ri, Rj, dt, torque, ti);
    }
    return f;
  }

  // Tangential force on j; adds the torques (on i into ti). Ri, Rj: distances from the centres to the contact point.
  // xi accumulates the half-step (position-consistent) tangential velocity, at the middle of the step (the
  // normal, lever arms and cell flow there: SpringMotion), and the dashpot acts on
  // the same velocity: a predicted end-of-step velocity (as the normal dashpot uses) is stable only
  // for c dt / m < 0.57 and the tangential-rotational mass of a disk pair is m* / 3, so grains with a
  // few contacts went unstable at c_t = c_n; the half-step velocity is stable up to c dt / m < 2.
  // flow: the pair's relative velocity from the cell's affine deformation (zero in a fixed cell); cn: the pair's c_n.
  // Sliding (|F_t| > mu F_n): F_t is capped, and the spring, if it alone exceeds the bound, is shortened to
  // |k_t xi| = mu F_n (physics.md section 4), never lengthened. With a tangential dashpot the trial force can
  // pass the bound while the spring is below it; stretching the spring to the bound then would store energy that
  // no motion had put there (an oblique frictional collision, e = 0.9, c_t = c_n / 2, impact parameter 0.7 d,
  // comes out with 1.7 % more energy than it went in with). Shortening
  // only is passive: the capped force does at most the work the spring and the dashpot would have done.
  // Without a dashpot (c_t = 0, the consolidation scenes) the trial force is the spring's and both rules agree.
  Vec<D> tangential_force(const Particles<D>& P, std::size_t i, std::size_t j, std::size_t k, const Vec<D>& n,
                          double d, const SpringMotion<D>& motion, double Rsum, double radius_i, double radius_j, double mi,
                          double mj, double fn, double elastic, double cn, double dt, Spin<D>* torque, Spin<D>& ti) {
    // Lever arms to the contact point, the middle of the overlap: they add up to d, so the
    // torques of F_t balance its moment and total angular momentum is conserved exactly.
    const double half_overlap = 0.5 * (Rsum - d), Ri = radius_i - half_overlap, Rj = radius_j - half_overlap;
    const Vec<D>& flow = motion.flow_mid;
    const double kt = friction_.stiffness_ratio * law_.stiffness(mi, mj);
    const double ct = friction_.damping_ratio * cn;
    const double bound = friction_.mu * (friction_.elastic_bound ? elastic : fn);   // >= 0
    if constexpr (D == 2) {
      // Everything along t = z x n: omega x (R n) = omega R t, and F_t = f t has torque -R f on both
      // grains (lever arms -Rj n and Ri n, forces f t and -f t). The relative velocity u is taken along the
      // tangent of the step's middle, t + eps n, eps = (h/2) u_t / d the pair's turn over half a step (by the
      // reciprocal n took, see unit), with the lever arms there (d - (h/2) u_n): to second order, as the
      // midpoint rule needs, without a root.
      const Vec<2> t(-n[1], n[0]);
      const Vec<2> u = P.velocity[j] - P.velocity[i] + flow;
      const double ut = u.dot(t), un = u.dot(n), half_step = 0.5 * dt;
      const double eps = half_step * ut * (1 / d), d_mid = d - half_step * un;
      const double half_mid = 0.5 * (Rsum - d_mid), Ri_mid = radius_i - half_mid, Rj_mid = radius_j - half_mid;
      const double vt = ut + eps * un - P.angular_velocity[j][0] * Rj_mid - P.angular_velocity[i][0] * Ri_mid;
      double& xi = history_.tangential[k][0];
      xi += vt * dt;
      double ft = -kt * xi - ct * vt;
      if (std::abs(ft) > bound) {   // sliding: cap the force, and the spring at |k_t xi| = mu F_n (see above)
        ft = std::copysign(bound, ft);
        if (std::abs(kt * xi) > bound) xi = std::copysign(bound, xi) / kt;
      }
      torque[j][0] -= Rj * ft;
      ti[0] -= Ri * ft;
      return ft * t;
    } else {
      // The same at the middle of the step, where the half-step velocities are (SpringMotion).
      const double half_mid = 0.5 * (Rsum - motion.d_mid), Ri_mid = radius_i - half_mid, Rj_mid = radius_j - half_mid;
      const Vec<3>& nm = motion.n_mid;
      Vec<3>& xi = history_.tangential[k];
      turn_into_tangent_plane(xi, motion.n_before, n);
      Vec<3> vt = (P.velocity[j] - P.angular_velocity[j].cross(Rj_mid * nm)) - (P.velocity[i] + P.angular_velocity[i].cross(Ri_mid * nm)) + flow;
      vt -= vt.dot(nm) * nm;
      vt -= vt.dot(n) * n;
      xi += vt * dt;
      Vec<3> ft = -kt * xi - ct * vt;
      const double mag2 = ft.squaredNorm();
      if (mag2 > bound * bound) {   // sliding (so |F_t| > 0): cap the force, and the spring at |k_t xi| = mu F_n (see above)
        ft *= bound / length_from_square(ft, mag2);
        const double reach = bound / kt, stretch2 = xi.squaredNorm();
        if (stretch2 > reach * reach) xi *= reach / std::sqrt(stretch2);
      }
      torque[j] += (-Rj * n).cross(ft);
      ti += (Ri * n).cross(-ft);
      return ft;
    }
  }

  // |v| from its square, also where that square overflows (linear_contacts::overflow_rescale).
  static double length_from_square(const Vec<3>& v, double square) {
    if (square <= std::numeric_limits<double>::max()) return std::sqrt(square);
    return std::sqrt((v * linear_contacts::overflow_rescale).squaredNorm()) / linear_contacts::overflow_rescale;
  }

  // x / d and r / d for a pair at distance d. In 2D through the reciprocal: the cohesive kernels take one
  // division for n, the spring's turn over half a step (tangential_force) and the attraction's tail, two or
  // three fewer a pair (4 % of a step). 3D divides, as the linear kernels do.
  static double over_distance(double x, double d) {
    if constexpr (D == 2) return x * (1 / d);
    else return x / d;
  }
  static Vec<D> unit(const Vec<D>& r, double d) {
    if constexpr (D == 2) return r * (1 / d);
    else return r / d;
  }

  // 3D springs (xi, theta_R) follow the contact: v, in the plane normal to n_before, is turned by the rotation
  // that takes n_before to n (about n_before x n, which keeps its length and its direction about n), then what
  // rounding left along n is taken off. Not projected into the new plane and rescaled to its old length: that
  // turns it towards the rotation axis by (w h)^2 / 2 a step, first order in a turning contact
  // (docs/accuracy.md, "Order of whole scenes").
  // A normal turned by (nearly) half a turn in one step, a pair whose centres crossed, has no such rotation (0 / 0 would
  // give NaN): v is then only projected into the new plane (linear_contacts::spring_turnable). Elsewhere the
  // turn is well-conditioned.
  static void turn_into_tangent_plane(Vec<3>& v, const Vec<3>& n_before, const Vec<3>& n) {
    const double c = 1 + n_before.dot(n);
    if (c > linear_contacts::spring_turnable) v -= v.dot(n) / c * (n_before + n);
    v -= v.dot(n) * n;
  }

  // The pair's geometry at the step's start and middle, where the springs need it: the step moved the pair
  // by dt v(t + dt/2) exactly (then, in a deforming cell, scaled it with the cell). v: the relative half-step
  // velocity. Written out operation by operation: the batched kernels repeat them in this order.
  static SpringMotion<D> spring_motion(const System<D>& s, const Vec<D>& r, const Vec<D>& v) {
    SpringMotion<D> m;
    if constexpr (D == 3) {   // 2D: tangential_force takes the middle of the step to second order itself
      Vec<D> before, mid;
      for (int a = 0; a < D; ++a) {
        before[a] = (s.affine_flow ? r[a] / s.cell_scale[a] : r[a]) - s.dt * v[a];
        mid[a] = 0.5 * (before[a] + r[a]);
      }
      m.d_mid = std::sqrt(mid.squaredNorm());
      m.n_mid = mid * (1 / m.d_mid);
      m.n_before = before * (1 / std::sqrt(before.squaredNorm()));
    }
    m.flow_mid = Vec<D>::Zero();
    if (s.affine_flow)
      for (int a = 0; a < D; ++a) m.flow_mid[a] = flow_factor(s, a) * r[a];
    return m;
  }
  // The cell's share of a pair's move over the step, as a velocity, is this times the pair vector r: the
  // scaling r / scale -> r over the step h (exact: with it, h (v + flow) is the pair's whole move; the strain
  // rate at the step's end is half a step late). An evaluation without a step (h = 0) takes the strain rate.
  static double flow_factor(const System<D>& s, int a) {
    return s.dt > 0 ? (1 - 1 / s.cell_scale[a]) / s.dt : s.strain_rate[a];
  }

  // Rolling resistance (physics.md section 5): theta_R accumulates the half-step relative rotation
  // (3D: its part perpendicular to n, the spring rotated into the current tangent plane like xi);
  // with K_R = 0 (mu_R = 0) only the rolling dashpot acts. Ri, Rj: the grains' radii; c_n: the pair's.
  void rolling_moment(const Particles<D>& P, std::size_t i, std::size_t j, std::size_t k, const Vec<D>& n,
                      const SpringMotion<D>& motion, double elastic, double cn, double Ri, double Rj, double dt,
                      Spin<D>* torque, Spin<D>& ti) {
    const Spin<D> spin = P.angular_velocity[j] - P.angular_velocity[i];
    Spin<D> moment = Spin<D>::Zero();   // on j
    if (rolling_.stiffness > 0) {
      const double bound = rolling_.coefficient * elastic;   // >= 0
      Spin<D>& theta = history_.rolling_angle[k];
      if constexpr (D == 2) {   // a scalar: the bound is a comparison of absolute values
        theta[0] += spin[0] * dt;
        moment[0] = -rolling_.stiffness * theta[0];
        if (std::abs(moment[0]) > bound) {   // rolling: cap the moment, and the spring so that |K_R theta_R| = mu_R F_N^e
          moment[0] = std::copysign(bound, moment[0]);
          theta[0] = moment[0] / -rolling_.stiffness;
        }
      } else {   // into the tangent plane like xi, the bound on squared lengths
        turn_into_tangent_plane(theta, motion.n_before, n);
        const Vec<3>& nm = motion.n_mid;
        Vec<3> turn = spin - spin.dot(nm) * nm;
        theta += (turn - turn.dot(n) * n) * dt;
        moment = -rolling_.stiffness * theta;
        const double mag2 = moment.squaredNorm();
        if (mag2 > bound * bound) {
          moment *= bound / length_from_square(moment, mag2);
          theta = moment / -rolling_.stiffness;
        }
      }
    }
    // The rolling dashpot, outside the bound like the normal one: it acts on the whole relative spin
    // (3D: twisting too), at the half-step velocity (stable for c_r dt / I < 2, see tangential_force).
    if (rolling_.damping > 0) moment -= rolling_.damping * cn * Ri * Rj * spin;
    torque[j] += moment;
    ti -= moment;
  }

  // The springs and first-step stamps of the shell's entries in the shell's order ("slots"), where the
  // cohesive kernel runs over the shell directly: a batch's slots are consecutive, so the kernel loads
  // and stores them (and the pairs' c_n and partners) as vectors where through the list's entries it
  // gathered and scattered them, the costliest of its memory operations. While live they are the pairs'
  // history and the list's copies of the shell's entries are stale: flush_slots writes them back before
  // anything reads the history through the list (a new list or shell, a save, an observation, the
  // filter's path). A cache of the state, not state: hence mutable, and flushed from const readers.
  struct Slots {
    bool live = false;
    long shell_builds = -1, list_builds = -1;   // the shell and list they were loaded for
    std::vector<std::uint32_t> entry;           // each slot's list entry
    std::vector<std::uint32_t> id;              // 0, 1, 2, ...: the pair loop's entries where it runs over slots
    std::vector<std::uint32_t> touched;
    std::vector<Spring> tangential;
    std::vector<Spin<D>> rolling_angle;
    std::vector<double> damping;
    std::vector<double> radius_i, radius_j;   // the pair's radii (constant through a run)
  };
  void load_slots(const System<D>& s) {
    const auto& entry = s.shell.entry;
    const std::size_t n = entry.size();
    slots_.entry = entry;
    if (slots_.id.size() != n) {
      slots_.id.resize(n);
      for (std::size_t e = 0; e < n; ++e) slots_.id[e] = std::uint32_t(e);
    }
    slots_.touched.resize(n), slots_.damping.resize(n), slots_.radius_i.resize(n), slots_.radius_j.resize(n);
    slots_.tangential.resize(Friction::enabled ? n : 0), slots_.rolling_angle.resize(Rolling::enabled ? n : 0);
    for (std::size_t e = 0; e < n; ++e) {
      const std::uint32_t k = entry[e];
      slots_.touched[e] = touched_[k], slots_.damping[e] = damping_[k];
      slots_.radius_i[e] = s.particles.radius[s.shell.owner[e]], slots_.radius_j[e] = s.particles.radius[s.shell.partner[e]];
      if constexpr (Friction::enabled) slots_.tangential[e] = tangential_[k];
      if constexpr (Rolling::enabled) slots_.rolling_angle[e] = rolling_angle_[k];
    }
    slots_.live = true, slots_.shell_builds = s.shell.builds(), slots_.list_builds = s.neighbours.builds();
  }
  void flush_slots() const {
    if (!slots_.live) return;
    for (std::size_t e = 0; e < slots_.entry.size(); ++e) {
      const std::uint32_t k = slots_.entry[e];
      touched_[k] = slots_.touched[e];
      if constexpr (Friction::enabled) tangential_[k] = slots_.tangential[e];
      if constexpr (Rolling::enabled) rolling_angle_[k] = slots_.rolling_angle[e];
    }
    slots_.live = false;
  }
  // Where this evaluation's pairs keep their history, indexed by the pair loop's entries: the list's
  // arrays, or the slots.
  struct History {
    std::uint32_t* touched;
    Spring* tangential;
    Spin<D>* rolling_angle;
  };

  Law law_;
  Friction friction_;
  Rolling rolling_;
  // Per neighbour pair, aligned with the list (mutable: see Slots): xi (2D: along z x n), theta_R, and the
  // last evaluation at which the pair overlapped (0: never).
  mutable std::vector<Spring> tangential_;
  mutable std::vector<Spin<D>> rolling_angle_;
  mutable std::vector<std::uint32_t> touched_;
  mutable Slots slots_;
  History history_{};
  std::uint32_t evaluation_ = 1;          // force evaluations so far, + 1
  std::vector<Gathered> gathered_;       // per thread, reused
  std::vector<OnsetLag> pending_;        // onset lags found in the last step, made up in the next
  std::vector<OnsetLag> active_;         // ... being made up in this step
  std::vector<Parted> charged_;          // parting charges of the last evaluation
  long clamped_now_ = 0, clamped_total_ = 0;
  std::vector<double> damping_;   // batched_cohesive_: each list entry's c_n, for the list of build damping_builds_
  long damping_builds_ = -1;
};

}  // namespace grains
