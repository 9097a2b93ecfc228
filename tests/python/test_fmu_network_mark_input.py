"""A host marks a stage's contacts with network.mark, the value a stage label such as its P* (0.01), through fmpy's
input table. The mark is discrete (it matters only where it changes): fmpy holds the value it is given. Declared
continuous, fmpy interpolated it between equal samples as 0.009999999999999998 at some communication points, each
of which made a new reference, so contacts_gained since the stage began read 0 where 17 contacts had formed."""
import fmpy
import numpy as np
import pytest

from fmu_host import Unit, fmu_path

COUNTS = ["contacts_kept", "contacts_lost", "contacts_gained"]


@pytest.mark.parametrize("version", [2, 3])
def test_a_mark_given_through_fmpy_is_set_once(version):
    path = str(fmu_path("consolidation", version))
    start = {"particles.count": 100}
    marked_at, end, h = 3000, 9000, 7   # steps
    mark = next(v for v in fmpy.read_model_description(path).modelVariables if v.name == "network.mark")
    assert mark.variability == "discrete"

    unit = Unit(path).initialize(start)   # a host that sets the mark once
    dt = unit.get("time.dt")
    n = 0
    while n < end:
        if n == marked_at:
            unit.set("network.mark", 0.01)
        m = min(h, (marked_at if n < marked_at else end) - n)
        unit.step(m * dt)
        n += m
    once = {name: unit.get(name) for name in COUNTS}
    unit.free()
    assert once["contacts_gained"] > 0   # the packing changed since the mark

    table = np.array([(0.0, 0.0), (marked_at * dt, 0.0), (marked_at * dt, 0.01), (end * dt, 0.01)],
                     dtype=[("time", np.float64), ("network.mark", np.float64)])
    run = fmpy.simulate_fmu(path, start_values=start, stop_time=end * dt, output_interval=h * dt, input=table,
                            output=["network.mark"] + COUNTS)
    assert set(run["network.mark"]) == {0.0, 0.01}
    assert {name: run[name][-1] for name in COUNTS} == once
