"""A host drives the consolidation FMU's target pressure P* (input cell.pressure) through a loading ramp
and an unloading, and the solid fraction output Phi traces the consolidation curve: Phi grows with P*
on loading, and the compaction is kept on unloading (cohesive grains: almost no elastic rebound)."""
import math

import pytest

from fmu_host import Unit, fmu_path

LOADING = [0.01, 0.1, 1.0, 10.0]
UNLOADING = [1.0, 0.1, 0.01]


@pytest.mark.parametrize("version", [2, 3])
def test_pressure_ramp_traces_the_consolidation_curve(version):
    unit = Unit(fmu_path("consolidation", version)).initialize({"particles.count": 200})
    h = 3000 * unit.get("time.dt")
    phi = {}
    trace = []
    for stage, p in enumerate(LOADING + UNLOADING):
        unit.set("cell.pressure", p)
        assert unit.get("cell.pressure") == p
        # the strain rate is capped at I_a / T0 (8 steps of h are 3.4 T0): the top stage takes three times longer
        for _ in range(24 if p == LOADING[-1] and stage < len(LOADING) else 8):
            unit.step(h)
            trace.append(unit.get("solid_fraction"))
        phi[(stage < len(LOADING), p)] = trace[-1]
    assert all(math.isfinite(x) and 0 < x < 1 for x in trace)
    loading = [phi[(True, p)] for p in LOADING]
    assert loading[1:] == sorted(loading[1:]) and loading[-1] > loading[0] + 0.2, loading   # compaction under load
    for p in UNLOADING:   # unloading keeps the compaction (no rebound beyond 0.01 as P* falls a thousandfold)
        assert phi[(False, p)] > phi[(True, 10.0)] - 0.01, (p, phi)
        assert phi[(False, p)] > phi[(True, p)] + 0.2, (p, phi)   # hysteresis: far denser than on loading
    assert unit.errors() == []
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_pressure_the_clamped_contacts_cannot_carry_is_warned_about_once(version):
    """The unit's clamp carries at most K_N f_max R_min = 12508 F0: a host asking P* = 1e6 (the input's top) drives
    the packing into overlaps past a radius. Its log says so, once, however often the host asks."""
    unit = Unit(fmu_path("consolidation", version), logging=True).initialize({"particles.count": 100})
    try:
        dt = unit.get("time.dt")
        unit.set("cell.pressure", 1e4)
        unit.step(dt)
        warned = lambda: [m for s, c, m in unit.messages if s == 1 and "clamped contact gives" in m]   # noqa: E731
        assert warned() == []
        for p in (1e6, 2e6 / 3, 1e6):
            unit.set("cell.pressure", p)
            unit.step(dt)
        assert len(warned()) == 1, warned()
        assert "cell.pressure = 1e+06 asks each contact for about P a^(D-1) = 1e+06, not below 12507.6" in warned()[0]
    finally:
        unit.free()
