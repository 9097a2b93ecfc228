"""FMI 2's status queries each answer one kind. A null value pointer with the right kind was refused as
"only fmi2DoStepStatus is available", naming as wrong the kind the host had passed; now each mistake is named."""
import ctypes

import pytest

from fmu_host import Unit, fmu_path

QUERIES = [("fmi2GetStatus", 0, "fmi2DoStepStatus", ctypes.c_int),
           ("fmi2GetRealStatus", 2, "fmi2LastSuccessfulTime", ctypes.c_double),
           ("fmi2GetBooleanStatus", 3, "fmi2Terminated", ctypes.c_int)]


@pytest.mark.parametrize("function, kind, kind_name, value_type", QUERIES, ids=[q[0] for q in QUERIES])
def test_a_null_value_and_a_wrong_kind_are_named_as_such(function, kind, kind_name, value_type):
    unit = Unit(fmu_path("collision", 2))
    try:
        unit.initialize()
        query = getattr(unit.fmu.dll, function)
        query.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]
        query.restype = ctypes.c_int
        value = value_type()
        assert query(unit.fmu.component, kind, ctypes.byref(value)) == 0   # fmi2OK: the kind it answers
        assert query(unit.fmu.component, kind, None) == 3   # fmi2Error
        assert unit.errors()[-1] == f"{function}: value is a null pointer: pass where the status goes"
        assert query(unit.fmu.component, 1, ctypes.byref(value)) == 3   # fmi2PendingStatus, answered by none
        assert unit.errors()[-1] == f"{function}: status kind 1 is not available: only {kind_name} ({kind})"
        unit.step(unit.get("time.dt"))   # the instance goes on
    finally:
        unit.free()
