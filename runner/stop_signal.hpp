// Ctrl-C and SIGTERM ask a run or programme to stop at its next step boundary, write a checkpoint there
// and end, so that `grains resume` continues it (rather than the process dying mid-step).
#pragma once

namespace grains {

void catch_stop_signals();   // from now on SIGINT and SIGTERM set the request instead of ending the process
bool stop_requested();

}  // namespace grains
