"""Illegal calls and bad values: each returns an error status with a clear message through the host's
logger, and the host process (this one) carries on; the instance can be reset and used again."""
import shutil

import pytest

from fmu_host import FMICallException, Unit, extracted, fmu_path, host_process


@pytest.fixture(params=[2, 3], ids=["fmi2", "fmi3"])
def unit(request):
    u = Unit(fmu_path("aggregation", request.param))
    yield u
    u.free()


def fails(unit, call, *words):
    """The call raises (error status) and one logged error message holds every word."""
    before = len(unit.errors())
    with pytest.raises(FMICallException):
        call()
    new = unit.errors()[before:]
    assert new, "no message was logged"
    assert any(all(w in m for w in words) for m in new), new
    return new


def test_do_step_before_initialization(unit):
    fails(unit, lambda: unit.fmu.doStep(0.0, 0.1), "DoStep", "not allowed", "instantiated")


def test_terminate_in_initialization_mode(unit):
    """FMI 2 and 3 allow Terminate after initialization only (it was accepted in Initialization Mode)."""
    if unit.version == 2:
        unit.fmu.setupExperiment(startTime=0.0)
    unit.fmu.enterInitializationMode()
    fails(unit, lambda: unit.fmu.terminate(), "Terminate", "not allowed", "initialization")
    unit.fmu.exitInitializationMode()
    unit.fmu.terminate()


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("name", ["", " \t"])
def test_a_blank_instance_name_is_refused(version, name):
    """FMI 2 and 3 want at least one character that is not white space (it names the instance in messages)."""
    unit = Unit.__new__(Unit)
    with pytest.raises(Exception):
        unit.__init__(fmu_path("aggregation", version), name=name)
    assert any("instanceName must be a non-empty string" in m for _, _, m in unit.messages), unit.messages


def test_fixed_parameter_after_initialization(unit):
    unit.initialize({"particles.count": 100})
    fails(unit, lambda: unit.set("contact.restitution", 0.7), "contact.restitution", "fixed parameter")
    unit.step(5 * unit.get("time.dt"))   # the instance still works


def test_unknown_value_reference(unit):
    get = unit.fmu.getReal if unit.version == 2 else unit.fmu.getFloat64
    fails(unit, lambda: get([9999]), "unknown value reference 9999")


def test_nan_input(unit):
    unit.initialize({"particles.count": 100})
    fails(unit, lambda: unit.set("gravity.G", float("nan")), "gravity.G", "nan", "not allowed")
    assert unit.get("gravity.G") == 1.0


def test_out_of_range_parameter_gets_the_scene_schema_message(unit):
    fails(unit, lambda: unit.set("contact.restitution", 1.5), "the FMU's parameters", "contact.restitution", "1.5", "(0, 1]")
    fails(unit, lambda: unit.set("particles.count", 0), "particles.count", "0")
    # NaN and inf get the same message, with the schema's exact range (once "[0, inf]" for "(0, inf)")
    fails(unit, lambda: unit.set("contact.duration", float("nan")), "contact.duration", "nan", "(0, inf)")
    fails(unit, lambda: unit.set("contact.restitution", float("inf")), "contact.restitution", "inf", "(0, 1]")
    unit.initialize({"particles.count": 100})   # the rejected values were not kept
    assert unit.get("contact.restitution") == 0.5


def test_an_enumeration_takes_its_items_values_only(unit):
    """A text scene key with choices (gravity.solver: direct, tree) is an enumeration: a value without an item is refused
    naming the items, one that needs other keys gets the scene's message, and the item set is the scene's."""
    assert unit.get("gravity.solver") == 1
    fails(unit, lambda: unit.set("gravity.solver", 3), "gravity.solver = 3 is out of range: allowed 1 (direct), 2 (tree)")
    fails(unit, lambda: unit.set("gravity.solver", 0), "gravity.solver = 0 is out of range")
    unit.set("particles.layout", 3)   # list: its positions are no parameter
    fails(unit, lambda: unit.initialize({}), "particles.positions: required here but missing", "Layout `list`")
    unit.reset()
    unit.initialize({"particles.count": 100, "gravity.solver": 2})
    assert unit.get("gravity.solver") == 2 and unit.get("particles.layout") == 2
    fails(unit, lambda: unit.set("gravity.solver", 1), "'gravity.solver' is a fixed parameter")


def test_a_value_beyond_64_bit_integers_is_named_as_the_host_passed_it():
    """fmpy passes a negative start value of the FMI 3 UInt64 `particles.count` as 2^64 - 3: the message
    names that value and the range (it once said -9223372036854775808, a double cast past int64)."""
    unit = Unit(fmu_path("aggregation", 3))
    try:
        fails(unit, lambda: unit.set("particles.count", 2**64 - 3), "particles.count", str(2**64 - 3), "[1, 1000000000]")
        for m in unit.errors():
            assert "-9223372036854775808" not in m
        seed = fails(unit, lambda: unit.set("particles.seed", 2**63 - 1), "particles.seed", "out of range")
        assert not any("-9223372036854775808" in m for m in seed), seed
        unit.initialize({"particles.count": 100})   # the rejected values were not kept
        assert unit.get("particles.count") == 100
    finally:
        unit.free()


def test_a_tunable_scene_key_before_initialization_gets_the_scene_schema_range(unit):
    """gravity.G may be set to 0 while stepping (gravity off), but the scene needs G > 0: before
    initialization a negative G is refused with the scene's range, not the tunable's [0, inf]."""
    new = fails(unit, lambda: unit.set("gravity.G", -1.0), "gravity.G", "-1", "(0, inf)")
    assert not any("[0, inf]" in m for m in new), new
    fails(unit, lambda: unit.set("gravity.G", 0.0), "gravity.G", "(0, inf)")
    fails(unit, lambda: unit.set("drag.rate", -1.0), "drag.rate", "-1", "[0, inf]")
    unit.initialize({"particles.count": 100})
    fails(unit, lambda: unit.set("gravity.G", -1.0), "gravity.G", "-1", "[0, inf]")   # while stepping 0 is allowed
    unit.set("gravity.G", 0.0)


def test_a_read_with_room_for_fewer_values_than_asked_is_an_error():
    """FMI 3: nValues must be the values the references hold; too few was answered fmi3OK with the first
    values only (too many was already an error)."""
    unit = Unit(fmu_path("aggregation", 3))
    try:
        unit.initialize({"particles.count": 100})
        refs = [unit.variables[n].valueReference for n in ("kinetic_energy", "virial_ratio", "contact.restitution")]
        for n in (1, 2, 4):
            fails(unit, lambda: unit.fmu.getFloat64(refs, nValues=n), f"the call passes {n} values for variables holding 3")
        assert list(unit.fmu.getFloat64(refs, nValues=3))[2] == 0.5
    finally:
        unit.free()


def test_wrong_type(unit):
    set_int = unit.fmu.setInteger if unit.version == 2 else unit.fmu.setInt64
    fails(unit, lambda: set_int([unit.variables["contact.restitution"].valueReference], [1]), "contact.restitution", "type")


def test_simulation_going_non_finite_is_an_error_then_reset_recovers(unit):
    unit.initialize({"particles.count": 100, "particles.mass": 100.0})
    dt = unit.get("time.dt")
    unit.step(dt)
    unit.set("gravity.G", 1e308)   # allowed, but the next forces overflow
    fails(unit, lambda: unit.step(dt), "non-finite", "particle", "step 2")
    fails(unit, lambda: unit.step(dt), "DoStep", "error state")
    unit.reset()
    unit.initialize({"particles.count": 100})
    unit.step(3 * dt)
    assert unit.get("step") == 3


def test_a_step_whose_kinetic_energy_overflows_is_an_error_though_every_grain_stays_finite(unit):
    """Heavy, wide grains falling through each other's softened cores at far too long a step gain energy until
    1/2 m v^2 overflows while v does not: the step is an error, not OK with the outputs reading inf."""
    unit.initialize({"particles.count": 50, "particles.mass": 1e150, "particles.diameter": 1e10})
    unit.set("gravity.G", 5e17)
    dt = unit.get("time.dt")
    fails(unit, lambda: [unit.step(100 * dt) for _ in range(50)], "DoStep", "the kinetic energy overflows a double")
    fails(unit, lambda: unit.step(dt), "DoStep", "error state")


def test_wrong_instantiation_token_is_refused(tmp_path):
    from fmpy.fmi2 import FMU2Slave
    path = fmu_path("collision", 2)
    unit = Unit(path)
    unit.free()
    fmu = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=extracted(path),
                    modelIdentifier=unit.md.coSimulation.modelIdentifier, instanceName="bad")
    with pytest.raises(Exception):
        fmu.instantiate()


@pytest.mark.parametrize("version", [2, 3])
def test_an_empty_instantiation_token_is_refused(version):
    """The host must pass the model description's token; an empty one was taken as no check at all."""
    script = """
import sys
from fmu_host import Unit, fmu_path
import fmu_host
unit = Unit.__new__(Unit)
real = fmu_host.read_model_description
def without_token(path):
    md = real(path)
    md.guid = ""
    return md
fmu_host.read_model_description = without_token
try:
    unit.__init__(fmu_path("collision", int(sys.argv[1])))
except Exception:
    pass
else:
    print("instantiated")
print([m for _, _, m in unit.messages])
"""
    r = host_process(script, version)
    assert r.returncode == 0 and "instantiated" not in r.stdout, r.stdout + r.stderr
    call = "fmi2Instantiate" if version == 2 else "fmi3InstantiateCoSimulation"
    assert f"{call}: no instantiation token given" in r.stdout, r.stdout


@pytest.mark.parametrize("version", [2, 3])
def test_an_unknown_vector_code_choice_in_the_host_environment_is_an_error_not_a_crash(version):
    """GRAINS_GRAVITY_ISA with a name the engine does not know: the instance, whose simulation is built at
    instantiation, is refused (no instance) with a logged message naming the variable, the value and what is
    allowed; the host goes on."""
    script = """
import sys
from fmu_host import Unit, fmu_path
unit = Unit.__new__(Unit)
try:
    unit.__init__(fmu_path("aggregation", int(sys.argv[1])))
except Exception:
    print("refused")
print([m for _, _, m in unit.messages])
print("host alive")
"""
    r = host_process(script, version, env={"GRAINS_GRAVITY_ISA": "avx1024"})
    assert r.returncode == 0 and "refused" in r.stdout and "host alive" in r.stdout, r.stdout + r.stderr
    call = "fmi2Instantiate" if version == 2 else "fmi3InstantiateCoSimulation"
    assert f'{call}: instantiation failed: GRAINS_GRAVITY_ISA = "avx1024" is not a set of gravity kernels: ' \
           "allowed portable, avx2, avx512" in r.stdout, r.stdout


@pytest.mark.parametrize("version", [2, 3])
def test_resources_found_through_a_percent_encoded_location(tmp_path, version):
    """fmpy passes file URIs (FMI 2, spaces become %20) and paths (FMI 3): both must reach resources/."""
    path = fmu_path("collision", version)
    odd = tmp_path / "dir with space%25"
    shutil.copytree(extracted(path), odd)
    from fmu_host import _extracted
    _extracted[str(odd) + ".fmu"] = str(odd)
    shutil.copy(path, str(odd) + ".fmu")
    unit = Unit(str(odd) + ".fmu")
    unit.initialize()
    unit.step(0.5)
    assert unit.get("step") == 250   # dt = t_c / 50 = 0.002: the packaged scene was read from resources/
    unit.free()


# Instantiate, free, free again, then call on the freed pointer and on one never handed out, through the
# raw C functions (fmpy's freeInstance also unloads the library). In a subprocess: a crash fails the test.
FREED_INSTANCE_HOST = """
import ctypes, sys
from fmu_host import Unit, fmu_path
version = int(sys.argv[1])
fmu = Unit(fmu_path("collision", version)).fmu
c = ctypes.c_void_p(fmu.component)
free = fmu.dll[f"fmi{version}FreeInstance"]
free.argtypes, free.restype = [ctypes.c_void_p], None
step = fmu.dll[f"fmi{version}DoStep"]
flag = ctypes.c_int if version == 2 else ctypes.c_bool   # noSetFMUStatePriorToCurrentPoint
step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, flag] + [ctypes.c_void_p] * 4 * (version == 3)
step.restype = ctypes.c_int
extra = [None] * 4 * (version == 3)
reset = fmu.dll[f"fmi{version}Reset"]
reset.argtypes, reset.restype = [ctypes.c_void_p], ctypes.c_int
free(c)
free(c)   # a second free does nothing
print(step(c, 0.0, 0.1, 0, *extra), step(ctypes.c_void_p(7), 0.0, 0.1, 0, *extra))
# A new instance, which may take the freed one's memory: the freed handle still refers to nothing.
fmu.instantiate()
new = ctypes.c_void_p(fmu.component)
print(new.value != c.value, reset(c), reset(new))
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_freed_instance_is_refused_not_dereferenced(version):
    r = host_process(FREED_INSTANCE_HOST, version)
    assert r.returncode == 0, r.stderr
    # fmi2Error / fmi3Error for the freed handle and for a stranger; then a new handle, which works, while the
    # freed one is still refused
    assert r.stdout.split() == ["3", "3", "True", "3", "0"], r.stdout


def test_a_step_beyond_the_step_counter_is_refused_and_the_instance_goes_on(unit):
    unit.initialize({"particles.count": 100})
    fails(unit, lambda: unit.fmu.doStep(0.0, 1e300), "communication step size 1e+300", "at most 1e15 steps")
    unit.step(unit.get("time.dt"))   # refused before stepping: not an error state
    assert unit.get("step") == 1


def test_fmi2_refuses_the_fmi3_arrays_whatever_their_size():
    """FMI 2's modelDescription declares no arrays; with one particle an array has one element, and must
    still be an unknown reference there."""
    unit = Unit(fmu_path("aggregation", 2))
    unit.initialize({"particles.count": 1, "run.threads": 1})
    last = max(v.valueReference for v in unit.md.modelVariables)
    fails(unit, lambda: unit.fmu.getReal([last + 2]), f"unknown value reference {last + 2}", f"0 to {last}",
          "particles.radius is an FMI 3 array")
    fails(unit, lambda: unit.fmu.setReal([last + 1], [1.0]), f"unknown value reference {last + 1}")
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_the_moduli_switch_is_not_a_parameter(version):
    """analysis.elastic_moduli is no parameter: its only other value (false) would remove the moduli outputs, which
    the FMU refuses; like the modules' switches it is the packaged scene's."""
    unit = Unit(fmu_path("consolidation", version))
    try:
        names = {v.name for v in unit.md.modelVariables}
        assert "analysis.elastic_moduli" not in names and {"B", "G", "C11"} <= names
        assert "particles.count" in names
    finally:
        unit.free()


def test_a_contact_duration_without_a_finite_stiffness_is_refused(unit):
    """contact.duration = 1e200 once gave k_n = 0 (contacts that do not push) and 1e-300 k_n = inf, silently."""
    for duration, stiffness in ((1e200, "k_n = 0"), (1e-300, "k_n = inf")):
        unit.set("contact.duration", duration)
        fails(unit, lambda: unit.fmu.enterInitializationMode(), "contact.duration", stiffness, "finite, nonzero stiffness")
        unit.fmu.reset()


@pytest.mark.parametrize("version", [2, 3])
def test_an_attraction_no_clamped_contact_balances_is_refused(version):
    """The consolidation unit's clamp carries at most K_N f_max R_min = 1e5 * 0.5 * 0.2502 = 12508: an adhesion.force
    above it once ran, the bonded grains sinking into each other with a thousandfold kinetic energy."""
    unit = Unit(fmu_path("consolidation", version))
    try:
        unit.set("adhesion.force", 2e4)
        fails(unit, lambda: unit.fmu.enterInitializationMode(), "adhesion.force: value 20000",
              "not below K_N f_max R_min = 12507.6", "allowed [0, 12507.6)")
        unit.fmu.reset()
        unit.set("adhesion.force", 1e4)   # rest overlap 0.1, inside the clamp's 0.125
        unit.fmu.enterInitializationMode()
        unit.fmu.exitInitializationMode()
    finally:
        unit.free()


NULL_CATEGORY_HOST = """
import ctypes, sys
from fmu_host import Unit, fmu_path
version = int(sys.argv[1])
unit = Unit(fmu_path("collision", version))
f = unit.fmu.dll[f"fmi{version}SetDebugLogging"]
f.argtypes = [ctypes.c_void_p, ctypes.c_int if version == 2 else ctypes.c_bool, ctypes.c_size_t, ctypes.POINTER(ctypes.c_char_p)]
f.restype = ctypes.c_int
print(f(unit.fmu.component, 1, 2, (ctypes.c_char_p * 2)(b"logCalls", None)))
print(unit.errors()[-1])
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_null_log_category_is_an_error_not_a_crash(version):
    r = host_process(NULL_CATEGORY_HOST, version)
    assert r.returncode == 0, r.stderr
    status, message = r.stdout.splitlines()[:2]
    assert status == "3" and "null pointer" in message, r.stdout


# A state freed through one copy of its pointer and used through another (as a C host holding it in two places
# would), and a state used by another instance, through the raw C functions. In a subprocess: a crash (the
# freed state was dereferenced) fails the test.
STALE_STATE_HOST = """
import ctypes, sys
from ctypes import byref, c_size_t, c_void_p, POINTER
from fmu_host import Unit, fmu_path
version = int(sys.argv[1])
P, S = ("fmi2", "FMUstate") if version == 2 else ("fmi3", "FMUState")
a = Unit(fmu_path("collision", version), name="a").initialize()
def raw(name, argtypes):
    f = a.fmu.dll[name]
    f.argtypes, f.restype = argtypes, ctypes.c_int
    return f
get, set_ = raw(f"{P}Get{S}", [c_void_p, POINTER(c_void_p)]), raw(f"{P}Set{S}", [c_void_p, c_void_p])
free, size = raw(f"{P}Free{S}", [c_void_p, POINTER(c_void_p)]), raw(f"{P}Serialized{S}Size", [c_void_p, c_void_p, POINTER(c_size_t)])
ca = c_void_p(a.fmu.component)
state = c_void_p()
get(ca, byref(state))
copy = c_void_p(state.value)
free(ca, byref(state))
n = c_size_t()
print(state.value, set_(ca, copy), free(ca, byref(c_void_p(copy.value))), size(ca, copy, byref(n)), set_(ca, c_void_p(8)))
print(a.errors()[0])
# (fmpy's FMI 2 logger proxy sends every instance's messages to the newest Unit's list: b's, from here on)
b = Unit(fmu_path("collision", version), name="b").initialize()
fresh = c_void_p()
get(ca, byref(fresh))
print(fresh.value != copy.value, set_(c_void_p(b.fmu.component), fresh), set_(ca, fresh), free(ca, byref(fresh)), fresh.value)
print((a.errors() + b.errors())[-1])
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_freed_or_foreign_fmu_state_is_refused_not_dereferenced(version):
    r = host_process(STALE_STATE_HOST, version)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.splitlines()
    # freeing sets the pointer to null; set, free and size through the freed copy, and a pointer never handed
    # out, are fmi2Error / fmi3Error
    assert lines[0].split() == ["None", "3", "3", "3", "3"], r.stdout
    assert f"fmi{version}Set" in lines[1] and "is not a live state: it was freed already, or never handed out" in lines[1], lines[1]
    # a new state is not the freed one; another instance refuses it, its own instance sets and frees it
    assert lines[2].split() == ["True", "3", "0", "0", "None"], r.stdout
    assert "belongs to instance 'a', not to 'b'" in lines[3], lines[3]


def test_int64_values_are_exact_or_refused_as_passed():
    """Int64 values travel as doubles: 2^53 + 1 was rounded to 2^53 with fmi3OK, and 2^63 - 1 was refused as
    9223372036854775808. The FMU declares and checks the range doubles hold exactly, quoting the value passed."""
    unit = Unit(fmu_path("aggregation", 3))
    try:
        seed = unit.variables["particles.seed"]
        assert (seed.min, seed.max) == ("0", "9007199254740992")   # as modelDescription.xml declares it
        ref = seed.valueReference
        for x in (2**53, 2**53 - 1, 1234567890123):
            unit.fmu.setInt64([ref], [x])
            assert list(unit.fmu.getInt64([ref])) == [x]
        for x in (2**53 + 1, 2**63 - 1, -2**63):
            fails(unit, lambda: unit.fmu.setInt64([ref], [x]), f"particles.seed = {x} is out of range",
                  "[0, 9007199254740992]")
        assert list(unit.fmu.getInt64([ref])) == [1234567890123]   # the refused values were not kept
        unit.initialize({"particles.count": 100})
    finally:
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_non_finite_start_time_is_refused_where_the_host_gives_it(version):
    """fmi2SetupExperiment(startTime = NaN) returned fmi2OK, and only the next call failed."""
    unit = Unit(fmu_path("collision", version))
    try:
        for bad in (float("nan"), float("inf")):
            if version == 2:
                fails(unit, lambda: unit.fmu.setupExperiment(startTime=bad), "fmi2SetupExperiment", f"start time {bad}",
                      "a finite number")
            else:
                fails(unit, lambda: unit.fmu.enterInitializationMode(startTime=bad), f"start time {bad}", "a finite number")
        unit.initialize(start_time=1.0)
        unit.step(0.5)
        assert unit.get("time") == 1.5
    finally:
        unit.free()


# Twenty million particles (5 GB by the engine's estimate, which the machine passes) in a process whose address
# space is capped at 2 GB: an allocation fails at once (nothing is touched), as on a machine without the memory.
OUT_OF_MEMORY_HOST = """
import resource, sys
from fmu_host import Unit, fmu_path
version = int(sys.argv[1])
unit = Unit(fmu_path("aggregation", version))
unit.set("run.threads", 1)
unit.set("particles.count", 2 * 10**7)
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
try:
    unit.fmu.enterInitializationMode() if version == 2 else unit.fmu.enterInitializationMode(startTime=0.0)
    print("initialized")
except Exception:
    print(unit.errors()[-1])
"""


@pytest.mark.parametrize("version", [2, 3])
def test_out_of_memory_is_named_as_the_runner_names_it(version):
    r = host_process(OUT_OF_MEMORY_HOST, version)
    assert r.returncode == 0, r.stderr[-2000:]
    message = r.stdout.strip()
    # named after the host's call, as every error the FMU logs
    assert message.startswith(f"fmi{version}EnterInitializationMode: out of memory: the scene needs more memory than "
                              "this machine gives") and \
        "particles.count" in message and "bad_alloc" not in message, message


def test_configuration_mode_sets_only_the_structural_parameter():
    unit = Unit(fmu_path("aggregation", 3))
    unit.fmu.enterConfigurationMode()
    fails(unit, lambda: unit.set("contact.restitution", 0.7), "contact.restitution", "not a structural parameter",
          "particles.count", "ExitConfigurationMode")
    unit.set("particles.count", 120)   # the structural one is accepted
    unit.fmu.exitConfigurationMode()
    unit.set("contact.restitution", 0.7)   # and the other after it
    unit.initialize({"run.threads": 1})
    assert unit.get("contact.restitution") == 0.7
    unit.free()


def test_setting_an_output_array_names_it_not_the_value_count():
    unit = Unit(fmu_path("aggregation", 3))
    var = unit.variables["particles.position"]
    fails(unit, lambda: unit.fmu.setFloat64([var.valueReference], [0.0] * 3000), "particles.position",
          "output array", "cannot be set")
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_an_open_lower_bound_is_declared_as_the_nearest_value_inside_it(version):
    """FMI's min is inclusive: contact.duration in (0, inf) must not declare min = 0, which the FMU refuses."""
    unit = Unit(fmu_path("aggregation", version))
    duration = unit.variables["contact.duration"]
    assert float(duration.min) > 0 and float(duration.min) < 1e-300
    assert "(0, inf)" in duration.description
    fails(unit, lambda: unit.set("contact.duration", 0.0), "contact.duration")
    unit.free()


@pytest.mark.parametrize("model", ["aggregation", "collision", "consolidation"])
def test_no_parameter_value_changes_the_set_of_variables(model):
    """The FMU's variables are fixed by its modelDescription: a parameter whose value would add or remove outputs (as
    analysis.elastic_moduli = false did) is the packaged scene's, not a parameter. Every fixed parameter, set to 0 and
    to another value, builds a simulation with the same variables or is refused for its value, never for changing
    them (the refusal stays as a guard, though no parameter reaches it)."""
    probe = Unit(fmu_path(model, 2))
    parameters = [v for v in probe.md.modelVariables if v.causality == "parameter" and v.variability == "fixed"]
    probe.free()
    counted = any(v.name == "particles.count" for v in parameters)   # a drawn count, kept small here
    fixed = [(v.name, v.start, v.type) for v in parameters
             if v.name != "particles.count" and v.type in ("Real", "Integer", "Boolean", "Enumeration")]
    items = {v.name: [int(i.value) for i in v.declaredType.items] for v in parameters if v.type == "Enumeration"}
    assert model != "aggregation" or "gravity.solver" in items, items
    tried = 0
    for name, start, kind in fixed:
        s = float(start) if kind != "Boolean" else float(start in ("true", "1", True))
        values = {"Real": [0.0, 2 * s if s else 1.0], "Integer": [0, int(s) + 1], "Boolean": [not s],
                  "Enumeration": items.get(name)}[kind]
        for value in values:
            unit = Unit(fmu_path(model, 2))
            try:
                if counted:
                    unit.set("particles.count", 60)
                unit.set(name, value)
                unit.initialize({})
                tried += 1
            except FMICallException:
                pass
            finally:
                assert not [m for m in unit.errors() if "set of variables" in m], (name, value, unit.errors())
                unit.free()
    assert tried > len(fixed) // 2   # most values build: the check saw simulations, not refusals alone
