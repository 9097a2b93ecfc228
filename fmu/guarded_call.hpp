// The frame of every FMI function that takes an instance, FMI 2 and 3 alike: finds the instance behind the host's
// handle, logs the call, runs the body and turns anything it throws into an error named after the function, so that
// nothing thrown ever crosses into the host. Each API converts the Status to its own (same order).
#pragma once
#include <exception>
#include <new>
#include <string_view>

#include <fmt/format.h>

#include "instance.hpp"
#include "live_instances.hpp"

namespace grains::fmu {

// The calls that change nothing of the instance: the Get functions (values, status, dependencies), not the FMU state's.
inline bool reads_only(std::string_view function) {
  return function.find("Get") != std::string_view::npos && function.find("FMUstate") == std::string_view::npos &&
         function.find("FMUState") == std::string_view::npos;
}

template <class Body>
Status guarded_call(const void* handle, const char* function, Body&& body) {
  // One call at a time on an instance (claim_instance): the same thread may call again from inside.
  Claim claim;
  try {
    claim = claim_instance(handle, function);
    if (!claim.busy.empty()) claim.busy_logger(Status::error, log_error, claim.busy);
  } catch (...) {   // the refusal's message or the logger's copy out of memory: nothing may reach the host
  }
  if (!claim.instance) return Status::error;   // null, freed, not ours, or busy (said above)
  Instance* in = claim.instance;
  struct Release {   // declared before Answering: released after it has restored the instance
    const void* handle;
    bool outermost;
    ~Release() {
      try {
        if (outermost) release_instance(handle);
      } catch (...) {   // out of memory taking the instance's states out: it stays, freed by nothing
      }
    }
  } release{handle, claim.outermost};
  // From inside another call on this instance (its host's logger calling back), only reads: a set, a reset or a
  // state call there changes what the outer call is using (a logger's set is lost to the rebuild around it, its
  // snapshots_every = 0 divides by zero, its FreeFMUState frees the state being filled).
  if (!claim.outermost && !reads_only(function))
    return in->error(fmt::format("{}: called from inside another call on this instance (its logger calling back): only "
                                 "reads (the Get functions, but for the FMU state's) and FreeInstance are allowed there",
                                 function));
  struct Answering {   // the instance's errors name this call until it returns
    Instance& in;
    const char* outer;
    Answering(Instance& i, const char* f) : in(i), outer(i.answering(f)) {}
    ~Answering() { in.answering(outer); }
  } answering(*in, function);
  try {
    in->log_call(function);
    in->take_warned();   // an earlier call's warnings were its own
    const Status status = body(*in);
    // FMI 2 and 3: Warning is the status of a call that logged a warning (the engine's, raised by this call).
    return status == Status::ok && in->take_warned() ? Status::warning : status;
  } catch (const std::bad_alloc&) {   // a state's copy, say: named as everywhere else
    in->error(fmt::format("{}: {}", function, out_of_memory_message));
  } catch (const std::exception& e) {
    in->error(fmt::format("{}: {}", function, e.what()));
  } catch (...) {
    in->error(fmt::format("{}: unexpected internal error", function));
  }
  return Status::error;
}

}  // namespace grains::fmu
