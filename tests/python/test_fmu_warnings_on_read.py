"""A warning raised while a host reads the outputs reaches the host's logger in that read. The energy and
pass-through checks of a gravity scene run as the outputs are computed, which in an FMU is when they are read; were
such a warning to wait for the next DoStep, one raised by the last read before Terminate would never be logged."""
import pytest

from fmu_host import Unit, fmu_path

WARNING = 1   # fmi2Warning, fmi3Warning


@pytest.mark.parametrize("version", [2, 3])
def test_a_warning_raised_by_a_read_is_logged_by_that_read(version):
    # 200 spheres with contacts soft enough (k* about 10) that grains pass through each other within a t_ff
    unit = Unit(fmu_path("aggregation", version), logging=True).initialize(
        {"particles.count": 200, "contact.duration": 0.5})
    dt = unit.get("time.dt")
    logged_by = []
    for chunk in range(30):
        before = len(unit.messages)
        unit.step(10 * dt)
        logged_by += [("step", m) for s, _, m in unit.messages[before:] if s == WARNING]
        before = len(unit.messages)
        unit.outputs()
        logged_by += [("read", m) for s, _, m in unit.messages[before:] if s == WARNING]
        if any("contact check" in m for _, m in logged_by):
            break
    unit.fmu.terminate()
    unit.free()
    checks = [call for call, m in logged_by if "contact check" in m]
    assert checks == ["read"], f"the pass-through warning was logged by {checks} (warnings: {logged_by})"
