"""fmpy drives the consolidation FMU's target pressure through a staircase (a structured array with repeated times
at the jumps). Its interpolation gives a level as the value itself at most communication points and one ulp off at
others, more of them the smaller the step: those roundings are no new targets, so CVODE restarts at the jumps and
on its schedule alone, the same at any communication step (each ulp had restarted it: 213 restarts in 12,000 steps
at h = 7 dt, 24 at h = 2000 dt)."""
import fmpy
import numpy as np
import pytest

from fmu_host import Unit, fmu_path

LEVELS = [0.01, 0.05, 0.2]
EVERY = 2000   # steps per level


@pytest.mark.parametrize("version", [2, 3])
def test_a_staircase_restarts_cvode_alike_at_any_communication_step(version):
    path = str(fmu_path("consolidation", version))
    start = {"particles.count": 100}
    unit = Unit(path).initialize(start)
    dt = unit.get("time.dt")
    unit.free()
    rows = [(t * EVERY * dt, p) for i, p in enumerate(LEVELS) for t in (i, i + 1)]
    staircase = np.array(rows, dtype=[("time", np.float64), ("cell.pressure", np.float64)])
    runs = {k: fmpy.simulate_fmu(path, start_values=start, stop_time=len(LEVELS) * EVERY * dt, output_interval=k * dt,
                                 input=staircase, output=["step", "cell.pressure", "cvode_reinitialisations"])
            for k in (EVERY, 7)}
    assert len(set(runs[7]["cell.pressure"])) > len(LEVELS)   # fmpy's roundings are there
    for run in runs.values():
        assert run["step"][-1] == len(LEVELS) * EVERY
    assert runs[7]["cvode_reinitialisations"][-1] == runs[EVERY]["cvode_reinitialisations"][-1]
