"""The test host's own logging: each FMI 2 instance's messages reach its own Unit. fmpy's FMI 2 logger proxy keeps
one callback for the process, the last one given: an error of one instance was filed under the newest Unit, where
`errors() == []` of the first passed whatever it logged."""
import pytest

from fmu_host import Unit, fmu_path


def test_each_fmi2_instance_logs_to_its_own_unit():
    a = Unit(fmu_path("collision", 2), name="a")
    b = Unit(fmu_path("collision", 2), name="b")
    try:
        a.set("contact.restitution", 1.5)
    except Exception:
        pass
    assert any("contact.restitution" in m and "1.5" in m for m in a.errors()), a.messages
    assert b.errors() == []
    a.free()
    b.free()


@pytest.mark.parametrize("version", [2, 3])
def test_a_parameter_set_again_does_not_repeat_the_start_up_warnings(version):
    """A host that sets its parameters again in Initialization Mode (libcosim does) rebuilt the simulation and had every
    start-up warning twice (an outside review, 2026-12-07). A reset starts a new experiment: they are said again."""
    unit = Unit(fmu_path("collision", version))
    coarse = "time.steps_per_contact"   # 10: dt past t_c / 20, a start-up warning
    said = lambda: sum("exceeds t_c / 20" in m for m in unit.warnings())
    unit.set(coarse, 10)
    if version == 2:
        unit.fmu.setupExperiment(startTime=0.0)
        unit.fmu.enterInitializationMode()
    else:
        unit.fmu.enterInitializationMode(startTime=0.0)
    assert said() == 1
    unit.set(coarse, 10)
    unit.set("contact.restitution", 0.6)   # a rebuild with new values: the warning, the same, not again
    unit.fmu.exitInitializationMode()
    unit.step(0.01)
    assert said() == 1
    unit.reset()
    unit.initialize({coarse: 10})
    assert said() == 2
    unit.free()
