"""A host whose OpenMP runtime starts fewer threads than the scene asks for (OMP_THREAD_LIMIT, OMP_DYNAMIC, or a
doStep called inside the host's own parallel region) gets the results of the scene's thread count, bit for bit."""
import pytest

from fmu_host import host_process

# The packaged aggregation scene: 1000 particles on two threads; 600 steps bring the first contacts.
HOST = """
import sys
from fmu_host import Unit, fmu_path
unit = Unit(fmu_path("aggregation", int(sys.argv[1]))).initialize()
h = 20 * unit.get("time.dt")
for _ in range(30):
    unit.step(h)
print(unit.get("run.threads"), unit.get("contacts"))
print(sorted((k, repr(v)) for k, v in unit.outputs().items() if k != "cvode_seconds"))   # that one is wall time
"""


@pytest.mark.parametrize("version", [2, 3])
def test_one_openmp_thread_for_a_two_thread_scene_gives_the_two_thread_results(version):
    """With one thread for the scene's two, the second thread's share of the contact forces was never evaluated:
    27 contacts after 600 steps against 11 (particles ran into each other unopposed)."""
    free = host_process(HOST, version)
    limited = host_process(HOST, version, env={"OMP_THREAD_LIMIT": "1"})
    assert free.returncode == 0 and limited.returncode == 0, free.stderr + limited.stderr
    threads, contacts = free.stdout.split("\n")[0].split()
    assert threads == "2" and float(contacts) > 0, free.stdout   # two threads asked for, and contacts to get wrong
    assert limited.stdout == free.stdout
