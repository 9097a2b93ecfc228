"""A host thread that writes HDF5 snapshots through an instance, frees it and ends: the host goes on."""
import pytest

from fmu_host import host_process

# In a subprocess (a crash fails the test, not the suite), in a scratch working directory for the snapshot files.
HOST = """
import os, sys, threading
from fmu_host import Unit, fmu_path
os.chdir(sys.argv[2])
def host_thread(name):
    unit = Unit(fmu_path("collision", int(sys.argv[1])), name=name).initialize({"fmu.snapshots_every": 10})
    for _ in range(3):
        unit.step(5 * unit.get("time.dt"))
    unit.free()
for name in ("first", "second"):
    thread = threading.Thread(target=host_thread, args=(name,))
    thread.start()
    thread.join()
print(sorted(f for f in os.listdir(".") if f.endswith(".h5")))
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_host_thread_that_wrote_snapshots_ends_without_a_crash(tmp_path, version):
    """Debian's HDF5 is built thread-safe: it keeps per-thread data under thread keys, whose destructors run when the
    thread ends. Freeing the instance unloaded the snapshot plugin and HDF5 with it, and the thread's end called
    into unmapped code: a segmentation fault. The plugin now stays loaded once loaded."""
    r = host_process(HOST, version, tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["['first.h5',", "'second.h5']"], r.stdout
