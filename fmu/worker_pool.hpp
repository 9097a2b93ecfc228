// OpenMP's worker threads inside a host process that loads and unloads the FMU library, forks, and steps instances
// from several threads. libgomp keeps one pool of workers per host thread that ran a parallel region.
#pragma once

namespace grains::fmu {

// Once per load of the FMU library, before its first instance: keeps libgomp loaded for the rest of the process and
// releases the forking thread's pool before a fork.
void prepare_worker_pools();

// Releases the calling host thread's pool (its workers end; the next parallel region starts new ones).
void release_worker_pool();

}  // namespace grains::fmu
