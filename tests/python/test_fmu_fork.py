"""A host that forks after the FMU has run (Python's multiprocessing does on Linux): the child runs an FMU, a new
instance or the one it inherited, and the parent goes on."""
import pytest

from fmu_host import host_process

HOST = """
import os, sys
from fmu_host import Unit, fmu_path
version = int(sys.argv[1])
params = {"particles.count": 300, "run.threads": 2}
parent = Unit(fmu_path("aggregation", version), name="parent").initialize(params)
h = 5 * parent.get("time.dt")
parent.step(h)   # this thread's OpenMP workers are running
pid = os.fork()
if pid == 0:
    child = Unit(fmu_path("aggregation", version), name="child").initialize(params)
    child.step(h)
    parent.step(h)
    print("child", int(child.get("step")), int(parent.get("step")), flush=True)
    os._exit(0)
_, status = os.waitpid(pid, 0)
parent.step(h)
print("parent", int(parent.get("step")), os.waitstatus_to_exitcode(status))
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_forked_child_runs_the_fmu_and_the_parent_goes_on(version):
    """fork() copies only the forking thread: the child's first parallel region waited for the parent's OpenMP
    workers forever. The timeout only ends such a hang; the run takes seconds."""
    r = host_process(HOST, version, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["child", "5", "10", "parent", "10", "0"], r.stdout
