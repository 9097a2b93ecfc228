"""A host that forks after the FMU has run (Python's multiprocessing does on Linux): the child runs an FMU, a new
instance or the one it inherited, and the parent goes on; also when the FMU library was unloaded before the fork."""
import shutil
import zipfile

import pytest

from fmu_host import fmu_path, host_process

HOST = """
import os, sys
from fmu_host import Unit
path = sys.argv[1]
params = {"particles.count": 300, "run.threads": 2}
parent = Unit(path, name="parent").initialize(params)
h = 5 * parent.get("time.dt")
parent.step(h)   # this thread's OpenMP workers are running
pid = os.fork()
if pid == 0:
    child = Unit(path, name="child").initialize(params)
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
    r = host_process(HOST, fmu_path("aggregation", version), timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["child", "5", "10", "parent", "10", "0"], r.stdout


@pytest.mark.parametrize("version", [2, 3])
def test_without_the_fork_guard_the_fmu_runs_and_a_fork_while_it_is_loaded_works(tmp_path, version):
    """An FMU whose grains_fork_guard.so was taken out still loads and runs, and registers a fork handler of its own
    (which goes when the library is unloaded)."""
    path = fmu_path("aggregation", version)
    stripped = tmp_path / path.name
    with zipfile.ZipFile(path) as full, zipfile.ZipFile(stripped, "w") as out:
        for entry in full.infolist():
            if not entry.filename.endswith("/grains_fork_guard.so"):
                out.writestr(entry, full.read(entry))
    assert len(zipfile.ZipFile(stripped).namelist()) == len(zipfile.ZipFile(path).namelist()) - 1
    r = host_process(HOST, stripped, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["child", "5", "10", "parent", "10", "0"], r.stdout


# A host thread that stays steps an instance of each FMU given; the main thread frees them, and fmpy unloads the FMU
# library at each free; then the stepping thread, whose OpenMP workers outlive those frees, forks. The child loads
# the last FMU anew and steps. Before the fork: how many fork guards and FMU binaries the process has mapped.
AFTER_UNLOAD = """
import os, queue, sys, threading
from fmu_host import Unit
paths = sys.argv[1:]
params = {"particles.count": 300, "run.threads": 2}
jobs, done = queue.Queue(), queue.Queue()
threading.Thread(target=lambda: [done.put(job()) for job in iter(jobs.get, None)], daemon=True).start()
for i, path in enumerate(paths):
    unit = Unit(path, name=f"freed{i}").initialize(params)
    h = 5 * unit.get("time.dt")
    jobs.put(lambda: unit.step(h))
    done.get()
    unit.free()   # fmi*FreeInstance releases this thread's pool, not the stepper's; then fmpy unloads the library
mapped = {line.split()[-1] for line in open("/proc/self/maps") if line.rstrip().endswith(".so")}
print("guards", sum(p.endswith("/grains_fork_guard.so") for p in mapped),
      "binaries", sum(p.endswith("/grains_aggregation.so") for p in mapped), flush=True)

def fork_and_run():
    pid = os.fork()
    if pid == 0:
        child = Unit(paths[-1], name="child").initialize(params)
        child.step(h)
        print("child", int(child.get("step")), flush=True)
        os._exit(0)
    return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])

jobs.put(fork_and_run)
print("parent", done.get(), flush=True)
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_child_forked_after_the_library_is_unloaded_runs_the_fmu(tmp_path, version):
    """The FMU library's fork handler went with the library, and the child forked by a thread that had stepped an
    instance freed elsewhere waited at its first parallel region for workers it does not have. The handler now lives in
    grains_fork_guard.so, which stays loaded: one for the process, also with the FMU extracted twice (the same archive
    under two names), while the FMU binaries are unloaded. The timeout only ends such a hang; the run takes seconds."""
    path = fmu_path("aggregation", version)
    twice = tmp_path / f"again-{path.name}"
    shutil.copy(path, twice)
    r = host_process(AFTER_UNLOAD, path, twice, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["guards", "1", "binaries", "0", "child", "5", "parent", "0"], r.stdout
