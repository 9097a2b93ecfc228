"""A host that steps an instance on one thread and frees it from another, then unloads the library (fmpy unloads
it at every free) and loads it again: no thread is left behind per cycle, and nothing crashes."""
import pytest

from fmu_host import host_process

# A host thread that stays (a worker of the host's own) steps; the main thread frees. In a subprocess: a crash
# fails the test, not the suite.
HOST = """
import os, queue, sys, threading
from fmu_host import Unit, fmu_path
jobs, done = queue.Queue(), queue.Queue()
threading.Thread(target=lambda: [done.put(job()) for job in iter(jobs.get, None)], daemon=True).start()
threads = []
for cycle in range(6):
    unit = Unit(fmu_path("aggregation", int(sys.argv[1])), name=f"u{cycle}")
    unit.initialize({"particles.count": 300, "run.threads": 2})
    jobs.put(lambda: unit.step(5 * unit.get("time.dt")))
    done.get()
    unit.free()   # fmi*FreeInstance, then fmpy unloads the library
    threads.append(len(os.listdir("/proc/self/task")))
print(threads)
"""


@pytest.mark.parametrize("version", [2, 3])
def test_freeing_from_another_thread_and_unloading_leaves_no_thread_and_no_crash(version):
    """The stepping thread's OpenMP workers outlive the free (only the freeing thread's are released). Unloading the
    FMU unloaded libgomp under them, left waiting in unmapped code: one thread more per cycle (4, 5, ..., 9), and a
    segmentation fault in the fifth cycle of one run of five. libgomp now stays loaded, and the next load's steps
    reuse that thread's workers."""
    r = host_process(HOST, version)
    assert r.returncode == 0, r.stderr[-2000:]
    threads = eval(r.stdout)
    assert len(threads) == 6 and len(set(threads)) == 1, threads
