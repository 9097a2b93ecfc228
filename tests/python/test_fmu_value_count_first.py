"""FMI 3 get and set pass nValues beside the values: a call whose nValues the references cannot hold is refused
before the FMU reads or allocates that many values. A set with nValues past the host's array read past it (the
host died of SIGSEGV) and a get allocated and zeroed nValues doubles, before either compared the count."""
from fmu_host import host_process

# nValues of 2^26 (512 MB of doubles) beside arrays of one value each, in a host process of its own: a crash there
# is a signal in its return code, and its peak memory is its own.
WRONG_COUNT_HOST = """
import ctypes, resource
from fmu_host import FMICallException, Unit, fmu_path
unit = Unit(fmu_path("aggregation", 3))
unit.initialize({"particles.count": 100, "run.threads": 1})
n = 1 << 26
ref = lambda name: (ctypes.c_uint32 * 1)(unit.variables[name].valueReference)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
calls = [
    ("set Float64", unit.fmu.fmi3SetFloat64, ref("drag.rate"), (ctypes.c_double * 1)(0.5)),
    ("get Float64", unit.fmu.fmi3GetFloat64, ref("kinetic_energy"), (ctypes.c_double * 1)()),
    ("get Int64", unit.fmu.fmi3GetInt64, ref("particles.seed"), (ctypes.c_int64 * 1)()),
    ("set Int64", unit.fmu.fmi3SetInt64, ref("run.threads"), (ctypes.c_int64 * 1)(1)),
]
for label, function, refs, values in calls:
    try:
        function(unit.fmu.component, refs, 1, values, n)
        print(label, "accepted")
    except FMICallException:
        print(label, "refused:", unit.errors()[-1])
grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
print("grown kB", grown)
unit.step(unit.get("time.dt"))   # the instance goes on
print("stepped")
"""


def test_a_value_count_the_references_cannot_hold_is_refused_before_any_value_is_copied():
    r = host_process(WRONG_COUNT_HOST)
    assert r.returncode == 0, (r.returncode, r.stdout[-2000:], r.stderr[-2000:])
    lines = {line.split(" refused: ")[0].removesuffix(" accepted"): line for line in r.stdout.splitlines()}
    n = 1 << 26
    assert f"the call passes {n} values for 1 scalar variables" in lines["set Float64"], r.stdout
    assert f"the call passes {n} values for variables holding 1" in lines["get Float64"], r.stdout
    assert f"the call passes {n} values for variables holding 1" in lines["get Int64"], r.stdout
    assert f"the call passes {n} values for 1 scalar variables" in lines["set Int64"], r.stdout
    grown = int(r.stdout.split("grown kB ")[1].split()[0])
    assert grown < 64 * 1024, f"the refused calls grew the host by {grown} kB (nValues alone is {n * 8 // 1024} kB)"
    assert "stepped" in r.stdout
