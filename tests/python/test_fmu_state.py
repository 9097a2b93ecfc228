"""FMU state, reset, several instances, threads and a parameter sweep, on the real .fmu files
through fmpy's FMI 2 and FMI 3 classes."""
import os
import struct

import numpy as np
import pytest

from fmu_host import Unit, fmu_path
from head_on import clamped_restitution

SMALL = {"particles.count": 200, "run.threads": 1}   # a quick aggregation


def run(unit, steps, h):
    trace = []
    for _ in range(steps):
        unit.step(h)
        trace.append(unit.outputs())
    return trace


def same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        for k in x:
            assert x[k] == y[k] or (np.isnan(x[k]) and np.isnan(y[k])), k


@pytest.mark.parametrize("version", [2, 3])
def test_restored_and_deserialized_states_continue_exactly(version):
    unit = Unit(fmu_path("aggregation", version)).initialize(SMALL)
    h = 7 * unit.get("time.dt") + 0.3 * unit.get("time.dt")   # not a whole number of dt: a remainder step each time
    run(unit, 3, h)
    state = unit.get_state()
    t0 = unit.time
    original = run(unit, 4, h)
    serialized = unit.serialize(state)

    unit.set_state(state)
    unit.time = t0
    same(run(unit, 4, h), original)

    restored = unit.deserialize(serialized)
    assert unit.serialize(restored) == serialized   # byte-exact round trip
    unit.set_state(restored)
    unit.time = t0
    same(run(unit, 4, h), original)
    assert unit.errors() == []
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_reset_returns_to_the_instantiated_state(version):
    unit = Unit(fmu_path("aggregation", version))
    unit.initialize(SMALL)
    h = 10 * unit.get("time.dt")
    first = run(unit, 5, h)
    unit.reset()
    assert unit.get("particles.count") == 1000   # parameters back to the packaged scene
    unit.initialize(SMALL)
    assert unit.get("step") == 0
    same(run(unit, 5, h), first)
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_two_interleaved_instances_equal_each_alone(version):
    path = fmu_path("aggregation", version)
    a = Unit(path, "a").initialize(SMALL)
    h = 10 * a.get("time.dt")
    alone_a = run(a, 6, h)
    a.free()
    other = dict(SMALL, **{"contact.restitution": 0.2, "particles.seed": 7})
    b = Unit(path, "b").initialize(other)
    alone_b = run(b, 6, h)
    b.free()

    a, b = Unit(path, "a").initialize(SMALL), Unit(path, "b").initialize(other)
    together_a, together_b = [], []
    for _ in range(6):
        together_a += run(a, 1, h)
        together_b += run(b, 1, h)
    same(together_a, alone_a)
    same(together_b, alone_b)
    assert alone_a[-1]["kinetic_energy"] != alone_b[-1]["kinetic_energy"]   # really two different runs
    a.free()
    b.free()


def threads():
    return len(os.listdir("/proc/self/task"))


@pytest.mark.parametrize("version", [2, 3])
def test_free_instance_shuts_the_worker_threads_down(version):
    before = threads()
    unit = Unit(fmu_path("aggregation", version)).initialize(dict(SMALL, **{"run.threads": 2}))
    unit.step(5 * unit.get("time.dt"))
    assert threads() > before   # the OpenMP workers of the two-thread scene are running
    unit.free()
    assert threads() == before


@pytest.mark.parametrize("version", [2, 3])
def test_restitution_sweep_reusing_one_instance_with_reset(version):
    """As fmpy's parameter-sweep examples do: one instance, reset between runs. Each run equals a fresh
    instance's, and the head-on collision's realised restitution sqrt(K_after / K_before) is the exact one
    of the non-pulling contact (above e: F_n >= 0 dissipates less than the linear oscillator), to the
    1e-3 that 50 steps per contact give. t_c = 0.1 keeps the overlap below the clamp (0.1 R)."""
    path = fmu_path("collision", version)
    unit = Unit(path)
    realised = []
    for e in (0.3, 0.6, 0.9):
        unit.reset()
        params = {"contact.restitution": e, "contact.duration": 0.1}
        unit.initialize(params)
        before = unit.get("kinetic_energy")
        unit.step(1.0)   # approach, contact from t = 0.2 to about 0.3, separation
        assert unit.get("contacts") == 0 and unit.get("clamped_contacts_total") == 0
        realised.append((unit.get("kinetic_energy") / before) ** 0.5)
        assert realised[-1] == pytest.approx(clamped_restitution(e), rel=1e-3)
        fresh = Unit(path, "fresh").initialize(params)
        fresh.step(1.0)
        assert fresh.outputs() == unit.outputs()
        fresh.free()
    assert realised == sorted(realised) and len(set(realised)) == 3
    assert unit.errors() == []
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_gravity_is_tunable_while_stepping(version):
    """gravity.G steers the attraction between steps. G = 0 takes effect at the next force evaluation:
    after that the sparse cold cloud (no contacts yet) moves force-free, its kinetic energy exactly constant."""
    unit = Unit(fmu_path("aggregation", version)).initialize(SMALL)
    h = 20 * unit.get("time.dt")
    unit.set("gravity.G", 0.0)
    assert unit.get("gravity.G") == 0.0
    unit.step(h)
    coasting = unit.get("kinetic_energy")
    unit.step(h)
    assert unit.get("contacts") == 0 and unit.get("kinetic_energy") == coasting
    unit.set("gravity.G", 1.0)
    unit.step(h)
    assert unit.get("kinetic_energy") > 2 * coasting
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_taking_a_consolidation_state_changes_nothing_and_restoring_it_continues_exactly(version):
    """The barostat's CVODE history is rebuilt from what the state carries: taking a state leaves the run as
    it was, and a restored one continues bit for bit, its CVODE counters back at their values."""
    def run(take_at):
        unit = Unit(fmu_path("consolidation", version), name="c").initialize({"particles.count": 100})
        h = 7 * unit.get("time.dt")
        state, trace, counters = None, [], None
        for k in range(40):
            if k == take_at:
                state = unit.get_state()
                counters = (unit.get("cvode_steps"), unit.get("cvode_reinitialisations"), unit.time)
            unit.step(h)
            trace.append(unit.outputs())
        return unit, state, counters, trace

    plain = run(None)[3]
    unit, state, counters, taken = run(3)
    assert taken[-1]["cell_length_x"] != taken[0]["cell_length_x"]   # the cell moved
    same([dict(t, cvode_seconds=0) for t in taken], [dict(t, cvode_seconds=0) for t in plain])
    unit.set_state(state)
    assert (unit.get("cvode_steps"), unit.get("cvode_reinitialisations")) == counters[:2]
    unit.time = counters[2]
    again = [None] * 3
    for k in range(3, 40):
        unit.step(7 * unit.get("time.dt"))
        again.append(unit.outputs())
    same([dict(t, cvode_seconds=0) for t in again[3:]], [dict(t, cvode_seconds=0) for t in taken[3:]])
    assert unit.errors() == []
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_corrupted_state_is_refused_and_the_instance_goes_on(version):
    unit = Unit(fmu_path("aggregation", version)).initialize(SMALL)
    h = 20 * unit.get("time.dt")
    unit.step(h)
    good = unit.serialize(unit.get_state())
    unit.step(h)
    reference = unit.outputs()
    for at in range(40, len(good), len(good) // 13):   # past the FMU's header: particles, lists, springs, the sum
        bad = bytearray(good)
        bad[at] ^= 0x40
        with pytest.raises(Exception):
            unit.set_state(unit.deserialize(bytes(bad)))
        assert "check sum" in unit.errors()[-1]
    unit.set_state(unit.deserialize(good))   # the good one still restores, and continues as before
    unit.time = h
    unit.step(h)
    same([unit.outputs()], [reference])
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_state_restores_where_the_fixed_parameters_have_the_same_values(version):
    """A host that writes every parameter's start value (the default among them), or sets one and then sets
    it back, has the packaged values: the state of an instance that set nothing restores there."""
    path = fmu_path("collision", version)
    a = Unit(path, name="a").initialize()
    a.step(0.05)
    saved = a.serialize(a.get_state())
    b = Unit(path, name="b").initialize({"contact.restitution": 0.5})   # the packaged value
    b.set_state(b.deserialize(saved))
    c = Unit(path, name="c")
    c.set("contact.restitution", 0.7)
    c.set("contact.restitution", 0.5)
    c.initialize()
    c.set_state(c.deserialize(saved))
    d = Unit(path, name="d").initialize({"contact.restitution": 0.7})   # really other values: refused
    with pytest.raises(Exception):
        d.set_state(d.deserialize(saved))
    assert "other parameter values" in d.errors()[-1]
    for u in (b, c):
        u.time = 0.05
        u.step(0.05)
    a.step(0.05)
    assert b.outputs() == a.outputs() == c.outputs()
    for u in (a, b, c, d):
        u.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_host_restarts_from_a_state_stored_before_a_failed_step(version):
    """FMI 2.0 section 2.1.3: after an error a host may restart from a state it stored before."""
    unit = Unit(fmu_path("aggregation", version)).initialize(dict(SMALL, **{"particles.mass": 100.0}))
    dt = unit.get("time.dt")
    unit.step(dt)
    state = unit.get_state()
    unit.set("gravity.G", 1e308)   # the next forces overflow
    with pytest.raises(Exception):
        unit.step(dt)
    assert "non-finite" in unit.errors()[-1]
    unit.set_state(state)
    unit.time = dt
    unit.set("gravity.G", 1.0)
    unit.step(dt)
    assert unit.get("step") == 2
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_the_fmu_keeps_the_host_clock_over_a_long_run(version):
    """40,000 communication steps of 0.02 (ten steps of dt each) to t = 800, as fmpy counts them (k h) and as
    a host that adds its steps up: each step starts where the host says the FMU is, and ends on t + h.
    A sum of dt drifted 3e-9 from the host's clock by t = 700, beyond the tolerance of the check."""
    path = fmu_path("collision", version)
    counting, adding = Unit(path, name="k").initialize(), Unit(path, name="a").initialize()
    h, t = 0.02, 0.0
    for k in range(40000):
        counting.fmu.doStep(k * h, h)
        adding.fmu.doStep(t, h)
        t += h
    assert counting.get("time") == 39999 * h + h and adding.get("time") == t
    assert counting.get("step") == adding.get("step") == 400000
    for tiny in range(10):   # steps far below dt: the FMU is still where the host says
        adding.fmu.doStep(t, 1e-13)
        t += 1e-13
    adding.fmu.doStep(t, h)
    assert adding.get("time") == t + h
    assert counting.errors() == adding.errors() == []
    counting.free()
    adding.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_state_whose_start_or_current_time_is_damaged_is_refused(version):
    """Bytes 16 to 31 of a state hold the start and the current time, which the engine's check sum does not
    cover: a damaged current time restored with OK, and the next step ran the gap to it."""
    unit = Unit(fmu_path("aggregation", version)).initialize(SMALL)
    dt = unit.get("time.dt")
    unit.step(5 * dt)
    good = unit.serialize(unit.get_state())
    assert struct.unpack("<dd", good[16:32]) == (0.0, 5 * dt)
    for at, value in ((16, 1.0), (24, 1.0), (24, 5 * dt + dt)):
        bad = bytearray(good)
        bad[at:at + 8] = struct.pack("<d", value)
        with pytest.raises(Exception):
            unit.set_state(unit.deserialize(bytes(bad)))
        assert "check sum" in unit.errors()[-1] and "time" in unit.errors()[-1], unit.errors()[-1]
    assert unit.get("time") == 5 * dt and unit.get("step") == 5   # nothing restored
    unit.set_state(unit.deserialize(good))
    unit.step(dt)
    assert unit.get("step") == 6
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_state_set_before_the_end_of_initialization_is_refused(version):
    """A state set in the instantiated state was answered OK, then initialization put the clock back to the
    start time, and every doStep took no step at all. It is refused with a message, before initialization and
    in initialization mode (whose start time and parameters would replace it); after it, it restores."""
    path = fmu_path("aggregation", version)
    a = Unit(path, "a").initialize(SMALL)
    dt = a.get("time.dt")
    a.step(5 * dt)
    saved = a.serialize(a.get_state())
    b = Unit(path, "b")
    for name, value in SMALL.items():
        b.set(name, value)
    # Each version's own name for the function called (FMI 2 spells it with a lower-case s)
    set_state = "fmi2SetFMUstate" if version == 2 else "fmi3SetFMUState"
    with pytest.raises(Exception):
        b.set_state(b.deserialize(saved))
    assert f"{set_state} is not allowed in the instantiated state" in b.errors()[-1], b.errors()[-1]
    if version == 2:
        b.fmu.setupExperiment(startTime=0.0)
    b.fmu.enterInitializationMode() if version == 2 else b.fmu.enterInitializationMode(startTime=0.0)
    with pytest.raises(Exception):
        b.set_state(b.deserialize(saved))
    assert f"{set_state} is not allowed in initialization mode" in b.errors()[-1], b.errors()[-1]
    b.fmu.exitInitializationMode()
    b.step(dt)   # the refused states left the instance at its start
    assert b.get("step") == 1
    b.set_state(b.deserialize(saved))   # after initialization: restored, and stepping goes on from it
    b.time = 5 * dt
    b.step(dt)
    a.step(dt)
    assert b.get("step") == 6
    same([b.outputs()], [a.outputs()])
    a.free()
    b.free()
