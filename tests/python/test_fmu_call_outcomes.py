"""What a call tells the host besides its values: Warning when it raised a warning, nothing kept of a refused set
call, the snapshot file closed by Terminate, and (FMI 3) the structural particle count fixed once Initialization Mode
begins. Each guards against a failure: a warning logged only with logging on and the call returning OK, a set call
refused at its second value keeping the first, the snapshot file locked until FreeInstance, and FMI 3 taking a new
particle count in Initialization Mode."""
import ctypes
import math

import h5py
import pytest
from fmu_host import FMICallException, Unit, fmu_path

OK, WARNING = 0, 1   # fmi2Status / fmi3Status


def enter_initialization_raw(unit):
    """The host's Enter Initialization Mode, returning its status (fmpy drops a Warning)."""
    c = unit.fmu.component
    if unit.version == 2:
        unit.fmu.setupExperiment(startTime=0.0)
        return unit.fmu.dll.fmi2EnterInitializationMode(c)
    return unit.fmu.dll.fmi3EnterInitializationMode(c, False, 0.0, 0.0, False, 0.0)


def do_step_raw(unit, h):
    c = unit.fmu.component
    if unit.version == 2:
        status = unit.fmu.dll.fmi2DoStep(c, unit.time, h, 1)
    else:
        flags, last = [ctypes.c_bool() for _ in range(3)], ctypes.c_double()
        status = unit.fmu.dll.fmi3DoStep(c, unit.time, h, True, *(ctypes.byref(f) for f in flags), ctypes.byref(last))
    unit.time += h
    return status


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("logging", [False, True])
def test_a_call_that_raises_a_warning_returns_warning_and_logs_it(version, logging):
    # 1.5 steps per contact: the time step rule's warnings, raised as the simulation is built for initialization
    unit = Unit(fmu_path("collision", version), logging=logging)
    unit.set("time.steps_per_contact", 1.5)
    assert [m for m in unit.messages if m[0] != OK] == []   # logCalls messages aside
    assert enter_initialization_raw(unit) == WARNING
    warnings = [m for s, c, m in unit.messages if s == WARNING]
    assert warnings and all(c == "logStatusWarning" for s, c, m in unit.messages if s == WARNING)
    assert any("steps_per_contact" in m or "time step" in m for m in warnings), warnings
    # the next calls raise nothing new: OK, the warning is not carried on
    exit_call = unit.fmu.dll.fmi2ExitInitializationMode if version == 2 else unit.fmu.dll.fmi3ExitInitializationMode
    assert exit_call(unit.fmu.component) == OK
    assert do_step_raw(unit, unit.get("time.dt")) == OK
    assert len([m for s, c, m in unit.messages if s == WARNING]) == len(warnings)
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_warnings_switched_off_by_name_still_give_the_status(version):
    unit = Unit(fmu_path("collision", version), logging=True)
    unit.fmu.setDebugLogging(False, ["logStatusWarning"])
    unit.set("time.steps_per_contact", 1.5)
    assert enter_initialization_raw(unit) == WARNING
    assert [m for s, c, m in unit.messages if s == WARNING] == []
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_refused_set_call_keeps_none_of_its_values(version):
    unit = Unit(fmu_path("collision", version))
    set_real = unit.fmu.setReal if version == 2 else unit.fmu.setFloat64
    ref = {name: unit.variables[name].valueReference for name in ("contact.restitution", "contact.duration", "drag.rate")}
    before = {name: unit.get(name) for name in ref}
    # before initialization: a scene parameter accepted, then one refused (NaN), or an unknown reference
    for refs, values in ([ref["contact.restitution"], ref["contact.duration"]], [0.7, math.nan]), \
                        ([ref["contact.restitution"], 99999], [0.7, 1.0]):
        with pytest.raises(FMICallException):
            set_real(refs, values)
        assert {name: unit.get(name) for name in ref} == before
    assert 0.7 != before["contact.restitution"] and 2.0 * before["drag.rate"] + 1.0 != before["drag.rate"]
    # after initialization: a tunable parameter accepted, then a fixed one refused
    unit.initialize()
    with pytest.raises(FMICallException):
        set_real([ref["drag.rate"], ref["contact.restitution"]], [2.0 * before["drag.rate"] + 1.0, 0.7])
    assert unit.get("drag.rate") == before["drag.rate"]
    # the same values accepted one call at a time: the refusals above were the calls' own
    set_real([ref["drag.rate"]], [2.0 * before["drag.rate"] + 1.0])
    assert unit.get("drag.rate") == 2.0 * before["drag.rate"] + 1.0
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_terminate_closes_the_snapshot_file(version, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)   # the snapshots go to <instance name>.h5 in the working directory
    first = Unit(fmu_path("collision", version), name="closed")
    first.set("fmu.snapshots_every", 5)
    first.initialize()
    dt = first.get("time.dt")
    for _ in range(4):
        first.step(5 * dt)
    first.fmu.terminate()
    # readable before FreeInstance (HDF5's lock released), with every frame
    with h5py.File(tmp_path / "closed.h5", "r") as f:
        assert list(f["particles/all/position/step"][:]) == [0, 5, 10, 15, 20]
    # and a new instance of the same name may write it
    second = Unit(fmu_path("collision", version), name="closed")
    second.set("fmu.snapshots_every", 5)
    second.initialize()
    second.step(5 * dt)
    second.fmu.terminate()
    with h5py.File(tmp_path / "closed.h5", "r") as f:
        assert list(f["particles/all/position/step"][:]) == [0, 5]
    first.free()
    second.free()


def test_fmi3_the_particle_count_is_fixed_once_initialization_mode_begins():
    unit = Unit(fmu_path("aggregation", 3))
    count = unit.variables["particles.count"].valueReference
    unit.fmu.enterConfigurationMode()
    unit.fmu.setUInt64([count], [5])
    unit.fmu.exitConfigurationMode()
    unit.fmu.setUInt64([count], [6])   # Instantiated: still allowed (fmpy's start values come here)
    unit.fmu.enterInitializationMode(startTime=0.0)
    with pytest.raises(FMICallException):
        unit.fmu.setUInt64([count], [7])
    assert any("particles.count" in m and "structural" in m and "initialization mode" in m for m in unit.errors())
    unit.fmu.exitInitializationMode()
    assert unit.get("particles.count") == 6
    assert len(unit.get("particles.radius")) == 6
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_refused_state_names_the_parameters_that_differ(version):
    path = fmu_path("aggregation", version)
    saver = Unit(path, "saver").initialize({"particles.count": 20, "contact.restitution": 0.5})
    saved = saver.serialize(saver.get_state())
    other = Unit(path, "other").initialize({"particles.count": 21, "contact.restitution": 0.5, "gravity.solver": 2})
    with pytest.raises(FMICallException):
        other.set_state(other.deserialize(saved))
    message = other.errors()[-1]
    assert "particles.count = 20 in the state, 21 here" in message, message
    assert "gravity.solver = 1 (direct) in the state, 2 (tree) here" in message, message   # an enumeration's items
    assert "restitution" not in message, message   # only those that differ
    # a state of another model: said so, no parameters compared
    collision = Unit(fmu_path("collision", version), "collision").initialize()
    foreign = collision.serialize(collision.get_state())
    with pytest.raises(FMICallException):
        other.set_state(other.deserialize(foreign))
    assert "saved by another FMU" in other.errors()[-1], other.errors()[-1]
    for unit in (saver, other, collision):
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_state_restores_where_the_pressure_input_started_elsewhere_and_runs_on_as_saved(version):
    """The barostat's tolerance on the cell's rates has a time unit from the start value of cell.pressure (above
    P* = 1 it depends on P*), which the state must hold: without it a state saved at P* = 0.01 is refused where the
    input started at 3 ("history does not lead to the saved cell lengths"), and one saved at 3 right after
    initialization is taken where it started at 0.01 and then runs otherwise (cell_length_x 10.8712046 against
    10.8712040 after 10,000 dt)."""
    path = fmu_path("consolidation", version)

    def outputs(unit):   # NaN as a string, so that equal NaNs compare equal
        return {k: "nan" if v != v else v for k, v in unit.outputs().items() if k != "cvode_seconds"}

    for saved_at, restored_at, steps_first in ((0.01, 3.0, 10), (3.0, 0.01, 0)):
        saver = Unit(path, "saver").initialize({"particles.count": 100, "cell.pressure": saved_at})
        dt = saver.get("time.dt")
        if steps_first:
            saver.step(steps_first * dt)
        state = saver.serialize(saver.get_state())
        other = Unit(path, "other").initialize({"particles.count": 100, "cell.pressure": restored_at})
        other.set_state(other.deserialize(state))
        other.time = saver.time
        for _ in range(20):
            saver.step(500 * dt)
            other.step(500 * dt)
        assert outputs(other) == outputs(saver), (saved_at, restored_at)
        saver.free()
        other.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_value_the_engine_refuses_takes_back_those_set_before_it_in_the_call(version):
    """A value within its declared range that the engine refuses (P* = 0 in a cohesionless cell) must not leave the
    values before it in the call applied."""
    unit = Unit(fmu_path("consolidation", version))
    unit.initialize({"particles.count": 30, "adhesion.force": 0.0, "cell.pressure": 0.5})
    set_real = unit.fmu.setReal if version == 2 else unit.fmu.setFloat64
    rate, pressure = (unit.variables[n].valueReference for n in ("drag.rate", "cell.pressure"))
    before = unit.get("drag.rate")
    with pytest.raises(FMICallException):
        set_real([rate, pressure], [before + 7.0, 0.0])
    assert "cohesionless" in unit.errors()[-1], unit.errors()[-1]
    assert (unit.get("drag.rate"), unit.get("cell.pressure")) == (before, 0.5)
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_set_call_that_raises_a_warning_returns_it_itself(version):
    """A pressure past what the contacts' clamp holds is warned of as it is set: that call returns Warning, not OK
    with the next, unrelated one returning Warning."""
    unit = Unit(fmu_path("consolidation", version)).initialize({"particles.count": 30})
    c, pressure = unit.fmu.component, unit.variables["cell.pressure"].valueReference
    if version == 2:
        status = unit.fmu.dll.fmi2SetReal(c, (ctypes.c_uint * 1)(pressure), 1, (ctypes.c_double * 1)(1e5))
    else:
        status = unit.fmu.dll.fmi3SetFloat64(c, (ctypes.c_uint * 1)(pressure), 1, (ctypes.c_double * 1)(1e5), 1)
    assert status == WARNING
    assert any("cell.pressure = 100000" in m for s, _, m in unit.messages if s == WARNING)
    rate = unit.variables["drag.rate"].valueReference
    if version == 2:
        assert unit.fmu.dll.fmi2GetReal(c, (ctypes.c_uint * 1)(rate), 1, (ctypes.c_double * 1)()) == OK
    else:
        assert unit.fmu.dll.fmi3GetFloat64(c, (ctypes.c_uint * 1)(rate), 1, (ctypes.c_double * 1)(), 1) == OK
    unit.free()
