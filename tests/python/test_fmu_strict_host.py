"""The FMUs in a host other than fmpy: strict_host.cpp, compiled here, calls FMI 2 and FMI 3 in the standards'
order (setup, parameters, Initialization Mode with its outputs read, steps of varying size, Terminate, Reset, Free),
with every call required to return OK and no message of warning or worse. Its outputs are the runner's, bit for
bit, and do not depend on how the resource location is written (file URIs with and without a trailing slash,
localhost, percent-encoded spaces and non-ASCII, FMI 3's native path), on a null logger, or on a reset."""
import shutil
import subprocess
import urllib.parse
import zipfile

import fmpy
import pytest

from fmu_host import Unit, extracted, fmu_path
from test_fmu_matches_runner import WALL_CLOCK, runner_observables

PLATFORM = {2: "linux64", 3: "x86_64-linux"}

# (model, particle count or None, real parameters and inputs, internal steps per communication step, in turn)
CASES = [
    ("collision", None, {"contact.restitution": 0.8}, [1, 3, 2, 5, 9] * 8),   # the contact falls in steps 100-150
    ("aggregation", 200, {"contact.restitution": 0.3}, [20, 50, 30, 100]),
    ("consolidation", 200, {"cell.pressure": 0.5}, [50, 20, 80]),
]


@pytest.fixture(scope="module")
def strict_host(tmp_path_factory, root):
    compiler = shutil.which("g++") or shutil.which("c++")
    assert compiler, "no C++ compiler (runner/setup.sh installs g++)"
    exe = tmp_path_factory.mktemp("strict-host") / "strict_host"
    subprocess.run([compiler, "-std=c++20", "-O1", "-Wall", "-Wextra", "-Werror", "-I", str(root / "fmu"),
                    str(root / "tests" / "python" / "strict_host.cpp"), "-ldl", "-o", str(exe)], check=True)
    return exe


def file_uri(directory):
    return "file://" + urllib.parse.quote(str(directory))


class Run:
    """The strict host's rows (one per communication point, the first in Initialization Mode) for one FMU."""

    def __init__(self, host, model, version, directory=None):
        path = fmu_path(model, version)
        self.md = fmpy.read_model_description(str(path))
        self.version, self.directory = version, directory or extracted(path)
        self.refs = {v.name: v.valueReference for v in self.md.modelVariables}
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output" and not v.dimensions
                        and not v.name.endswith(WALL_CLOCK)]
        self.host = host

    def __call__(self, steps, location=None, count=None, sets=None, flags=()):
        library = f"{self.directory}/binaries/{PLATFORM[self.version]}/{self.md.coSimulation.modelIdentifier}.so"
        location = file_uri(f"{self.directory}/resources") + "/" if location is None else location
        args = [str(self.host), str(self.version), library, location, self.md.guid,
                "--out", ",".join(str(self.refs[n]) for n in self.outputs), "--steps", ",".join(map(repr, steps))]
        if count is not None:
            args += ["--count", f"{self.refs['particles.count']}={count}"]
        for name, value in (sets or {}).items():
            args += ["--set", f"{self.refs[name]}={value!r}"]
        done = subprocess.run(args + list(flags), capture_output=True, text=True)
        assert done.returncode == 0, f"strict host, FMI {self.version}, location {location!r}: {done.stderr}"
        return [[float.fromhex(x) for x in line.split(",")[1:]] for line in done.stdout.splitlines()]


def same(a, b):
    """Bit for bit, NaN equal to NaN (aggregation_time before the aggregation)."""
    return len(a) == len(b) and all(x == y or (x != x and y != y) for x, y in zip(a, b))


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("model,count,sets,chunks", CASES, ids=[c[0] for c in CASES])
def test_strict_host_outputs_equal_the_runner(grains_bin, root, tmp_path, strict_host, version, model, count, sets,
                                              chunks):
    run = Run(strict_host, model, version)
    overrides = dict(sets, **({"particles.count": count} if count else {}))
    # dt as the FMU reports it (a calculated parameter): the steps are whole multiples of it, as a host computes them
    unit = Unit(fmu_path(model, version)).initialize(overrides)
    dt = unit.get("time.dt")
    unit.free()
    rows = run([k * dt for k in chunks], count=count, sets=sets)

    runner = runner_observables(grains_bin, root, tmp_path, model, overrides, 1, sum(chunks))
    points = [0]
    for k in chunks:
        points.append(points[-1] + k)
    assert len(rows) == len(points)
    assert [row[run.outputs.index("step")] for row in rows] == points
    compared = 0
    for j, name in enumerate(run.outputs):
        if name == "step":
            continue
        steps, values = runner[name]
        assert same([row[j] for row in rows], [values[p] for p in points]), f"{name} differs from the runner"
        compared += 1
    assert compared >= 15


@pytest.mark.parametrize("version", [2, 3])
def test_strict_host_takes_resource_locations_as_hosts_write_them(tmp_path, strict_host, version):
    # A folder name with a space, a non-ASCII letter and a '%' (percent-encoded in the URIs)
    directory = tmp_path / "grains fmus é 100%" / "collision"
    zipfile.ZipFile(fmu_path("collision", version)).extractall(directory)
    run = Run(strict_host, "collision", version, directory)
    steps = [0.002, 0.004, 0.001, 0.0037, 0.002]
    resources = directory / "resources"
    locations = [file_uri(resources), file_uri(resources) + "/", "file://localhost" + urllib.parse.quote(str(resources)) + "/",
                 "file:" + urllib.parse.quote(str(resources)) + "/", ""]
    if version == 3:   # FMI 3 passes a native path, ending with a separator
        locations += [str(resources) + "/", str(resources)]
    expected = run(steps, locations[0])
    assert len(expected) == len(steps) + 1
    for location in locations[1:]:
        assert run(steps, location) == expected, location
    assert run(steps, flags=["--null-logger"]) == expected
    assert run(steps, flags=["--no-terminate"]) == expected
    assert run(steps, flags=["--reset-and-repeat"]) == expected + expected
