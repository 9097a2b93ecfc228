"""A host that runs several instances at once, each from its own thread (fmpy's ctypes calls release the GIL): every
instance gives bit for bit what it gives alone, and its messages reach its own logger on the calling thread."""
import threading
import time

import pytest

from fmu_host import Unit, _fmi2_messages, fmu_path

# Both models, both FMI versions, one and two engine threads.
CASES = [("aggregation", 2, {"particles.count": 300, "run.threads": 2}),
         ("aggregation", 3, {"particles.count": 300, "run.threads": 2, "contact.restitution": 0.3}),
         ("aggregation", 3, {"particles.count": 200, "run.threads": 1}),
         ("consolidation", 2, {"particles.count": 100}),
         ("consolidation", 3, {"particles.count": 120}),
         ("collision", 2, {})]


class Witness(list):
    """A message list that notes the thread each message arrives on."""

    def __init__(self):
        super().__init__()
        self.threads = set()

    def append(self, message):
        self.threads.add(threading.get_ident())
        super().append(message)


def run(case, name):
    model, version, params = case
    unit = Unit(fmu_path(model, version), name=name, logging=True)
    unit.messages = Witness()   # read by the FMI 3 callback; FMI 2's are routed by componentEnvironment
    if version == 2:
        _fmi2_messages[unit._callbacks.componentEnvironment] = unit.messages
    unit.initialize(params)
    h = 7 * unit.get("time.dt")
    trace = []
    for _ in range(15):
        unit.step(h)
        trace.append({k: repr(v) for k, v in unit.outputs().items() if k != "cvode_seconds"})   # that one is wall time
    unit.free()
    return trace, unit.messages


def test_instances_stepped_from_host_threads_at_once_equal_each_alone():
    """The threads come first: they also make the test host unpack each FMU from several threads at once."""
    together, callers = [None] * len(CASES), [None] * len(CASES)

    def host_thread(i):
        callers[i] = threading.get_ident()
        together[i] = run(CASES[i], f"thread{i}")

    threads = [threading.Thread(target=host_thread, args=(i,)) for i in range(len(CASES))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    alone = [run(case, f"alone{i}") for i, case in enumerate(CASES)]
    for i, ((trace, messages), (trace_alone, messages_alone)) in enumerate(zip(together, alone)):
        assert trace and trace == trace_alone, CASES[i]
        assert messages == messages_alone and len(messages) > 15, CASES[i]   # every logCalls message, its own
        assert messages.threads == {callers[i]}, CASES[i]   # the logger is called on the host's calling thread
        assert not [m for s, c, m in messages if s >= 3], CASES[i]


def test_a_call_from_a_second_thread_while_one_is_inside_is_refused_not_raced():
    """FMI allows one call at a time on an instance; a host that stepped one instance from two threads (Ecos, with two
    slots loaded from one FMU path) would corrupt the heap, 1 run in 6 aborting the host. A second thread's call
    returns Error naming the rule, and the call inside goes on; a free asked meanwhile is
    done when that call ends."""
    for version in (2, 3):
        unit = Unit(fmu_path("aggregation", version), name="shared")
        unit.initialize({"particles.count": 1000, "run.threads": 1})
        dt = unit.get("time.dt")
        done, stepped = threading.Event(), []

        def long_step():
            try:
                started.set()
                unit.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=4000 * dt)   # seconds; raises on Error
                stepped.append(True)
            finally:
                done.set()

        started = threading.Event()
        stepping = threading.Thread(target=long_step)
        stepping.start()
        started.wait()
        time.sleep(0.05)   # into the step
        refused = 0
        while not done.is_set() and refused < 3:
            try:
                unit.get("kinetic_energy")
            except Exception:
                refused += 1
            done.wait(0.05)
        # and a free: kept until the step ends (fmpy's freeInstance would unload the library under it)
        getattr(unit.fmu, f"fmi{version}FreeInstance")(unit.fmu.component)
        stepping.join()
        assert refused >= 1, "the long step ended before a second call could be made"
        said = [m for m in unit.errors() if "while another thread is inside a call on instance \"shared\"" in m]
        assert len(said) == refused, unit.errors()
        assert stepped == [True]   # the step inside went on to its end, OK
        with pytest.raises(Exception):   # then the free was done: the handle is no instance any more
            unit.get("kinetic_energy")
