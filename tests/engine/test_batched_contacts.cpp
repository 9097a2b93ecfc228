// The batched (AVX-512 and AVX2, each where the processor has it) evaluation of steady contacts and the
// vector pair filters against the portable pair loop, on 1 and 2 threads: the whole saved state (positions,
// velocities, springs, stamps, cell) is the same byte for byte, and the contact counters agree.
// - Cohesive disks (interactions/cohesive_contacts.hpp, both builds; AVX-512 with the velocities gathered and
//   loaded): a loose packing with friction and rolling
//   resistance (rolling dashpot on), in a fixed cell and compressed in a pressure-controlled one. It gains
//   contacts, slides and rolls on the way, so steady contacts, first steps, distant bonds, the parting
//   charge and both Coulomb caps all occur.
// - Spheres (interactions/linear_contacts.hpp, both builds): a dense hot gas, fixed and compressed (so the
//   release charge, clamped overlaps and the affine flow occur), frictionless and with Coulomb friction
//   (mu = 0.1: most contacts slide; mu = 0.5 with k_t = 2/7 k_n and c_t = c_n / 2 as in the gas-friction scene).
#include <cstring>

#include <catch2/catch.hpp>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "interactions/cohesive_contacts.hpp"
#include "interactions/pair_filter.hpp"
#include "io/scene.hpp"
#include "packing_scenes.hpp"

using namespace grains;

namespace {

struct Outcome {
  std::vector<std::byte> state;
  double contacts, clamped;
};

using pair_filter::Isa;

Outcome run(const Scene& scene, Isa isa, long steps) {
  pair_filter::cap_isa(isa);
  auto s = Simulation::create(scene);
  s->step_n(steps);
  pair_filter::cap_isa(Isa::avx512);
  return {s->save_state(), s->get("contacts"), s->get("clamped_contacts_total")};
}

// The vector builds this processor runs (AVX2, AVX-512); one it lacks is named in a warning, and without
// either the test is reported as skipped (tests/CMakeLists.txt).
std::vector<Isa> vector_isas() {
  std::vector<Isa> out;
  for (Isa isa : {Isa::avx2, Isa::avx512}) {
    pair_filter::cap_isa(isa);
    if (pair_filter::isa() == isa) out.push_back(isa);
    else WARN("this processor lacks " << (isa == Isa::avx2 ? "AVX2" : "AVX-512") << " (or GRAINS_PAIR_ISA caps it): that build is not tested");
  }
  pair_filter::cap_isa(Isa::avx512);
  if (out.empty()) WARN("no vector build of the pair loop here: only the portable one runs");
  return out;
}

const char* name(Isa isa) { return isa == Isa::avx512 ? "AVX-512" : isa == Isa::avx2 ? "AVX2" : "portable"; }

}  // namespace

TEST_CASE("batched contacts, cohesive disks: bit-identical to the portable pair loop", "[contacts][batched]") {
  for (int threads : {1, 2})
    for (double rolling : {0.0, 0.005})
      for (bool affine : {true, false}) {
        const Scene scene = compressed_packing(threads, rolling, affine);
        const Outcome portable = run(scene, Isa::portable, 30000);
        for (Isa isa : vector_isas())
          // AVX-512: the velocities gathered and read by plain loads (pair_filter::vector_loads); AVX2 has one way.
          for (bool loads : isa == Isa::avx512 ? std::vector<bool>{false, true} : std::vector<bool>{false}) {
            INFO(name(isa) << (loads ? " (velocities by loads)" : "") << ", threads " << threads << ", rolling " << rolling
                           << ", deforming cell " << affine);
            const bool loads_before = pair_filter::vector_loads();
            pair_filter::set_vector_loads(loads);
            const long dense_before = cohesive_contacts::dense_evaluations();
            const Outcome batched = run(scene, isa, 30000);
            pair_filter::set_vector_loads(loads_before);
            // Most evaluations ran the kernel over the shell's slots (the pairs near contact nearly all touch).
            CHECK(cohesive_contacts::dense_evaluations() - dense_before > 10000);
            CHECK(batched.contacts > 100);   // steady contacts are most of the work
            CHECK(batched.contacts == portable.contacts);
            CHECK(batched.clamped == portable.clamped);
            CHECK(batched.state.size() == portable.state.size());
            CHECK(batched.state == portable.state);
          }
      }
}

// Where the kernel runs over the shell's slots, the springs live there and are written back to the list's
// entries before anything reads them through the list: observations (every 100 steps here), saved states
// (restored into a new simulation, which continues), a new list or shell. None of these may change the run,
// in a deforming cell too (a saved state carries what rebuilds CVODE's history).
TEST_CASE("batched contacts, cohesive disks: reading or saving the springs between steps leaves the run as it was",
          "[contacts][batched]") {
  for (Isa isa : vector_isas())
  for (int threads : {1, 2})
    for (bool affine : {false, true}) {
      INFO(name(isa) << ", threads " << threads << ", deforming cell " << affine);
      pair_filter::cap_isa(isa);
      const Scene scene = compressed_packing(threads, 0.005, affine);
      auto straight = Simulation::create(scene);
      const long dense_before = cohesive_contacts::dense_evaluations();
      for (int chunk = 0; chunk < 6; ++chunk) straight->step_n(1000);
      CHECK(cohesive_contacts::dense_evaluations() - dense_before > 2000);
      CHECK(straight->get("neighbour_builds") > 1);
      CHECK(straight->get("shell_builds") > 10);
      auto read = Simulation::create(scene);
      double energy = 0;
      for (int chunk = 0; chunk < 60; ++chunk) {
        read->step_n(100);
        energy += read->get("elastic_energy");   // the springs' energy: read through the list
        if (chunk % 10 == 9) {                    // saved and continued by a new simulation
          auto next = Simulation::create(scene);
          next->restore_state(read->save_state());
          read = std::move(next);
        }
      }
      CHECK(energy > 0);
      CHECK(read->get("elastic_energy") == straight->get("elastic_energy"));
      CHECK(read->save_state() == straight->save_state());
      pair_filter::cap_isa(Isa::avx512);
    }
}

// The other ways out of the slots: the portable pair loop chosen between steps (the slots are flushed and
// the list's arrays serve it, then loaded again), the springs read through the list (the elastic energy;
// the moduli's Z2, from list_springs' |F_T| and |Gamma|) against the portable loop's at the same steps, a
// state restored into the same simulation while its slots are live (rewound), and row shares of three
// threads. Fixed cell: no save restarts CVODE here.
TEST_CASE("batched contacts, cohesive disks: the slots survive path switches, spring reads and rewinds", "[contacts][batched]") {
  constexpr long steps = 6000;
  // Steps in uneven chunks; every third on the portable loop if `mixed`, else all of them; the springs read
  // after every fifth (as bytes: Z2 may be NaN), and the state saved once past the middle.
  const auto run = [](Simulation& s, Isa isa, bool mixed, std::vector<double>& read, std::vector<std::byte>* middle) {
    for (long done = 0, chunk = 0; done < steps; ++chunk) {
      const long n = std::min(steps - done, 3 + (chunk * 7) % 17);
      pair_filter::cap_isa(!mixed || chunk % 3 == 2 ? Isa::portable : isa);
      s.step_n(n);
      pair_filter::cap_isa(Isa::avx512);
      done += n;
      if (chunk % 5 == 0) read.push_back(s.get("Z2")), read.push_back(s.get("elastic_energy"));   // Z2 first: its own flush
      if (middle && middle->empty() && done >= steps / 2) *middle = s.save_state();
    }
  };
  const auto same_bytes = [](const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
  };
  for (Isa isa : vector_isas())
  for (int threads : {1, 2, 3}) {
    INFO(name(isa) << ", threads " << threads);
    const Scene scene = compressed_packing(threads, 0.005, false, "[analysis]\nelastic_moduli = true\n");
    std::vector<double> portable_reads, mixed_reads;
    auto portable = Simulation::create(scene);
    run(*portable, isa, false, portable_reads, nullptr);
    const auto reference = portable->save_state();
    auto mixed = Simulation::create(scene);
    std::vector<std::byte> middle;
    const long dense_before = cohesive_contacts::dense_evaluations();
    run(*mixed, isa, true, mixed_reads, &middle);
    CHECK(cohesive_contacts::dense_evaluations() - dense_before > 1000);
    CHECK(same_bytes(mixed_reads, portable_reads));
    CHECK(mixed->save_state() == reference);
    // Back to the middle of the run and on again, in the same simulation (its slots were live).
    mixed->step_n(50);
    mixed->restore_state(middle);
    mixed->step_n(steps - mixed->step_count());
    CHECK(mixed->save_state() == reference);
  }
}

TEST_CASE("batched contacts, spheres with and without friction: bit-identical to the portable pair loop", "[contacts][batched]") {
  for (int threads : {1, 2})
    for (bool cell : {false, true})
      for (double mu : {0.0, 0.1, 0.5}) {
        const Scene scene = hot_spheres(threads, cell, mu);
        const Outcome portable = run(scene, Isa::portable, 4000);
        for (Isa isa : vector_isas()) {
        INFO(name(isa) << ", threads " << threads << ", pressure-controlled cell " << cell << ", mu " << mu);
        const Outcome batched = run(scene, isa, 4000);
        CHECK(batched.contacts > 30);   // friction cools the gas: fewer contacts at the end
        CHECK(batched.clamped > 0);   // overlaps beyond the limit happen too
        CHECK(batched.contacts == portable.contacts);
        CHECK(batched.clamped == portable.clamped);
        CHECK(batched.state == portable.state);
        }
      }
}
