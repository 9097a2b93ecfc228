"""The FMU-state messages name the function the host called, in its version's spelling: FMI 2's fmi2GetFMUstate,
fmi2SetFMUstate and fmi2DeSerializeFMUstate, FMI 3's fmi3GetFMUState, fmi3SetFMUState and fmi3DeserializeFMUState
(as do_step's name fmi2DoStep and fmi3DoStep). Both versions' messages used FMI 3's unprefixed spelling."""
import pytest

from fmu_host import Unit, fmu_path

SMALL = {"particles.count": 200, "run.threads": 1}   # a quick aggregation
NAMES = {
    2: ("fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2DeSerializeFMUstate"),
    3: ("fmi3GetFMUState", "fmi3SetFMUState", "fmi3DeserializeFMUState"),
}


@pytest.mark.parametrize("version", [2, 3])
def test_each_state_message_names_the_called_function_as_its_version_spells_it(version):
    get_name, set_name, deserialize_name = NAMES[version]
    path = fmu_path("aggregation", version)
    other = Unit(path, "other").initialize(dict(SMALL, **{"particles.seed": 99}))   # other parameter values
    foreign = other.serialize(other.get_state())
    other.free()
    unit = Unit(path).initialize(SMALL)
    dt = unit.get("time.dt")
    unit.step(dt)
    good = unit.serialize(unit.get_state())

    with pytest.raises(Exception):
        unit.deserialize(b"not a state of this FMU")
    assert unit.errors()[-1].startswith(f"{deserialize_name}: these bytes are not a state"), unit.errors()[-1]

    with pytest.raises(Exception):
        unit.set_state(unit.deserialize(foreign))
    assert unit.errors()[-1].startswith(f"{set_name}: the state was saved with other parameter values"), unit.errors()[-1]

    unit.set("gravity.G", 1e308)   # the next forces overflow: the instance is in its error state
    with pytest.raises(Exception):
        unit.step(dt)
    with pytest.raises(Exception):
        unit.get_state()
    assert unit.errors()[-1].startswith(f"{get_name} is not allowed in the error state"), unit.errors()[-1]

    unit.set_state(unit.deserialize(good))   # the messages changed, not what the calls do
    unit.free()
