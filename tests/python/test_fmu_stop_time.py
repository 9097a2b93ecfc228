"""The host's stop time (stopTimeDefined, stopTime: FMI 2's fmi2SetupExperiment, FMI 3's fmi3EnterInitializationMode).
Both standards say that a host computing past it gets an error; the FMU ignored it and stepped on. Now a stop time
that is not finite or lies before the start time is refused where the host gives it; a step that would end past it
is refused before it is taken (the instance stays where it was, and can still step up to the stop time); a step that
ends on it as a host adding its steps up rounds it is allowed. Without a stop time, or after a reset, stepping goes on.
The stop time belongs to the host's experiment, not to the FMU state: a restored state keeps the instance's."""
import fmpy
import pytest

from fmu_host import Unit, fmu_path
from test_fmu_errors import fails

OUTPUTS = ["time", "step", "kinetic_energy", "momentum_x", "contacts"]


def path(version):
    return fmu_path("collision", version)


def scene_dt(version):
    unit = Unit(path(version)).initialize()
    try:
        return unit.get("time.dt")
    finally:
        unit.free()


def outputs(unit):
    return {name: unit.get(name) for name in OUTPUTS}


@pytest.mark.parametrize("version", [2, 3])
def test_a_stop_time_not_finite_or_before_the_start_time_is_refused_where_the_host_gives_it(version):
    unit = Unit(path(version))
    function = "fmi2SetupExperiment" if version == 2 else "fmi3EnterInitializationMode"
    set_up = unit.fmu.setupExperiment if version == 2 else unit.fmu.enterInitializationMode
    try:
        for bad in (0.5, 1.0 - 1e-12, float("nan"), float("inf"), float("-inf")):
            fails(unit, lambda: set_up(startTime=1.0, stopTime=bad), function, f"stop time {bad!r}", "start time 1:",
                  "a finite number at or after the start time")
        unit.initialize(start_time=1.0, stop_time=1.0)   # an experiment of no length: allowed, and nothing to step
        unit.step(0.0)
        fails(unit, lambda: unit.fmu.doStep(1.0, 1e-3), "past the stop time 1")
        assert unit.get("time") == 1.0
    finally:
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_step_past_the_stop_time_is_an_error_and_is_not_taken(version):
    dt = scene_dt(version)
    start, stop = 1.0, 1.0 + 100 * dt
    unit = Unit(path(version)).initialize(start_time=start, stop_time=stop)
    try:
        for _ in range(60):
            unit.step(dt)
        before = outputs(unit)
        t, h = unit.time, 50 * dt
        fails(unit, lambda: unit.fmu.doStep(t, h), f"fmi{version}DoStep", f"communication point {t!r}",
              f"step size {h!r}", f"would end at {t + h!r}", f"past the stop time {stop!r}", "not taken")
        assert outputs(unit) == before   # neither the time nor the simulation moved
        for _ in range(40):   # and the instance steps on, up to the stop time
            unit.step(dt)
        assert unit.get("step") == 100
    finally:
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_hosts_reach_the_stop_time_through_their_clocks_rounding_and_step_no_further(version):
    dt = scene_dt(version)
    # fmpy's last communication point, 3 x 0.1, passes a stop time of 0.3 by its rounding
    run = fmpy.simulate_fmu(str(path(version)), stop_time=0.3, output_interval=0.1, output=["step"])
    assert run["time"][-1] > 0.3 and run["step"][-1] == round(0.3 / dt)
    # as does a host that adds its steps up: 100,000 steps of dt (0.002) pass 200 by 2.3e-10, a hundred times what a
    # whole step's rounding allows (1e-9 dt + 4 eps t), within the tolerance of the time check
    steps = 100_000
    stop = steps * dt
    unit = Unit(path(version)).initialize(stop_time=stop)
    try:
        for _ in range(steps):   # t += dt, as many hosts count
            unit.step(dt)
        assert unit.time > stop, "the host's sum should pass the stop time by its rounding, or this tests nothing"
        assert unit.get("time") == unit.time and unit.get("step") == steps
        # a step of a thousandth of dt is no rounding
        fails(unit, lambda: unit.fmu.doStep(unit.time, 1e-3 * dt), "past the stop time")
        assert unit.get("step") == steps
    finally:
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_far_from_time_zero_neither_the_clock_nor_the_stop_time_lets_a_step_through(version):
    # At 1e13 steps from zero the tolerance's relative part (1e-12 |t|) is 10 dt: a host clock three steps off, and a
    # step ending three steps past the stop time, passed. Double precision still resolves 2e-3 dt there.
    dt = scene_dt(version)
    start = 1e13 * dt
    stop = start + 5 * dt
    unit = Unit(path(version)).initialize(start_time=start, stop_time=stop)
    try:
        unit.step(dt)
        t = unit.time
        fails(unit, lambda: unit.fmu.doStep(t + 3 * dt, dt), "is not the FMU's time")
        fails(unit, lambda: unit.fmu.doStep(t, 7 * dt), "past the stop time")
        assert unit.get("step") == 1
        unit.step(4 * dt)   # up to the stop time, as the host's clock rounds it
        assert unit.get("step") == 5
    finally:
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_without_a_stop_time_stepping_goes_on_and_a_reset_clears_it(version):
    dt = scene_dt(version)
    unit = Unit(path(version)).initialize(stop_time=10 * dt)
    try:
        for _ in range(10):
            unit.step(dt)
        fails(unit, lambda: unit.fmu.doStep(unit.time, dt), "past the stop time")
        unit.fmu.terminate()
        unit.reset()   # back to before the experiment's setup: the next one defines no stop time
        unit.initialize()
        for _ in range(30):
            unit.step(dt)
        assert unit.get("step") == 30
    finally:
        unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_restored_state_keeps_the_stop_time_of_the_instance_it_is_restored_into(version):
    dt = scene_dt(version)
    saver = Unit(path(version), "saver").initialize(stop_time=20 * dt)
    earlier = Unit(path(version), "earlier").initialize(stop_time=12 * dt)
    unbounded = Unit(path(version), "unbounded").initialize()
    try:
        for _ in range(10):
            saver.step(dt)
        state = saver.serialize(saver.get_state())
        for unit in (earlier, unbounded):
            unit.set_state(unit.deserialize(state))
            unit.time = saver.time
        # 15 dt: the saver's stop time (20 dt) would allow it, this instance's (12 dt) does not
        fails(earlier, lambda: earlier.fmu.doStep(earlier.time, 5 * dt), "past the stop time")
        earlier.step(2 * dt)
        assert earlier.get("step") == 12
        for _ in range(15):   # past the saver's stop time: this instance has none
            unbounded.step(dt)
        assert unbounded.get("step") == 25
    finally:
        for unit in (saver, earlier, unbounded):
            unit.free()
