"""A host's communication step is often the difference of two points of its own clock (fmpy's start + n h), which
carries that clock's rounding. A step of dt that arrives a few roundings short is still one whole step of dt: the
run is the runner's whatever the start time, not one of slightly shorter steps (the head-on collision touches on a
step boundary, where a shorter step decides the contact's first step differently: its kinetic energy after the
collision moved by 6e-5)."""
import fmpy
import numpy as np
import pytest

from fmu_host import Unit, fmu_path

OUTPUTS = ["step", "kinetic_energy", "momentum_x", "contacts", "max_overlap_ratio"]


@pytest.mark.parametrize("version", [2, 3])
def test_steps_of_dt_from_a_late_start_time_are_whole_steps(version):
    path = str(fmu_path("collision", version))
    unit = Unit(path).initialize()
    dt = unit.get("time.dt")
    unit.free()
    steps = 200   # the spheres touch at step 100 and part before 200
    runs = {start: fmpy.simulate_fmu(path, start_time=start, stop_time=start + steps * dt, output_interval=dt,
                                     output=OUTPUTS) for start in (0.0, 100.0, 3600.0)}
    for start, run in runs.items():
        assert list(run["step"]) == list(range(steps + 1)), start
        for name in OUTPUTS:
            np.testing.assert_array_equal(run[name], runs[0.0][name], err_msg=f"{name}, start time {start}")
