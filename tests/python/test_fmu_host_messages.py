"""The test host's own logging: each FMI 2 instance's messages reach its own Unit. fmpy's FMI 2 logger proxy keeps
one callback for the process, the last one given: an error of one instance was filed under the newest Unit, where
`errors() == []` of the first passed whatever it logged."""
import pytest

from fmu_host import Unit, fmu_path, host_process


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
    """A host that sets its parameters again in Initialization Mode (libcosim does) rebuilds the simulation, which must
    not say every start-up warning twice. A reset starts a new experiment: they are said again."""
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


REENTRANT_HOST = r"""
import sys
from fmu_host import Unit, fmu_path, host_process
mode = sys.argv[1]
unit = Unit(fmu_path("collision", 3), name="r")


class CallingBack(list):
    fired = False

    def append(self, message):
        super().append(message)
        if message[0] == 1 and not CallingBack.fired:   # the first warning
            CallingBack.fired = True
            if mode == "read":
                unit.get("kinetic_energy")   # runs the checks again, inside the call that logs
            elif mode == "set":
                try:
                    unit.set("time.steps_per_contact", 200)
                except Exception:
                    print("set refused")
            else:
                unit.fmu.fmi3FreeInstance(unit.fmu.component)


unit.messages = CallingBack()
unit.set("time.steps_per_contact", 10)   # two start-up warnings
unit.fmu.enterInitializationMode(startTime=0.0)
print("warnings", sum(m[0] == 1 for m in unit.messages))
if mode == "read":
    unit.set("contact.restitution", 0.6)   # a rebuild: its warnings are those said already
    unit.get("kinetic_energy")
    print("after the rebuild", sum(m[0] == 1 for m in unit.messages))
elif mode == "set":
    print("steps_per_contact", unit.get("time.steps_per_contact"), "dt", unit.get("time.dt"))
else:
    try:
        unit.get("kinetic_energy")
        print("still there")
    except Exception:
        print("freed when the call ended")
"""


def test_a_logger_calling_back_into_its_instance_is_served_once_and_safely():
    """A host's logger may call back into the instance it logs for, on the same thread (which is why a call claims its
    instance for a thread, not for good). A logger reading an output must not have the first warning twice, nor the
    next rebuild read past the end of the warnings (SIGSEGV); a logger freeing the instance must not free it under the
    call. Each warning is said once, and such a free is done when the call ends. A set from there is refused (it would
    be lost to the rebuild around it: steps_per_contact would read 200, the step be 10's)."""
    read = host_process(REENTRANT_HOST, "read", timeout=60)
    assert read.returncode == 0, (read.returncode, read.stderr)
    assert read.stdout.split() == ["warnings", "2", "after", "the", "rebuild", "2"], read.stdout
    free = host_process(REENTRANT_HOST, "free", timeout=60)
    assert free.returncode == 0, (free.returncode, free.stderr)
    assert free.stdout.splitlines() == ["warnings 2", "freed when the call ended"], free.stdout
    nested_set = host_process(REENTRANT_HOST, "set", timeout=60)
    assert nested_set.returncode == 0, (nested_set.returncode, nested_set.stderr)
    assert nested_set.stdout.splitlines() == ["set refused", "warnings 2", "steps_per_contact 10.0 dt 0.01"], nested_set.stdout


@pytest.mark.parametrize("version", [2, 3])
def test_a_parameter_that_changes_what_an_input_means_is_said(version):
    """adhesion.force = 0 makes the cell cohesionless, where P* is reduced by k_n, not F0: the input cell.pressure's
    target moves by orders of magnitude while the modelDescription still says a P / F0. Each new meaning is said once,
    naming the value that caused it."""
    unit = Unit(fmu_path("consolidation", version))
    meaning = lambda name: [m for m in unit.warnings() if f"'{name}' is:" in m]
    unit.initialize({"particles.count": 100})
    assert meaning("cell.pressure") == [] and meaning("pressure_reduced") == []
    unit.reset()
    unit.set("particles.count", 100)
    unit.set("adhesion.force", 0.0)
    if version == 2:
        unit.fmu.setupExperiment(startTime=0.0)
        unit.fmu.enterInitializationMode()
    else:
        unit.fmu.enterInitializationMode(startTime=0.0)
    unit.set("friction.coefficient", 0.3)   # a rebuild in Initialization Mode: said once all the same
    unit.fmu.exitInitializationMode()
    unit.step(0.01)
    said = meaning("cell.pressure")
    assert len(said) == 1, unit.warnings()
    assert "adhesion.force = 0" in said[0] and "P / k_n (cohesionless" in said[0] and "says: target reduced pressure P* = a P / F0" in said[0]
    assert len(meaning("pressure_reduced")) == 1
    unit.free()
