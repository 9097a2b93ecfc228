// Ctrl-C, SIGTERM and SIGHUP (unless ignored, as under nohup) ask a run or programme to stop at its next step
// boundary, write a checkpoint there and end, so that `grains resume` continues it (rather than the process dying mid-step).
#pragma once
#include <cstddef>

namespace grains {

void catch_stop_signals();   // from now on SIGINT, SIGTERM and SIGHUP set the request instead of ending the process
bool stop_requested();
// Steps between reads of the request in a run of `particles`: about two million particle-steps (a few tenths of a
// second), so that a run or a stage whose outputs or checks are rare still stops; chunks of steps run exactly as
// the whole (Simulation::step_n), so the results do not depend on it.
long stop_check_steps(std::size_t particles);

}  // namespace grains
