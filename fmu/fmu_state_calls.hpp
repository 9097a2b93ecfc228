// The six FMU-state functions (get, set, free, serialized size, serialize, deserialize), one body each for FMI 2
// and 3: the two APIs differ only in their type names and in the names their messages quote. `instance` is the
// host's instance handle, `function` the exported function's name, `argument` the standard's name of its state
// argument (FMUstate in FMI 2, FMUState in FMI 3). Each runs in guarded_call, as every FMI function does.
#pragma once
#include <cstddef>

#include "instance.hpp"

namespace grains::fmu::state_calls {

Status get(const void* instance, const char* function, const char* argument, void** state);
Status set(const void* instance, const char* function, const char* argument, const void* state);
Status free(const void* instance, const char* function, void** state);   // a null state: nothing to free (FMI 2 and 3)
Status serialized_size(const void* instance, const char* function, const void* state, std::size_t* size);
Status serialize(const void* instance, const char* function, const void* state, void* bytes, std::size_t size);
Status deserialize(const void* instance, const char* function, const void* bytes, std::size_t size, void** state);

}  // namespace grains::fmu::state_calls
