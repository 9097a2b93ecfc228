"""A small FMI host over fmpy's low-level classes, the same for FMI 2 and 3, that keeps every log
message the FMU sends. Used by the tests/python/test_fmu_*.py files and runner/bench_fmu.py."""
import ctypes
import itertools
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import threading

import fmpy
from fmpy import read_model_description
from fmpy.fmi2 import fmi2CallbackLoggerTYPE
from fmpy.fmi1 import FMICallException  # noqa: F401  (re-exported for the tests)


def fmu_dir():
    """build/fmus next to the runner binary (GRAINS_BIN), or GRAINS_FMU_DIR."""
    if os.environ.get("GRAINS_FMU_DIR"):
        return pathlib.Path(os.environ["GRAINS_FMU_DIR"])
    return pathlib.Path(os.environ["GRAINS_BIN"]).resolve().parents[1] / "fmus"


def fmu_path(model, version):
    return fmu_dir() / f"fmi{version}" / f"{model}.fmu"


def host_process(script, *args, env=None, timeout=None, cwd=None):
    """Runs a host script in its own process (a crash there fails the test, not the suite) with fmu_host importable;
    `env` adds to the environment. `timeout` (seconds) only ends a host that hangs, with the processes it forked."""
    here = pathlib.Path(__file__).parent
    env = dict(os.environ, **(env or {}))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(here), os.environ.get("PYTHONPATH")]))
    with subprocess.Popen([sys.executable, "-c", script, *map(str, args)], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, env=env, start_new_session=True, cwd=cwd) as host:
        try:
            out, err = host.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(host.pid, signal.SIGKILL)
            raise
    return subprocess.CompletedProcess(host.args, host.returncode, out, err)


# Each FMU a process opens is unpacked once, into a folder removed when the process ends (fmpy.extract alone
# leaves one folder per call in the system's temporary directory: ten per run of the test suite).
_scratch = tempfile.TemporaryDirectory(prefix="grains-fmus-")
_extracted = {}
_extracting = threading.Lock()   # Units made in several threads at once unpacked into one folder, over a loaded binary


def extracted(path):
    path = str(path)
    with _extracting:
        if path not in _extracted:
            _extracted[path] = fmpy.extract(path, unzipdir=os.path.join(_scratch.name, str(len(_extracted))))
        return _extracted[path]


# fmpy's FMI 2 logger proxy (which formats the printf-style message) holds one callback for the whole process, the
# last one given to it: every FMI 2 instance's messages went to the newest Unit, and once that Unit was collected, to
# freed memory (a crash, with instances in threads). So one callback, kept for the process's life, hands each message
# to the Unit its instance's componentEnvironment names.
_fmi2_messages = {}   # componentEnvironment -> that Unit's message list
_fmi2_keys = itertools.count(1)   # next() is atomic: Units are made in threads too
unrouted_messages = []   # of FMI 2 instances made with fmpy's own callbacks (no componentEnvironment), which share the proxy
_fmi2_logger = fmi2CallbackLoggerTYPE(lambda env, inst, status, cat, msg: _fmi2_messages.get(env, unrouted_messages).append(
    (status, cat.decode(), msg.decode())))


class Unit:
    """One instance of an FMU. Values are read and set by variable name; types come from the model description."""

    def __init__(self, path, name="unit", logging=False):
        self.md = read_model_description(str(path))
        self.version = int(self.md.fmiVersion[0])
        self.variables = {v.name: v for v in self.md.modelVariables}
        self.by_reference = {v.valueReference: v for v in self.md.modelVariables}
        self.messages = []
        kw = dict(guid=self.md.guid, unzipDirectory=extracted(path),
                  modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        if self.version == 2:
            from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions
            from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE
            from fmpy.logging import addLoggerProxy
            libc = ctypes.CDLL(None)
            libc.calloc.restype = ctypes.c_void_p
            self._callbacks = fmi2CallbackFunctions()
            self._callbacks.logger = _fmi2_logger
            self._callbacks.componentEnvironment = next(_fmi2_keys)
            _fmi2_messages[self._callbacks.componentEnvironment] = self.messages
            self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(libc.calloc)
            self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(libc.free)
            addLoggerProxy(ctypes.byref(self._callbacks))
            self.fmu = FMU2Slave(**kw)
            self.fmu.instantiate(callbacks=self._callbacks, loggingOn=logging)
        else:
            from fmpy.fmi3 import FMU3Slave
            self.fmu = FMU3Slave(**kw)
            self.fmu.instantiate(loggingOn=logging, logMessage=lambda env, status, cat, msg: self.messages.append(
                (status, cat.decode(), msg.decode())))
        self.time = 0.0

    # --- life cycle ---
    def initialize(self, start_values=None, start_time=0.0, stop_time=None):
        """stop_time None: the host defines no stop time."""
        for name, value in (start_values or {}).items():
            self.set(name, value)
        if self.version == 2:
            self.fmu.setupExperiment(startTime=start_time, stopTime=stop_time)
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=start_time, stopTime=stop_time)
        self.fmu.exitInitializationMode()
        self.time = start_time
        return self

    def step(self, h):
        self.fmu.doStep(self.time, h)
        self.time += h

    def reset(self):
        self.fmu.reset()
        self.time = 0.0

    def free(self):
        self.fmu.freeInstance()

    # --- values ---
    def _call(self, prefix, var):
        kind = var.type
        # an enumeration is read and set as FMI 2's Integer, FMI 3's Int64
        if kind == "Enumeration":
            kind = "Integer" if self.version == 2 else "Int64"
        name = kind
        return getattr(self.fmu, prefix + name)

    def set(self, name, value):
        var = self.variables[name]
        self._call("set", var)([var.valueReference], [value])

    def get(self, name):
        var = self.variables[name]
        if not var.dimensions:
            return self._call("get", var)([var.valueReference])[0]
        size = 1
        for d in var.dimensions:   # a fixed size, or the value of a structural parameter
            size *= int(d.start) if d.start else int(self.get(self.by_reference[d.valueReference].name))
        return self._call("get", var)([var.valueReference], nValues=size)

    def scalar_outputs(self):
        return [v.name for v in self.md.modelVariables if v.causality == "output" and not v.dimensions]

    def outputs(self):
        return {name: self.get(name) for name in self.scalar_outputs()}

    # --- state ---
    def get_state(self):
        return self.fmu.getFMUState() if self.version == 3 else self.fmu.getFMUstate()

    def set_state(self, state):
        self.fmu.setFMUState(state) if self.version == 3 else self.fmu.setFMUstate(state)

    def serialize(self, state):
        return bytes(self.fmu.serializeFMUState(state) if self.version == 3 else self.fmu.serializeFMUstate(state))

    def deserialize(self, data):
        return self.fmu.deserializeFMUState(data) if self.version == 3 else self.fmu.deSerializeFMUstate(data)

    def errors(self):
        return [m for s, c, m in self.messages if s >= 3]

    def warnings(self):
        return [m for s, c, m in self.messages if s == 1]
