"""runner/plot.py refuses a damaged run file in one line naming the file, the dataset or attribute, the value and what
is allowed, with exit status 2 and no image (not a traceback, nor a complete file's series cut short or its steps
rotated drawn without a word). The files are written here with h5py in grains' layout."""
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT


def run_file(path, status="complete", scene=""):
    """A run file with kinetic_energy and contacts recorded at steps 0, 10, 20, 30, its status `status`."""
    with h5py.File(path, "w") as f:
        f.create_group("parameters").attrs["scene.toml"] = f'[scene]\nname = "scene"\n{scene}'
        f.create_group("grains").attrs["status"] = np.bytes_(status)
        f.create_group("observables").attrs["complete_to_step"] = 30
        for name in ("kinetic_energy", "contacts"):
            f[f"observables/{name}/step"] = np.arange(4) * 10
            f[f"observables/{name}/time"] = np.arange(4) * 0.5
            f[f"observables/{name}/value"] = np.arange(1.0, 5.0)
    return path


def recreate(f, name, data):
    del f[name]
    f[name] = data


DAMAGE = {   # name -> (change to the file, words the refusal must hold)
    "step_scalar": (lambda f: recreate(f, "observables/kinetic_energy/step", 5),
                    ["observables/kinetic_energy/step has shape ()", "need 1 dimension(s)"]),
    "value_scalar": (lambda f: recreate(f, "observables/contacts/value", 1.0),
                     ["observables/contacts/value has shape ()", "need 1 or 2 dimension(s)"]),
    "value_short": (lambda f: recreate(f, "observables/kinetic_energy/value", np.arange(2.0)),
                    ["observables/kinetic_energy/value holds 2 row(s), observables/kinetic_energy/step 4",
                     "its status is 'complete'"]),
    "time_long": (lambda f: recreate(f, "observables/contacts/time", np.arange(5.0)),
                  ["observables/contacts/time holds 5 row(s)", "step 4"]),
    "steps_rotated": (lambda f: f["observables/contacts/step"].__setitem__(slice(None), [10, 20, 30, 0]),
                      ["observables/contacts/step is not strictly increasing (30 at record 2, then 0)"]),
    "scene_not_toml": (lambda f: f["parameters"].attrs.__setitem__("scene.toml", "[scene\nname = "),
                       ["parameters@scene.toml", "is not TOML"]),
    "aggregation_time_strings": (lambda f: f.__setitem__("observables/aggregation_time/value", np.array([b"x"])),
                                 ["observables/aggregation_time/value holds values of type |S1", "need numbers"]),
    "complete_to_step_text": (lambda f: f["observables"].attrs.__setitem__("complete_to_step", "abc"),
                              ["observables@complete_to_step is 'abc'", "a number"]),
}


@pytest.mark.parametrize("name", DAMAGE)
def test_a_damaged_run_file_is_refused_in_one_line(tmp_path, name):
    path = run_file(tmp_path / f"{name}.h5")
    with h5py.File(path, "r+") as f:
        DAMAGE[name][0](f)
    out = tmp_path / "p.png"
    r = subprocess.run([sys.executable, ROOT / "runner" / "plot.py", path, "-o", out], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr and r.stderr.count("\n") == 1, (r.returncode, r.stderr)
    assert r.stderr.startswith(f"plot.py: '{path}': ") and all(w in r.stderr for w in DAMAGE[name][1]), r.stderr
    assert not out.exists()


@pytest.mark.parametrize("name", ["value_short", "time_long"])
def test_a_run_still_writing_its_file_is_drawn_to_the_rows_every_part_holds(tmp_path, name):
    """While grains writes the file (status running, or a killed run's), a series' parts may differ in length by the
    rows being appended: drawn as far as all hold, as before."""
    path = run_file(tmp_path / f"{name}.h5", status="running")
    with h5py.File(path, "r+") as f:
        DAMAGE[name][0](f)
    r = subprocess.run([sys.executable, ROOT / "runner" / "plot.py", path, "-o", tmp_path / "p.png"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and (tmp_path / "p.png").stat().st_size > 0, r.stderr
