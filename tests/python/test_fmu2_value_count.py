"""FMI 2 get and set with an nvr that no array holds (2^62, a negative count passed as size_t) are refused in the
FMU's words, naming the function, the count and what is allowed, before anything is read or allocated. The host
saw the C++ library's "cannot create std::vector larger than max_size()" instead."""
from fmu_host import host_process

HUGE_COUNT_HOST = """
import ctypes
from fmu_host import FMICallException, Unit, fmu_path
unit = Unit(fmu_path("aggregation", 2))
unit.initialize({"particles.count": 100, "run.threads": 1})
n = 1 << 62
ref = lambda name: (ctypes.c_uint32 * 1)(unit.variables[name].valueReference)
calls = [
    ("fmi2GetReal", ref("kinetic_energy"), (ctypes.c_double * 1)()),
    ("fmi2GetInteger", ref("particles.seed"), (ctypes.c_int32 * 1)()),
    ("fmi2SetReal", ref("drag.rate"), (ctypes.c_double * 1)(0.5)),
    ("fmi2SetInteger", ref("run.threads"), (ctypes.c_int32 * 1)(1)),
    # no Boolean variables here: the count is refused before the references' types are looked at
    ("fmi2GetBoolean", ref("kinetic_energy"), (ctypes.c_int32 * 1)()),
    ("fmi2SetBoolean", ref("kinetic_energy"), (ctypes.c_int32 * 1)(1)),
]
for name, refs, values in calls:
    try:
        getattr(unit.fmu, name)(unit.fmu.component, refs, n, values)
        print(name, "accepted")
    except FMICallException:
        print(name, "refused:", unit.errors()[-1])
unit.step(unit.get("time.dt"))   # the instance goes on
print("stepped")
"""


def test_an_nvr_no_array_holds_is_refused_naming_the_function_the_count_and_the_limit():
    r = host_process(HUGE_COUNT_HOST)
    assert r.returncode == 0, (r.returncode, r.stdout[-2000:], r.stderr[-2000:])
    lines = {line.split(" ")[0]: line for line in r.stdout.splitlines()}
    n, most = 1 << 62, (2 ** 63 - 1) // 8
    for name in ("fmi2GetReal", "fmi2GetInteger", "fmi2SetReal", "fmi2SetInteger", "fmi2GetBoolean", "fmi2SetBoolean"):
        assert f"refused: {name}: nvr = {n} is more values than an array holds" in lines[name], r.stdout
        assert f"is allowed from 0 to {most}" in lines[name], r.stdout
    assert "max_size" not in r.stdout
    assert "stepped" in r.stdout
