"""A communication step that is not a whole number of dt is taken in ceil(h / dt) equal steps. Whole steps and
one short remainder put a short step beside whole ones, where the contacts' sub-step charges, which take the next
step to be as long, are off: the head-on collision's restitution came 6e-3 off at h = 1.001 dt and 4.5e-3 at
1.37 dt, against 2e-4 at h = dt. Equal steps keep it within the 1e-3 of whole steps at any h."""
import math

import pytest

from fmu_host import Unit, fmu_path
from head_on import clamped_restitution


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("steps_of_dt", [1.001, 1.37, 2.5])
def test_uneven_communication_steps_keep_the_restitution(version, steps_of_dt):
    unit = Unit(fmu_path("collision", version)).initialize({"contact.restitution": 0.5, "contact.duration": 0.1})
    dt = unit.get("time.dt")
    h = steps_of_dt * dt
    before = unit.get("kinetic_energy")
    communication_steps = 600 // math.ceil(steps_of_dt)   # well past the contact (t = 0.2 to 0.3)
    for _ in range(communication_steps):
        unit.step(h)
    assert unit.get("step") == communication_steps * math.ceil(steps_of_dt)   # equal steps, no remainder
    assert unit.get("time") == pytest.approx(communication_steps * h, rel=1e-14)
    realised = (unit.get("kinetic_energy") / before) ** 0.5
    assert realised == pytest.approx(clamped_restitution(0.5), rel=1e-3)
    assert unit.errors() == []
    unit.free()
