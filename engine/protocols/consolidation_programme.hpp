// The consolidation programme of physics.md section 9, driven through the Simulation seam only (the
// inputs cell.pressure, cell.active and network.mark): sample preparation (type 1, type 2 or none),
// then the stepwise compression, P* multiplied by 10^(1/stages_per_decade) per stage up to the top
// pressure, then unloading back to the start in larger steps. Every stage runs until the four
// equilibrium criteria hold or its step budget is spent; a stage that runs out is recorded with
// reached = false and the programme goes on, so the caller can report it. Once a stage has settled its
// slow modes are quenched (protocols/stage_quench.hpp: the drag drag.rate, optionally the rolling dashpot).
#pragma once
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "protocols/stage_quench.hpp"

namespace grains {

class Scene;
class Simulation;

struct ProgrammeSettings {
  std::string preparation = "none";   // none | type1 | type2
  double start_pressure = 0.01;       // P* of the prepared state, where unloading ends
  double top_pressure = 13.33;
  int stages_per_decade = 8, unload_stages_per_decade = 2;
  bool load = true, unload = true;
  long check_every = 100;             // steps between equilibrium checks
  long stage_budget = 2'000'000;      // steps per stage
  long aggregation_budget = 20'000'000;
  double first_compression_time = 0;  // the first stage under pressure ramps its target from 0 over this time
  QuenchSettings quench;              // the drag (and rolling dashpot) switched on once a stage has settled

  static ProgrammeSettings from_scene(const Scene& scene);
  // Whether a stage's budget holds the confirm_checks checks in a row that confirm an equilibrium: a stage checks
  // every check_every steps and once more at its budget's end.
  bool budget_can_confirm() const {
    const long checks = stage_budget / check_every + (stage_budget % check_every != 0);
    return checks >= quench.confirm_checks;
  }
  // A scene's own quench_drag_min above its quench_drag (refused for a new programme: the drag could not step
  // down; not on resuming, whose stored scene spells out every default): the SceneError naming it, or nothing.
  static void refuse_floor_above_drag(const Scene& scene);
  // What needs the simulation's time step dt: a first compression of more steps than a run may take is refused
  // naming programme.first_compression_time (SceneError).
  void check_time_step(const Scene& scene, double dt) const;
};

struct StageRecord {
  int index = 0;
  std::string phase;        // aggregation | equilibrate | loading | unloading
  double target = 0;        // P* the stage was run at (NaN for aggregation)
  bool reached = false;     // equilibrium (or, aggregating, one cluster) within the budget
  long steps = 0;
  double time = 0;          // simulated time at the end of the stage
  long quench_start = -1;   // steps into the stage when the quench was first switched on (-1: never)
  double quench_drag = 0;   // gamma T of the quench's drag at the stage's end (stepped down, or as set)
  std::vector<std::pair<std::string, double>> values;   // outputs at the end of the stage
};

// The names of StageRecord::values in `s`, in their order (the stage table's columns after quench_drag).
std::vector<std::string> stage_record_names(const Simulation& s);

// The P* of every stage after the prepared state: loading, then unloading.
std::vector<std::pair<std::string, double>> programme_pressures(const ProgrammeSettings& p);

// Every stage of the programme in order, as (phase, P*): the type-2 aggregation (P* NaN) and relaxation at
// P* = 0, the prepared state at the start pressure, then programme_pressures.
std::vector<std::pair<std::string, double>> programme_stages(const ProgrammeSettings& p);

// Where a programme stands between two equilibrium checks of a stage: with the simulation's state saved at
// the same step, enough to continue it as the unbroken programme goes on (a checkpoint inside a stage).
struct StageProgress {
  int stage = 0;                // the stage under way
  long steps = 0;               // its steps so far (0: from its start)
  std::vector<double> quench;   // StageQuench::progress(); empty for the aggregation, which has no quench

  std::vector<double> values() const;   // stage, steps, quench..., as a checkpoint stores them
  // Throws std::invalid_argument naming what does not fit the programme `p` run with time step dt.
  static StageProgress from_values(const std::vector<double>& values, const ProgrammeSettings& p, double dt);
};

// on_stage: after every stage (the simulation at the stage's end, the next stage not begun: a state saved
// there continues the programme from stage index + 1). on_check: after every equilibrium check that neither
// ended the stage nor spent its budget, with the stage so far (steps, no values), its budget and where the
// programme stands; returning true stops the programme there (the stage not finished, not recorded).
// `from` continues a programme whose earlier stages ran before (the simulation restored to the end of stage
// from.stage - 1, or, with from.steps > 0, to that step of stage from.stage); the records returned are those
// of the stages finished now.
using StageCheck = std::function<bool(const StageRecord&, long budget, const StageProgress&)>;
// Between two checks, `requested` is asked every `every` steps (a check_every of millions of steps would hold a
// Ctrl-C for minutes); when it answers true, on_check is called there, between checks, as at one. A programme
// continued from such a point goes on to the check the unbroken one makes next.
struct StopPoll {
  std::function<bool()> requested;
  long every = 0;   // steps; 0: asked at the checks only (on_check)
};
std::vector<StageRecord> run_programme(Simulation& s, const ProgrammeSettings& p,
                                       const std::function<void(const StageRecord&)>& on_stage = {},
                                       const StageCheck& on_check = {}, const StageProgress& from = {},
                                       const StopPoll& poll = {});

}  // namespace grains
