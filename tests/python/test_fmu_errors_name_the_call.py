"""Every error the FMU logs begins with the FMI function the host called, in its version's spelling: a host's log
interleaves many calls, and "unknown value reference 9999" alone does not say which one was refused."""
import pytest

from fmu_host import Unit, fmu_path


def refused(unit, call):
    """The call raises; its last logged error, returned."""
    with pytest.raises(Exception):
        call()
    return unit.errors()[-1]


@pytest.mark.parametrize("version", [2, 3])
def test_value_phase_and_initialization_errors_begin_with_the_called_function(version):
    fmi, real = f"fmi{version}", "Real" if version == 2 else "Float64"
    unit = Unit(fmu_path("consolidation", version))
    get, set_ = (unit.fmu.getReal, unit.fmu.setReal) if version == 2 else (unit.fmu.getFloat64, unit.fmu.setFloat64)
    try:
        m = refused(unit, lambda: get([9999]))
        assert m.startswith(f"{fmi}Get{real}: unknown value reference 9999"), m
        m = refused(unit, lambda: unit.set("adhesion.force", -1.0))
        assert m.startswith(f"{fmi}Set{real}: ") and "adhesion.force" in m and "-1" in m, m
        m = refused(unit, lambda: set_([9999], [1.0]))
        assert m.startswith(f"{fmi}Set{real}: unknown value reference 9999"), m
        m = refused(unit, lambda: unit.fmu.doStep(0.0, 0.1))   # named already: not twice
        assert m.startswith(f"{fmi}DoStep is not allowed"), m
        m = refused(unit, lambda: unit.fmu.terminate())   # in its version's spelling, once ("Terminate" is both's)
        assert m.startswith(f"{fmi}Terminate is not allowed in"), m
        unit.set("adhesion.force", 2e4)   # more than the contact's clamp holds: the simulation is not built
        m = refused(unit, lambda: unit.fmu.enterInitializationMode())
        assert m.startswith(f"{fmi}EnterInitializationMode: ") and "adhesion.force: value 20000" in m, m
        unit.fmu.reset()
        unit.initialize({"particles.count": 100})
        m = refused(unit, lambda: unit.set("adhesion.force", 1.0))
        assert m.startswith(f"{fmi}Set{real}: ") and "fixed parameter" in m, m
        assert not any(e.startswith(f"{fmi}Set{real}: {fmi}") for e in unit.errors()), unit.errors()
    finally:
        unit.free()
