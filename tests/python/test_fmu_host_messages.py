"""The test host's own logging: each FMI 2 instance's messages reach its own Unit. fmpy's FMI 2 logger proxy keeps
one callback for the process, the last one given: an error of one instance was filed under the newest Unit, where
`errors() == []` of the first passed whatever it logged."""
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
