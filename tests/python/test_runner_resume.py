"""`grains resume`: a run stopped by a signal or killed continues from the checkpoint in its output file
and ends with the records of the run that was never stopped."""
import fcntl
import os
import shutil
import signal
import socket
import stat
import struct
import subprocess
import time

import h5py
import numpy as np
import pytest

from h5text import text
from interrupt import interrupted, run


def records(path):
    """Every observable's (step, value) rows (grains consolidate's trace, grains/trace/*, too), every frame's
    (step, value) rows, and the collision table."""
    with h5py.File(path) as f:
        out = {f"observables/{k}": (s["step"][()], s["value"][()]) for k, s in f["observables"].items()}
        for k, s in f["grains"].get("trace", {}).items():
            out[f"trace/{k}"] = (s["step"][()], s["value"][()])
        for name, s in f["particles/all"].items():
            if name != "box":
                out[f"particles/{name}"] = (s["step"][()], s["value"][()])
        if "collisions" in f["grains"]:
            out["collisions"] = (None, f["grains/collisions"][()])
    return out


def status(path):
    with h5py.File(path) as f:
        return text(f["grains"].attrs.get("status", ""))


def killed_copy(whole, killed):
    """A copy of a finished run's file as a run killed after its last checkpoint leaves it: status 'running'."""
    shutil.copy(whole, killed)
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs["status"] = "running"
    return killed


def assert_same_records(whole, other):
    """Every record and frame equal, CVODE's own counters aside (they count from the resume)."""
    a, b = records(whole), records(other)
    assert a.keys() == b.keys()
    for name in a:
        if not name.startswith("observables/cvode"):
            assert np.array_equal(a[name][0], b[name][0]) and np.array_equal(a[name][1], b[name][1], equal_nan=True), name


def killed_programme(grains_bin, tmp_path, programme, keep_rows):
    """`grains consolidate` of programme (the scene, then its options) to its end as whole.h5 / whole.csv, and a
    copy of its file as a programme killed after its last checkpoint leaves it: no status, and a stage table of the
    rows keep_rows(rows) returns (rows: header, stages 0..last), named in the copy. Returns (whole, whole_table,
    killed, killed_table, rows)."""
    whole, whole_table = tmp_path / "whole.h5", tmp_path / "whole.csv"
    done = run(grains_bin, "consolidate", *programme[:1], "--out", whole, "--table", whole_table, *programme[1:])
    assert done.returncode == 0, done.stderr
    killed, killed_table = killed_copy(whole, tmp_path / "killed.h5"), tmp_path / "killed.csv"
    rows = whole_table.read_text().splitlines()
    killed_table.write_text("\n".join(keep_rows(rows)) + "\n")
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs["stage_table"] = killed_table.name
    return whole, whole_table, killed, killed_table, rows


def cohesionless_programme(root, top_pressure, stage_budget):
    """100 cohesionless disks loaded from P / K_N = 1e-5 to top_pressure, checkpointed every 1000 steps."""
    return [root / "models/cohesionless.toml", "--set", "particles.count=100", "--set", "programme.load=true",
            "--set", "programme.unload=false", "--set", f"programme.top_pressure={top_pressure}", "--set",
            f"programme.stage_budget={stage_budget}", "--set", "output.checkpoint_every=1000", "--set", "run.threads=1",
            "--quiet"]


# A small self-gravitating cloud with the collision log, checkpointed every 3000 of its 15,527 steps.
CLOUD = ["--set", "particles.count=200", "--set", "output.snapshots_every=2000", "--set", "output.checkpoint_every=3000",
         "--set", "analysis.collision_log=true", "--set", "run.threads=1", "--quiet"]


def test_a_killed_run_resumes_from_its_last_checkpoint_to_the_records_of_an_unbroken_run(grains_bin, root, tmp_path):
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", root / "models/aggregation.toml", "--out", whole, *CLOUD).returncode == 0
    # A run killed after its last checkpoint: no status, and records past the checkpoint that the resumed run
    # must drop and write again (spoiled here, so that keeping them would show).
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        del f["grains/collisions"]
        last = int(max(f["grains/checkpoint_0"].attrs["step"], f["grains/checkpoint_1"].attrs["step"]))
        assert last == 15000
        for name in ("observables/kinetic_energy", "particles/all/position"):
            later = f[name]["step"][()] > last
            assert later.any()
            f[name]["value"][later] = 0.0
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert "resumed      at step 15000" in resumed.stdout and status(killed) == "complete"
    assert "collisions" in records(whole)
    assert_same_records(whole, killed)
    a = records(whole)
    with open(killed.with_suffix(".xdmf")) as x:   # the ParaView companion lists every frame again
        assert x.read().count("<Grid Name=\"frame") == len(a["particles/position"][0]) == 9


def test_a_resume_with_other_gravity_kernels_says_so(grains_bin, root, tmp_path):
    """The gravity kernels' sums differ between instruction sets in their last bits (the pair loop's do not): a
    self-gravitating run resumed where other kernels are picked (another processor, GRAINS_GRAVITY_ISA) is not the
    unbroken run bit for bit, which the resume says, on stderr and in the file's warnings. With the same kernels it
    says nothing and ends with the unbroken run's records."""
    import os
    avx2 = subprocess.run([grains_bin, "check", root / "models/aggregation.toml"], capture_output=True, text=True,
                          env={**os.environ, "GRAINS_GRAVITY_ISA": "avx2"})
    if avx2.returncode != 0:
        pytest.skip("this processor runs the portable gravity kernels only")
    portable = {**os.environ, "GRAINS_GRAVITY_ISA": "portable"}
    whole = tmp_path / "whole.h5"
    done = subprocess.run([grains_bin, "run", root / "models/aggregation.toml", "--out", whole, *CLOUD], env=portable)
    assert done.returncode == 0
    with h5py.File(whole) as f:
        assert text(f["grains/checkpoint_0"].attrs["gravity_kernels"]) == "portable"
    said = "gravity kernels, where the run used portable"
    for env, warned in (({**os.environ, "GRAINS_GRAVITY_ISA": "avx2"}, True), (portable, False)):
        killed = killed_copy(whole, tmp_path / f"killed-{warned}.h5")
        resumed = subprocess.run([grains_bin, "resume", killed, "--quiet"], capture_output=True, text=True, env=env)
        assert resumed.returncode == 0, resumed.stderr
        assert (f"resumed at step 15000 with the avx2 {said}" in resumed.stderr) == warned, resumed.stderr
        with h5py.File(killed) as f:
            rows = [text(w) for w in f["grains/warnings"][()]]
        assert any(said in w for w in rows) == warned, rows
        if not warned:
            assert_same_records(whole, killed)


def test_a_file_whose_series_lost_rows_is_refused_not_resumed_out_of_step(grains_bin, root, tmp_path):
    """A series whose values are shorter than its steps (a damaged file) is refused, not extended with fill values and
    resumed to 'complete', its steps and values no longer matching."""
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", root / "models/aggregation.toml", "--out", whole, *CLOUD).returncode == 0
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        f["observables/kinetic_energy/value"].resize((3,))
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode != 0
    assert "kinetic_energy/value holds 3 rows" in resumed.stderr and "damaged" in resumed.stderr, resumed.stderr


def checkpointed_gas(grains_bin, root, whole):
    """64 frictional grains, 450 steps, a checkpoint every 100: step 300's in checkpoint_0, step 400's in checkpoint_1."""
    made = run(grains_bin, "run", root / "models/gas-friction.toml", "--out", whole, "--set", "particles.count=64",
               "--set", "time.steps=450", "--set", "output.checkpoint_every=100", "--set", "run.threads=1", "--quiet")
    assert made.returncode == 0, made.stderr
    return whole


def patch_header(path, dataset, pattern, at, value, length=1024):
    """Sets byte `at` of `pattern`, found once in `dataset`'s object header (its first `length` bytes), to `value`: a
    flipped bit in its metadata."""
    with h5py.File(path, "r") as f:
        header = h5py.h5o.get_info(f[dataset].id).addr
    data = bytearray(path.read_bytes())
    window = bytes(data[header : header + length])
    assert window.count(pattern) == 1, dataset
    data[header + window.index(pattern) + at] = value
    path.write_bytes(bytes(data))


# Found by tests/fuzz/corrupt_resume.py (one flipped bit each): HDF5 1.10.8 took the damaged layout or type as it
# read and `grains resume` died of SIGSEGV: in H5Dset_extent (a chunk 1024 rows long made 67,109,888 in the layout,
# its stored chunks still 1024; one of 42 made 554), or in the type conversion of a write (a float of 2112 bits of precision in its 64)
# or of a read (an integer whose bits start past its 8 bytes).
@pytest.mark.parametrize("dataset, pattern, at, value, defect", [
    ("particles/all/box/offset/value", struct.pack("<III", 1024, 3, 8), 3, 0x04,
     "/particles/all/box/offset/value has chunks of 67109888 rows, where grains writes at most 1024"),
    # within the rows grains writes, 42 made 554: the stored chunks' bytes are not the layout's
    ("particles/all/position/value", struct.pack("<IIII", 42, 64, 3, 8), 1, 0x02,
     "/particles/all/position/value has chunks of 554 x 64 x 3 values (850944 bytes) in its layout, but its first "
     "stored chunk holds 64512 bytes"),
    ("observables/momentum_y/value", struct.pack("<HHBBBBI", 0, 64, 52, 11, 0, 52, 1023), 3, 0x08,
     "/observables/momentum_y/value has a float of 8 bytes, 2112 bits of precision at bit 0, where grains writes a "
     "float of 8 bytes, 64 bits of precision at bit 0"),
    ("observables/rotational_energy/step", struct.pack("<B3sIHH", 0x10, b"\x08\0\0", 8, 0, 64), 8, 0x20,
     "/observables/rotational_energy/step has an integer of 8 bytes, 64 bits of precision at bit 32"),
])
def test_a_file_whose_layout_or_type_is_damaged_is_refused_not_crashed_on(grains_bin, root, tmp_path, dataset, pattern, at,
                                                                          value, defect):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    resumed = run(grains_bin, "resume", killed, "--quiet")   # undamaged, it resumes
    assert resumed.returncode == 0, resumed.stderr
    killed = killed_copy(whole, tmp_path / "killed.h5")
    patch_header(killed, dataset, pattern, at, value)
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert f"'{killed}': {defect}" in resumed.stderr and "damaged" in resumed.stderr, resumed.stderr


# Found by tests/fuzz/corrupt_resume.py (seeds 6 and 18): one flipped bit made a series' extent far larger than its
# chunks, and cutting it back (H5Dset_extent) visited each chunk of it: the resume never ended, nor stopped at SIGTERM.
@pytest.mark.parametrize("dataset, pattern, at, value, shape", [
    ("observables/momentum_y/time", struct.pack("<QQ", 6, 2**64 - 1), 7, 0x10, "1152921504606846982"),
    ("particles/all/box/offset/value", struct.pack("<QQQQ", 2, 3, 2**64 - 1, 2**64 - 1), 14, 0x08, "2 x 2251799813685251"),
])
def test_a_series_whose_extent_is_damaged_past_the_file_is_refused_not_cut_back_without_end(grains_bin, root, tmp_path,
                                                                                           dataset, pattern, at, value,
                                                                                           shape):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    patch_header(killed, dataset, pattern, at, value, length=256)
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert (f"'{killed}': /{dataset} has a shape of {shape}, more than the file's " in resumed.stderr
            and "damaged" in resumed.stderr), resumed.stderr


def set_attribute(slot, name, value):
    return lambda f: f[f"grains/{slot}"].attrs.__setitem__(name, value)


def set_checkpoint_1_attribute(name, value):
    return set_attribute("checkpoint_1", name, value)


def checkpoint_1_of_two_axes(f):
    state, attrs = f["grains/checkpoint_1"][()], dict(f["grains/checkpoint_1"].attrs)
    del f["grains/checkpoint_1"]
    f.create_dataset("grains/checkpoint_1", data=state[: len(state) // 2 * 2].reshape(-1, 2))
    f["grains/checkpoint_1"].attrs.update(attrs)
    return f"the shape {len(state) // 2} x 2"


def checkpoint_1_a_group(f):
    del f["grains/checkpoint_1"]
    f.create_group("grains/checkpoint_1").attrs.update({"valid": 1.0, "step": 400.0})


# A checkpoint's attributes are checked before they are converted (step 1e300 would read as step -9223372036854775808,
# a thread count of 1e12 or NaN convert with undefined behaviour), and an attribute or a slot of another shape than
# grains writes is not read into a buffer sized for grains' own (HDF5 crashes; the child that reads first says it is
# grains). Such a slot is passed over as one whose checksum fails is, not a refusal of the file whatever the other
# slot holds.
CP1 = "of /grains/checkpoint_1"
DAMAGED_SLOT = [
    (set_checkpoint_1_attribute("step", 1e300),
     f"attribute 'step' {CP1} is 1e+300, where grains writes a whole number in [0, 1000000000000000]"),
    (set_checkpoint_1_attribute("step", 400.5),
     f"attribute 'step' {CP1} is 400.5, where grains writes a whole number in [0, 1000000000000000]"),
    (set_checkpoint_1_attribute("threads", 1e12),
     f"attribute 'threads' {CP1} is 1000000000000, where grains writes a whole number in [0, 1048576]"),
    (set_checkpoint_1_attribute("threads", np.nan), f"attribute 'threads' {CP1} is nan, where grains writes a whole number"),
    (set_checkpoint_1_attribute("warnings", 1e15), f"attribute 'warnings' {CP1} is 1000000000000000, where grains writes a "
                                                   "whole number in [-1, 0]"),
    (set_checkpoint_1_attribute("time", np.inf), f"attribute 'time' {CP1} is inf, where grains writes a number in"),
    (set_checkpoint_1_attribute("step", np.array([400.0, 1.0])),
     f"attribute 'step' {CP1} holds a float of 8 bytes, 64 bits of precision at bit 0 in the shape 2, where grains writes "
     "one number (a scalar)"),
    (checkpoint_1_of_two_axes, "/grains/checkpoint_1 holds values of {}, where grains writes one axis of bytes"),
    (checkpoint_1_a_group, "opening dataset /grains/checkpoint_1 failed"),
]
DAMAGED_SLOT_IDS = ["step-1e300", "step-fraction", "threads-1e12", "threads-nan", "warnings-1e15", "time-inf",
                    "step-array", "slot-of-two-axes", "slot-a-group"]


@pytest.mark.parametrize("damage, message", DAMAGED_SLOT, ids=DAMAGED_SLOT_IDS)
def test_a_checkpoint_whose_attributes_or_shape_are_not_what_grains_writes_gives_way_to_the_other(grains_bin, root,
                                                                                                  tmp_path, damage, message):
    """Step 400's checkpoint damaged: the resume goes on from step 300's, as from a file where step 400's is not valid,
    and says so, naming the slot and what is wrong with it."""
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed, invalid = killed_copy(whole, tmp_path / "killed.h5"), killed_copy(whole, tmp_path / "invalid.h5")
    with h5py.File(killed, "r+") as f:
        message = message.format(damage(f))
    with h5py.File(invalid, "r+") as f:
        f["grains/checkpoint_1"].attrs["valid"] = 0.0
    resumed = subprocess.run([grains_bin, "resume", str(killed)], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 0, (resumed.returncode, resumed.stderr)
    place = "" if "'step'" in message or "opening" in message else " (step 400)"   # where the step reads
    reason = f"HDF5 output '{killed}': {message}" if "opening" in message else message   # HDF5's failures name the file
    assert (f"warning: '{killed}': the checkpoint in /grains/checkpoint_1{place} is damaged ({reason}" in resumed.stderr
            and ") and is passed over; resuming from the one in /grains/checkpoint_0 (step 300)\n" in resumed.stderr
            ), resumed.stderr
    assert "resumed      at step 300" in resumed.stdout
    assert run(grains_bin, "resume", invalid, "--quiet").returncode == 0
    assert_same_records(invalid, killed)
    assert_same_records(whole, killed)


def test_a_checkpoint_whose_header_is_damaged_gives_way_to_the_other_and_is_set_aside(grains_bin, root, tmp_path):
    """Found by tests/fuzz/corrupt_resume.py once a damaged slot gave way: one flipped bit made the rank of an attribute's
    shape 64, which HDF5 1.10.8 fails to decode in any lookup of the slot's attributes, and in freeing the slot, which it
    did after lowering the slot's reference count (the file changed, the resume refused). The slot is set aside instead,
    its space left unused."""
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    patch_header(killed, "grains/checkpoint_1", b"observables_at_step\0", 49, 0x40)   # the rank of its shape
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 0, (resumed.returncode, resumed.stderr)
    assert (f"warning: '{killed}': the checkpoint in /grains/checkpoint_1 is damaged (HDF5 output '{killed}': looking up "
            "attribute valid failed" in resumed.stderr and "resuming from the one in /grains/checkpoint_0 (step 300)\n"
            in resumed.stderr), resumed.stderr
    assert_same_records(whole, killed)
    with h5py.File(killed) as f:   # the slot made anew by the resumed run's last checkpoint
        assert f["grains/checkpoint_1"].attrs["valid"] == 1 and f["grains/checkpoint_1"].attrs["step"] == 400
        f["grains/checkpoint_1"][()]


@pytest.mark.parametrize("damage, message", DAMAGED_SLOT, ids=DAMAGED_SLOT_IDS)
def test_a_file_whose_checkpoints_are_both_damaged_is_refused_naming_each(grains_bin, root, tmp_path, damage, message):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        message = message.format(damage(f))
        set_attribute("checkpoint_0", "threads", 1e12)(f)
    before = killed.read_bytes()
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert (f"'{killed}': nothing to resume from: " in resumed.stderr and message in resumed.stderr
            and "the checkpoint in /grains/checkpoint_0 (step 300) is damaged (attribute 'threads' of "
                "/grains/checkpoint_0 is 1000000000000, where grains writes a whole number in [0, 1048576])"
            in resumed.stderr), resumed.stderr
    assert "crashed" not in resumed.stderr and killed.read_bytes() == before


# Whether the records at the checkpoint's step are the unbroken run's follows from the scene's cadences: a flag saying
# otherwise would have the record at that step dropped for good.
@pytest.mark.parametrize("damage, message", [
    (set_checkpoint_1_attribute("observables_at_step", 0.0),
     "its checkpoint at step 400 has the attribute 'observables_at_step' = 0, where output.observables_every = 100 makes it 1"),
    (set_checkpoint_1_attribute("frame_at_step", 1.0),
     "its checkpoint at step 400 has the attribute 'frame_at_step' = 1, where output.snapshots_every = 1000 makes it 0"),
], ids=["observables_at_step-0", "frame_at_step-1"])
def test_a_checkpoint_whose_record_flags_contradict_the_cadences_is_refused(grains_bin, root, tmp_path, damage, message):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        damage(f)
    before = killed.read_bytes()
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert f"'{killed}': {message}" in resumed.stderr and "damaged" in resumed.stderr, resumed.stderr
    assert "crashed" not in resumed.stderr and killed.read_bytes() == before


def replace_dataset(path, make):
    """Replaces the dataset at path by make(its values)."""
    def damage(f):
        values = f[path][()]
        del f[path]
        make(f, values)
    return damage


# Each refused naming the object: a series hard-linked to another (both appended into one dataset), steps out of order,
# a series or the box's edges removed (made anew with the resumed rows alone) and a file without /h5md would resume to
# "complete"; others would be refused without the object's path, or as a changed particle file.
@pytest.mark.parametrize("damage, message", [
    (lambda f: (f.__delitem__("observables/kinetic_energy"), f.__setitem__("observables/kinetic_energy",
                                                                           f["observables/rotational_energy"])),
     "/observables/rotational_energy/value is the same dataset as /observables/kinetic_energy/value (two names of one "
     "object), where grains writes each series its own"),
    (lambda f: f["observables/kinetic_energy/step"].__setitem__(slice(None), f["observables/kinetic_energy/step"][()][::-1]),
     "/observables/kinetic_energy/step is not increasing: its row 1 holds step 400 after step 450"),
    (lambda f: f.__delitem__("observables/kinetic_energy"),
     "/observables/kinetic_energy is missing, where the run records it with its other observables"),
    (lambda f: f.__delitem__("particles/all/box/edges"),
     "/particles/all/box/edges is missing, where grains writes it with every frame"),
    (lambda f: f.__delitem__("particles/all/velocity"),
     "/particles/all/velocity is missing, where grains writes it with every frame"),
    (lambda f: f.__delitem__("h5md"), "/h5md, the H5MD root group grains writes first, is missing"),
    (lambda f: f.__delitem__("observables/kinetic_energy/step"),
     "opening dataset /observables/kinetic_energy/step failed"),
    (lambda f: f.create_group("observables/bogus").create_dataset("value", data=np.zeros(3)),
     "opening dataset /observables/bogus/step failed"),
    (replace_dataset("observables/kinetic_energy/value", lambda f, v: f.create_dataset("observables/kinetic_energy/value",
                                                                                     data=v)),
     "/observables/kinetic_energy/value is not stored in chunks, where grains writes a series in chunked rows"),
    (replace_dataset("particles/all/position/value", lambda f, v: f.create_dataset(
        "particles/all/position/value", data=np.concatenate([v, v[:, :, :1]], 2), maxshape=(None, None, None), chunks=True)),
     "/particles/all/position/value holds floats of the shape 2 x 64 x 4, where grains writes floats of the shape frames "
     "x particles x 3"),
    (replace_dataset("particles/all/radius/value", lambda f, v: f.create_dataset(
        "particles/all/radius/value", data=v.astype(np.int64), maxshape=(None, None), chunks=True)),
     "/particles/all/radius/value holds non-floats of the shape 2 x 64, where grains writes floats of the shape frames x "
     "particles"),
    (lambda f: f["particles/all/position/value"].resize(10, axis=1),
     "the run's first frame (/particles/all/position/value) holds 10 particles, where the stored scene builds 64"),
], ids=["series-linked", "steps-out-of-order", "series-removed", "edges-removed", "velocity-removed", "h5md-removed",
        "step-removed", "extra-group", "contiguous-series", "position-of-4-columns", "integer-radius", "fewer-particles"])
def test_a_file_whose_series_do_not_go_together_is_refused_naming_the_object(grains_bin, root, tmp_path, damage, message):
    """Refused as it was, byte for byte: the checks of the series' steps, of the series as they go together and of
    the observables the run records run before the series are cut back, else a file refused would have lost its
    records after the checkpoint, its other checkpoint slot and its later warnings."""
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs.modify("status", np.bytes_(b"interrupted at step 450"))   # frames kept as they are
        damage(f)
    before = killed.read_bytes()
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert message in resumed.stderr and str(killed) in resumed.stderr, resumed.stderr
    assert killed.read_bytes() == before


def test_a_programme_refused_for_its_file_leaves_its_file_and_stage_table_as_they_were(grains_bin, root, tmp_path):
    """The stage table was cut back to the checkpoint's stage before the HDF5 file was checked, and the file cut back as
    it was checked: a file lacking an observable the programme records was refused with both already cut."""
    _, _, killed, killed_table, rows = killed_programme(grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000),
                                                        lambda rows: rows)
    with h5py.File(killed, "r+") as f:
        stage = int(max(f["grains/checkpoint_0"].attrs["stage"], f["grains/checkpoint_1"].attrs["stage"]))
        assert stage + 2 < len(rows)   # the resume would cut the table back
        del f["observables/quench_drag"]
    file_before, table_before = killed.read_bytes(), killed_table.read_bytes()
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert (f"'{killed}': /observables/quench_drag is missing, where the run records it with its other observables"
            in resumed.stderr), resumed.stderr
    assert killed.read_bytes() == file_before and killed_table.read_bytes() == table_before
    # The table's rows kept are written aside before the file is checked (a table that cannot be written then
    # refuses before the file is cut): a refused file leaves nothing of them behind.
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".resuming")) == []


def test_a_checkpoint_slot_whose_layout_is_damaged_is_not_written_over(grains_bin, root, tmp_path):
    """A resumed run writing its next checkpoint over the slot not holding the newest valid one (H5Dset_extent,
    H5Dwrite) would take it as its layout says: its chunks of 65,536 bytes made 67,174,400 by one flipped bit (as in
    the series above), H5Dwrite's Fletcher-32 sums that many and the resume dies of SIGSEGV. The resume keeps only the
    slot it resumed from and makes the other anew, so such a slot is never written: the resume ends as the unbroken
    run, its slots laid out as grains writes them."""
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:   # killed while writing step 400's checkpoint: the resume writes it again
        f["grains/checkpoint_1"].attrs["valid"] = 0.0
    patch_header(killed, "grains/checkpoint_1", struct.pack("<II", 65536, 1), 3, 0x04)
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, (resumed.returncode, resumed.stderr)
    assert_same_records(whole, killed)
    with h5py.File(killed) as f:
        for k in ("checkpoint_0", "checkpoint_1"):
            if k in f["grains"]:
                assert f["grains"][k].chunks == (65536,), k
                f["grains"][k][()]   # reads back: its checksum holds


def flip_view_mapping(path, view, at, mask):
    """Flips bits `mask` of byte `at` of the XDMF view `view`'s mapping: a virtual dataset's layout message names an
    object of a global heap collection, which holds the mapping (a version byte, the count of entries in 8 bytes, the
    source's file and dataset names, then the source's and the view's selections)."""
    with h5py.File(path, "r") as f:
        header = h5py.h5o.get_info(f[view].id).addr
    data = bytearray(path.read_bytes())
    window = bytes(data[header : header + 16 + struct.unpack_from("<I", data, header + 8)[0]])   # a version 1 header
    layout = [k for k in range(len(window) - 10) if struct.unpack_from("<HH4xBB", window, k) == (8, 16, 4, 3)]
    assert len(layout) == 1, view   # message 8 (layout) of 16 bytes: version 4, class 3 (virtual)
    collection, index = struct.unpack_from("<QI", window, layout[0] + 10)
    assert data[collection : collection + 4] == b"GCOL"
    end = collection + struct.unpack_from("<Q", data, collection + 8)[0]
    at_object = collection + 16
    while at_object < end:   # each object: its index, reference count, 4 reserved bytes, size, then its bytes
        number, size = struct.unpack_from("<H6xQ", data, at_object)
        if number == index:
            assert at < size
            data[at_object + 16 + at] ^= mask
            path.write_bytes(bytes(data))
            return
        at_object += 16 + (size + 7) // 8 * 8
    raise AssertionError(f"{view}: no object {index} in the global heap collection at {collection}")


# Found by tests/fuzz/corrupt_resume.py (seeds 24, 22 and 29 of 1 to 30, one flipped bit each): HDF5 1.10.8 died inside
# its own decoding of a header, before any call returned: SIGFPE in H5Dopen2 at a series' layout message read in the
# wrong version (its chunk dimensions then held a 0), and, where the resume drops the XDMF views of the frames after its
# checkpoint (H5Ldelete decodes the header of what it deletes), SIGSEGV at a view's mapping whose count of entries was
# 2^62 + 1, or a fortified abort (buffer overflow) at a selection in it. A child process reads the file first, and
# tells the refusal which object it was reading: the damaged one.
@pytest.mark.parametrize("damaged_object, damage, signal_name", [
    ("observables/angular_momentum_z/time",
     lambda path, name: patch_header(path, name, struct.pack("<HH4xBBB", 8, 24, 3, 2, 2), 8, 2, length=256), "SIGFPE"),
    ("grains/xdmf/mass/1", lambda path, name: flip_view_mapping(path, name, 8, 0x40), "SIGSEGV"),
    ("grains/xdmf/velocity/1", lambda path, name: flip_view_mapping(path, name, 107, 0x80), "SIGABRT"),
], ids=["chunk layout", "view mapping count", "view selection"])
def test_a_file_hdf5_dies_reading_is_refused_not_crashed_on(grains_bin, root, tmp_path, damaged_object, damage,
                                                            signal_name):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    damage(killed, damaged_object)
    damaged = killed.read_bytes()
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert resumed.stderr == (f"error: '{killed}': HDF5 crashed ({signal_name}) reading /{damaged_object}: the file is "
                              "damaged; not resumed\n"), resumed.stderr
    assert killed.read_bytes() == damaged   # refused before it was opened to be written


def test_a_damaged_view_of_a_frame_the_resume_keeps_does_not_stop_it(grains_bin, root, tmp_path):
    """The resume only looks up the XDMF views of the frames it keeps (frame 0, before step 400's checkpoint): the
    child reads the views of the frames a resume may drop, not these (two such flips were resumed before the child)."""
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    flip_view_mapping(killed, "grains/xdmf/mass/0", 8, 0x40)
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert status(killed) == "complete"


def view_header(path, view):
    with h5py.File(path, "r") as f:
        return h5py.h5o.get_info(f[view].id).addr


def views_match_their_frames(path):
    with h5py.File(path, "r") as f:
        frames = len(f["particles/all/position/value"])
        for name, group in f["grains/xdmf"].items():
            if name != "vertices":
                assert sorted(map(int, group)) == list(range(frames)), name
                for k in range(frames):
                    assert np.array_equal(group[str(k)][()][..., :f[f"particles/all/{name}/value"].shape[-1] if
                                                           f[f"particles/all/{name}/value"].ndim == 3 else None],
                                          f[f"particles/all/{name}/value"][k]), (name, k)


# A run killed while it writes a frame's XDMF views can leave their group unreadable ("bad heap free list", "address
# of object past end of allocation"; 3 of 45 kills of a 4096-sphere gas), where `grains resume` would stop for good,
# having cut the records back already. The views hold no data: a group that
# cannot be cut back is set aside, and the frames kept get new views.
def test_a_view_damaged_by_a_kill_in_a_frame_the_resume_drops_does_not_stop_it(grains_bin, root, tmp_path):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    data = bytearray(killed.read_bytes())
    header = view_header(killed, "grains/xdmf/velocity/1")   # frame 1, step 450: after the checkpoint of step 400
    assert data[header] == 1   # a version 1 object header ...
    data[header] = 9           # ... which HDF5 now refuses to decode (an error, not a crash)
    killed.write_bytes(bytes(data))
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert status(killed) == "complete"
    assert_same_records(whole, killed)
    views_match_their_frames(killed)


# The strings a resume reads back: grains wrote them as variable-length strings, each stored as a reference into HDF5's
# global heap, which HDF5 1.10.8 follows as it stands. A flipped bit of a reference's object index (found by
# tests/fuzz/corrupt_resume.py in the scene's) made `grains resume` die of SIGSEGV in H5HG_read, for the scene, the
# status, the scene's folder and the newest checkpoint's check sum of the scene alike.
RESUMED_STRINGS = [("parameters/scene.toml", None), ("grains", "status"), ("grains", "scene_directory"),
                   ("grains/checkpoint_0", "scene_check_sum"), ("grains/checkpoint_1", "scene_check_sum")]


def test_the_strings_a_resume_reads_are_stored_in_place_not_in_the_global_heap(grains_bin, root, tmp_path):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    with h5py.File(whole) as f:
        for path, attribute in RESUMED_STRINGS:
            kind = f[path].attrs.get_id(attribute).get_type() if attribute else f[path].id.get_type()
            assert isinstance(kind, h5py.h5t.TypeStringID) and not kind.is_variable_str(), (path, attribute)


def test_a_flipped_byte_in_the_stored_scene_is_refused_not_crashed_on(grains_bin, root, tmp_path):
    """The byte that held the scene's heap reference's object index, flipped (+256: past the heap's objects), now a
    character of the scene's text: the checkpoints' check sum of the scene refuses it."""
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed) as f:
        at = f["parameters/scene.toml"].id.get_offset()
    data = bytearray(killed.read_bytes())
    data[at + 13] ^= 0x01
    killed.write_bytes(bytes(data))
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert "its stored scene (parameters/scene.toml) is not the one its checkpoints were written with" in resumed.stderr


def test_a_file_whose_strings_an_older_grains_wrote_variable_length_resumes(grains_bin, root, tmp_path):
    whole = checkpointed_gas(grains_bin, root, tmp_path / "whole.h5")
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        for path, attribute in RESUMED_STRINGS:
            if attribute:
                f[path].attrs[attribute] = text(f[path].attrs[attribute])   # a str: variable length
            else:
                scene = text(f[path][()])
                del f[path]
                f.create_dataset(path, data=scene, dtype=h5py.string_dtype())
            kind = f[path].attrs.get_id(attribute).get_type() if attribute else f[path].id.get_type()
            assert kind.is_variable_str()
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert_same_records(whole, killed)


def test_a_run_stopped_by_a_signal_resumes_where_it_stopped(grains_bin, root, tmp_path):
    """Ctrl-C writes a checkpoint whatever output.checkpoint_every says; the resumed run's records are the
    unbroken run's."""
    gas = [root / "models/gas.toml", "--set", "particles.count=512", "--set", "time.steps=700000",
           "--set", "run.threads=1", "--quiet"]
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", *gas[:1], "--out", whole, *gas[1:]).returncode == 0
    stopped = tmp_path / "stopped.h5"
    code, out, err = interrupted([grains_bin, "run", gas[0], "--out", stopped, *gas[1:]], stopped, 0.5)
    assert code == 130, "the run ended before the signal: make it longer\n" + err
    assert "grains resume" in out and status(stopped).startswith("interrupted at step ")
    step = int(status(stopped).split()[-1])
    views_before = view_group(stopped)
    killed = killed_copy(stopped, tmp_path / "killed.h5")   # the same file as a kill would leave it
    resumed = run(grains_bin, "resume", stopped, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert f"resumed      at step {step}" in resumed.stdout
    # The records of the step it stopped at, between its scheduled ones, are dropped on resuming.
    assert_same_records(whole, stopped)
    # A run stopped by the signal closed its file whole: its XDMF views are cut back, not set aside (which would cost
    # their space at each resume); a killed one's are set aside and made anew.
    assert view_group(stopped) == views_before
    assert run(grains_bin, "resume", killed, "--quiet").returncode == 0
    assert view_group(killed) != views_before
    assert_same_records(whole, killed)


def view_group(path):
    """Where /grains/xdmf's object lies in the file (a group set aside and made anew lies elsewhere)."""
    with h5py.File(path, "r") as f:
        return h5py.h5o.get_info(f["grains/xdmf"].id).addr


@pytest.mark.parametrize("command", ["run", "consolidate"])
def test_ctrl_c_the_moment_the_output_file_is_touched_leaves_a_readable_file(grains_bin, root, tmp_path, command):
    """The signal handler is in place before the output file is created: a Ctrl-C as the writer lays the file
    out would kill the process and leave it truncated and unreadable."""
    scene = root / ("models/gas.toml" if command == "run" else "models/cohesionless.toml")
    out, earlier = tmp_path / "out.h5", tmp_path / "earlier.h5"
    sets = ["--set", f"particles.count={216 if command == 'run' else 200}", "--set", "run.threads=1", "--quiet"]
    assert run(grains_bin, "run", root / "models/gas.toml", "--out", earlier, "--set", "time.steps=10", "--set",
               "particles.count=216", "--quiet").returncode == 0
    for _ in range(4):
        shutil.copy(earlier, out)   # a valid earlier result at the path
        before = out.stat().st_mtime_ns
        extra = ["--table", tmp_path / "out.csv"] if command == "consolidate" else []
        p = subprocess.Popen([str(a) for a in [grains_bin, command, scene, "--out", out, *extra, *sets]],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        while p.poll() is None and out.stat().st_mtime_ns == before:
            pass   # the moment the writer touches the file
        p.send_signal(signal.SIGINT)
        p.communicate(timeout=60)
        with h5py.File(out) as f:   # the earlier file untouched, or the new one with its stop recorded
            assert "grains" in f
        assert os.path.getsize(out) > 0


@pytest.mark.parametrize("case", ["complete", "no checkpoint", "not a run", "programme in its first stage",
                                  "finished programme"])
def test_what_cannot_be_resumed_is_refused_with_the_reason(grains_bin, root, tmp_path, case):
    out = tmp_path / "run.h5"
    if case == "not a run":
        out = root / "models/gas.toml"
    elif "programme" in case:   # its four stages all short of their budget: "complete; 4 stage(s) did not ..."
        programme = ["--set", "particles.count=100", "--set", "programme.top_pressure=0.02", "--set",
                     "programme.stage_budget=2000", "--quiet"]
        assert run(grains_bin, "consolidate", root / "models/consolidation-type1.toml", "--out", out, "--table",
                   tmp_path / "t.csv", *programme).returncode == 0
        if case == "programme in its first stage":   # as one killed before any stage ended: no checkpoint yet
            with h5py.File(out, "r+") as f:
                del f["grains"].attrs["status"]
                for slot in ("checkpoint_0", "checkpoint_1"):
                    if slot in f["grains"]:
                        del f["grains"][slot]
    else:
        small = ["--set", "particles.count=512", "--set", "time.steps=200", "--quiet"]
        assert run(grains_bin, "run", root / "models/gas.toml", "--out", out, *small).returncode == 0
        if case == "no checkpoint":   # as a run killed before it wrote one
            with h5py.File(out, "r+") as f:
                del f["grains"].attrs["status"]
    done = run(grains_bin, "resume", out)
    assert done.returncode == 1
    expected = {"complete": "holds a finished run (status 'complete'): nothing to resume",
                "finished programme": "holds a finished run (status 'complete; 4 stage(s) did not reach equilibrium')",
                "no checkpoint": "has no valid checkpoint to resume from",
                "not a run": "file signature not found",
                "programme in its first stage": "the programme was killed before its first"}[case]
    assert str(out) in done.stderr and expected in done.stderr, done.stderr


def not_a_file(kind, at):
    """Makes `kind` at the path `at` (a link to the kind's thing, for "link to a FIFO" and "character device")."""
    if kind == "folder":
        at.mkdir()
    elif kind == "FIFO (named pipe)":
        os.mkfifo(at)
    elif kind == "link to a FIFO":
        os.mkfifo(at.with_name("pipe"))
        at.symlink_to("pipe")
    elif kind == "character device":
        at.symlink_to("/dev/zero")
    elif kind == "socket":
        listener = socket.socket(socket.AF_UNIX)
        listener.bind(str(at))
        return listener
    return None


@pytest.mark.parametrize("kind", ["folder", "FIFO (named pipe)", "link to a FIFO", "character device", "socket"])
def test_a_path_that_is_not_a_regular_file_is_refused_naming_what_it_is(grains_bin, tmp_path, kind):
    """A FIFO held the child that reads the file first for its minute's limit, /dev/zero was read as HDF5, and a folder
    was refused by the command line's check with no word of what is resumed: each is refused before any reading."""
    at = tmp_path / "run.h5"
    held = not_a_file(kind, at)
    try:
        resumed = subprocess.run([grains_bin, "resume", str(at), "--quiet"], capture_output=True, text=True, timeout=30)
    finally:
        if held:
            held.close()
    what = {"link to a FIFO": "FIFO (named pipe)"}.get(kind, kind)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert resumed.stderr == (f"error: '{at}' is a {what}: grains resume reads a regular file, the H5MD output that "
                              "grains run or grains consolidate wrote; not resumed\n"), resumed.stderr


@pytest.mark.parametrize("kind", ["folder", "FIFO (named pipe)"])
def test_a_programme_whose_stage_table_is_not_a_file_is_refused_naming_what_it_is(grains_bin, root, tmp_path, kind):
    """The resume reads the stage table back and rewrites it: one that is no longer a file is named as what it is,
    not said to be "gone"."""
    _, _, killed, killed_table, _ = killed_programme(grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000),
                                                     lambda rows: rows[:3])
    killed_table.unlink()
    not_a_file(kind, killed_table)
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert (f"'{killed}': its stage table '{killed_table}' is a {kind}, not the file the programme wrote; resuming "
            "needs that file" in resumed.stderr), resumed.stderr


@pytest.mark.parametrize("kind", ["folder", "FIFO (named pipe)"])
def test_an_xdmf_beside_that_is_not_a_file_is_refused_before_anything_is_rewritten(grains_bin, root, tmp_path, kind):
    """The resume rewrites the XDMF file beside the output by a rename: a FIFO there was replaced, and a folder failed
    the rename only after the file and the stage table had been cut back to the checkpoint, its status left 'running'."""
    _, _, killed, killed_table, _ = killed_programme(grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000),
                                                     lambda rows: rows[:3])
    xdmf = killed.with_suffix(".xdmf")
    xdmf.unlink(missing_ok=True)
    not_a_file(kind, xdmf)
    file_before, table_before = killed.read_bytes(), killed_table.read_text()
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert resumed.stderr == (f"error: '{killed}': the XDMF file the resume rewrites beside it, '{xdmf}', is a {kind}: "
                              "move that away (a regular file or nothing may be there); not resumed\n"), resumed.stderr
    assert killed.read_bytes() == file_before and killed_table.read_text() == table_before
    assert (xdmf.is_dir() if kind == "folder" else stat.S_ISFIFO(os.lstat(xdmf).st_mode))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["whole.h5", "whole.xdmf", "whole.csv", "killed.h5",
                                                                  "killed.csv", "killed.xdmf"])


def test_a_stage_table_another_run_has_rewritten_is_refused_not_continued(grains_bin, root, tmp_path):
    """A table whose rows are numbered 0, 1, ... may have been written since by another programme, whose rows the
    resume would continue below. Its rows must repeat the stage records."""
    _, _, killed, killed_table, rows = killed_programme(grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000),
                                                        lambda rows: rows[:3])
    header = rows[0].split(",")
    other = rows[2].split(",")
    phi = header.index("phi")
    recorded = other[phi]
    other[phi] = f"{float(recorded) * 1.01:.9g}"   # another sample's stage 1
    killed_table.write_text("\n".join(rows[:2] + [",".join(other)]) + "\n")
    file_before, table_before = killed.read_bytes(), killed_table.read_text()
    resumed = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert (f"its stage table '{killed_table}' is not the one the programme wrote: stage 1's row has P_star = "
            f"{other[header.index('P_star')]}, phi = {other[phi]} where the file's stage record has "
            f"{other[header.index('P_star')]}, {recorded}") in resumed.stderr, resumed.stderr
    assert killed.read_bytes() == file_before and killed_table.read_text() == table_before
    # The table as the programme wrote it resumes
    killed_table.write_text("\n".join(rows[:3]) + "\n")
    assert run(grains_bin, "resume", killed, "--quiet").returncode == 0


def moved_columns(rows, edit):
    """rows (header and stage rows, as lines) with edit(fields) applied to each line's fields."""
    out = []
    for line in rows:
        fields = line.split(",")
        edit(fields)
        out.append(",".join(fields))
    return out


def swap_p_star_and_phi(fields):
    fields[4], fields[5] = fields[5], fields[4]


def drop_quench_start(fields):
    del fields[9]


def drop_last(fields):
    del fields[-1]


def add_one(fields):
    fields.append("x")


# A header one column short or long: the first column that differs is the one past the shorter header, not the last
# that matched.
@pytest.mark.parametrize("edit, column", [(swap_p_star_and_phi, 5), (drop_quench_start, 10), (drop_last, "LAST"),
                                          (add_one, "NEXT")], ids=["swapped", "dropped", "last-dropped", "one-added"])
def test_a_stage_table_whose_columns_were_moved_or_removed_is_refused(grains_bin, root, tmp_path, edit, column):
    """Rows appended in grains' column order under whatever header the table has would go, with P_star and phi
    swapped, each under the other's name, and with quench_start deleted 67 fields under a 66-field header. The header
    must be grains' own, or the file and table are left as they were."""
    _, _, killed, killed_table, rows = killed_programme(grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000),
                                                        lambda rows: moved_columns(rows[:3], edit))
    found = killed_table.read_text().splitlines()[0]
    column = {"LAST": len(rows[0].split(",")), "NEXT": len(rows[0].split(",")) + 1}.get(column, column)
    file_before, table_before = killed.read_bytes(), killed_table.read_text()
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 1, (resumed.returncode, resumed.stderr)
    assert (f"its stage table '{killed_table}' has the header '{found}', where grains writes '{rows[0]}' (they differ "
            f"from column {column} on)") in resumed.stderr, resumed.stderr
    assert killed.read_bytes() == file_before and killed_table.read_text() == table_before


def test_a_stage_table_with_crlf_line_ends_keeps_them_in_the_rows_the_resume_writes(grains_bin, root, tmp_path):
    """A table saved with CRLF line ends gets its new rows with CRLF too, not LF."""
    whole, whole_table, killed, killed_table, rows = killed_programme(
        grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000), lambda rows: rows[:3])
    killed_table.write_bytes("".join(line + "\r\n" for line in rows[:3]).encode())
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert killed_table.read_bytes() == whole_table.read_bytes().replace(b"\n", b"\r\n")


def test_a_programme_with_a_drag_below_the_default_floor_resumes(grains_bin, root, tmp_path):
    """The refusal of a quench_drag_min above quench_drag read the stored scene, which spells out the default floor
    (0.125): every programme run with quench_drag = 0.1 would be refused on resuming."""
    programme = cohesionless_programme(root, 1.8e-5, 1000) + ["--set", "programme.quench_drag=0.1"]
    whole, whole_table, killed, killed_table, rows = killed_programme(grains_bin, tmp_path, programme, lambda rows: rows[:3])
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert killed_table.read_text() == whole_table.read_text()


def test_a_killed_consolidation_programme_resumes_from_its_last_finished_stage(grains_bin, root, tmp_path):
    """A checkpoint ends every stage but the last; the resumed programme's table and records are those of the
    programme that was never stopped, bit for bit (CVODE's own counters aside: they count from the resume)."""
    programme = [root / "models/consolidation-type1.toml", "--set", "particles.count=100", "--set",
                 "programme.top_pressure=0.1", "--set", "programme.stage_budget=20000", "--quiet"]
    # Killed during its last stage: no status, a partial last table row and records of that stage to drop.
    whole, whole_table, killed, killed_table, rows = killed_programme(
        grains_bin, tmp_path, programme, lambda rows: rows[:-1] + [rows[-1][:20]])
    with h5py.File(killed, "r+") as f:
        stage = int(max(f["grains/checkpoint_0"].attrs["stage"], f["grains/checkpoint_1"].attrs["stage"]))
        assert stage == len(rows) - 3   # the end of the last stage but one (rows: header, stages 0..last)
        f["observables/solid_fraction/value"][-1] = 0.0
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert f"0 steps into stage {stage + 1}" in resumed.stdout
    assert killed_table.read_text() == whole_table.read_text()
    assert_same_records(whole, killed)



def test_a_resumed_programme_replaces_its_stage_table_whole_and_keeps_a_link_to_it(grains_bin, root, tmp_path):
    """The resume writes the rows it keeps to a new file that then takes the table's name (a kill in between leaves
    the old table whole, where cutting the table to nothing first would not). A table reached through a link stays
    a link, the file it names holding the rows, and nothing is left beside it."""
    programme = [root / "models/consolidation-type1.toml", "--set", "particles.count=100", "--set",
                 "programme.top_pressure=0.1", "--set", "programme.stage_budget=20000", "--quiet"]
    whole, whole_table, killed, killed_table, rows = killed_programme(grains_bin, tmp_path, programme, lambda rows: rows[:-1])
    elsewhere = tmp_path / "tables"
    elsewhere.mkdir()
    real_table = elsewhere / "real.csv"
    killed_table.rename(real_table)
    killed_table.symlink_to(real_table)
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert killed_table.is_symlink() and real_table.read_text() == whole_table.read_text()
    assert sorted(p.name for p in elsewhere.iterdir()) == ["real.csv"]
    assert not any(p.name.endswith(".resuming") for p in tmp_path.iterdir())


# A type-2 programme of 200 disks: its aggregation takes about 1 million of its 1.16 million steps.
TYPE2 = ["--set", "particles.count=200", "--set", "programme.top_pressure=0.02", "--set", "programme.stage_budget=20000",
         "--set", "run.threads=1", "--quiet"]


def test_a_programme_stopped_by_a_signal_inside_a_stage_resumes_there(grains_bin, root, tmp_path):
    """Ctrl-C stops `grains consolidate` at its next equilibrium check with a checkpoint, inside the stage (here
    the aggregation, whose fixed cell needs no CVODE restart); the resume goes on from that step and ends as the
    programme that was never stopped, table and records bit for bit."""
    scene = root / "models/consolidation.toml"
    whole, whole_table = tmp_path / "whole.h5", tmp_path / "whole.csv"
    assert run(grains_bin, "consolidate", scene, "--out", whole, "--table", whole_table, *TYPE2).returncode == 0
    stopped, table = tmp_path / "stopped.h5", tmp_path / "stopped.csv"
    code, out, err = interrupted([grains_bin, "consolidate", scene, "--out", stopped, "--table", table, *TYPE2], stopped, 0.5)
    assert code == 130, "the programme ended before the signal\n" + err
    assert "INTERRUPTED in stage 0" in out and status(stopped).startswith("interrupted in stage 0 at step ")
    step = int(status(stopped).split()[-1])
    with h5py.File(stopped) as f:
        assert step % 100 == 0 and f["grains/checkpoint_0"].attrs["step"] == step
        assert list(f["grains/checkpoint_0"].attrs["stage_progress"]) == [0, step]   # the aggregation has no quench
        before = f["grains/checkpoint_0"].attrs["wall_seconds"]
    resumed = run(grains_bin, "resume", stopped, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert f"resumed      at step {step}, {step} steps into stage 0" in resumed.stdout
    assert table.read_text() == whole_table.read_text()
    assert status(stopped) == status(whole)
    assert_same_records(whole, stopped)
    # The file's wall time and rate are the whole programme's, the part before the stop included.
    with h5py.File(stopped) as f:
        g = f["grains"].attrs
        steps = f["observables/kinetic_energy/step"][-1]
        assert g["wall_seconds"] > before > 0
        assert g["particle_steps_per_second"] == pytest.approx(steps * 200 / g["wall_seconds"], rel=1e-12)
        assert 0 < g["cvode_share"] < 1


def test_a_programme_killed_inside_a_stage_resumes_from_its_last_checkpoint_with_the_quench_as_it_was(grains_bin, root,
                                                                                                      tmp_path):
    """With output.checkpoint_every a programme also saves inside its stages, the quench's counters with the state
    (here, in the last stage, quenched and counting checks towards its equilibrium). Saving changes nothing (CVODE's
    history is rebuilt from what the state carries), so the reference is the same programme without checkpoints:
    the resume from the last one ends with its table and records."""
    whole, whole_table, killed, killed_table, rows = killed_programme(
        grains_bin, tmp_path, cohesionless_programme(root, 1.4e-5, 300000), lambda rows: rows[:2])
    plain, plain_table = tmp_path / "plain.h5", tmp_path / "plain.csv"
    programme = cohesionless_programme(root, 1.4e-5, 300000)
    programme[programme.index("output.checkpoint_every=1000")] = "output.checkpoint_every=0"
    assert run(grains_bin, "consolidate", programme[0], "--out", plain, "--table", plain_table, *programme[1:]).returncode == 0
    assert plain_table.read_text() == whole_table.read_text()   # the checkpoints left the programme as it was
    header = rows[0].split(",")
    last = dict(zip(header, rows[2].split(",")))
    quenched_from = int(last["quench_start"])
    assert len(rows) == 3 and quenched_from > 0 and float(last["quench_drag"]) == 1   # stage 1 quenched, drag gamma T 1
    with h5py.File(killed, "r+") as f:
        newest = max(("checkpoint_0", "checkpoint_1"), key=lambda k: f["grains"][k].attrs["step"])
        progress = list(f["grains"][newest].attrs["stage_progress"])
    # Stage 1, steps into it, after its quench began; the quench's start as the table has it.
    assert progress[0] == 1 and progress[1] > quenched_from and progress[6] == quenched_from, progress
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert f"{int(progress[1])} steps into stage 1" in resumed.stdout
    assert killed_table.read_text() == whole_table.read_text()
    assert_same_records(whole, killed)


def test_a_scene_reading_a_particle_file_resumes_from_any_folder_and_only_with_that_file(grains_bin, tmp_path):
    """The stored scene's relative particles.file lies beside the scene, wherever `grains resume` runs; a file
    changed since the run started (other masses, or other positions, and with them the run's length in free-fall
    times) is refused, not silently used."""
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "pair.txt").write_text("-0.6 0 0 1 1 0.5 0 0\n0.6 0 0 1 1 -0.5 0 0\n")
    (folder / "pair.toml").write_text(
        '[scene]\nname = "pair"\ndimension = 3\n[particles]\nlayout = "file"\nfile = "pair.txt"\n'
        '[box]\nperiodic = false\n[contact]\nrestitution = 0.5\nduration = 0.1\n'
        '[time]\nsteps_per_contact = 50\nduration = 1.0\n[output]\nobservables_every = 1\ncheckpoint_every = 100\n')
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", folder / "pair.toml", "--out", whole, "--quiet").returncode == 0
    killed = killed_copy(whole, tmp_path / "killed.h5")   # after its checkpoint at step 400
    elsewhere = subprocess.run([grains_bin, "resume", str(killed), "--quiet"], capture_output=True, text=True, cwd=tmp_path)
    assert elsewhere.returncode == 0, elsewhere.stderr
    assert_same_records(whole, killed)
    killed_copy(whole, killed)
    (folder / "pair.txt").write_text("-0.6 0 0 1 2 0.5 0 0\n0.6 0 0 1 2 -0.5 0 0\n")
    changed = run(grains_bin, "resume", killed)
    assert changed.returncode == 1 and "another mass than the run's first frame" in changed.stderr, changed.stderr
    (folder / "pair.txt").write_text("-0.7 0 0 1 1 0.5 0 0\n0.6 0 0 1 1 -0.5 0 0\n")
    moved = run(grains_bin, "resume", killed)
    assert moved.returncode == 1 and "another position than the run's first frame" in moved.stderr, moved.stderr
    # The file gone: said so, and the stored scene named without a --set override the user never gave (the resume's
    # own thread count is no such override).
    (folder / "pair.txt").unlink()
    gone = run(grains_bin, "resume", killed)
    assert gone.returncode == 1 and "pair.txt' (no such file)" in gone.stderr, gone.stderr
    assert "override" not in gone.stderr and f"the scene stored in {killed}" in gone.stderr, gone.stderr


def damage_the_newest_checkpoint(path):
    """Flips a byte of the newest checkpoint's first chunk on disk (its checksum then fails); returns the (step, stage)
    of the older checkpoint and of the newest, and their slots' names."""
    with h5py.File(path, "r+") as f:
        slots = sorted(("checkpoint_0", "checkpoint_1"), key=lambda k: f["grains"][k].attrs["step"])
        older, newest = ((int(f["grains"][k].attrs["step"]), int(f["grains"][k].attrs["stage"])) for k in slots)
        chunk = f["grains"][slots[1]].id.get_chunk_info(0)   # where its first chunk lies in the file
    with open(path, "r+b") as raw:
        raw.seek(chunk.byte_offset + 100)
        byte = raw.read(1)
        raw.seek(chunk.byte_offset + 100)
        raw.write(bytes([byte[0] ^ 0xFF]))
    return older, newest, slots


def test_a_damaged_newest_checkpoint_gives_way_to_the_older_one(grains_bin, root, tmp_path):
    """Each checkpoint carries a checksum: bytes damaged on disk are detected, and the resume starts from the
    other slot, still ending with the unbroken run's records. It says so: the damaged one passed over, and the one it
    resumes from."""
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", root / "models/aggregation.toml", "--out", whole, *CLOUD).returncode == 0
    killed = killed_copy(whole, tmp_path / "killed.h5")
    (older, _), (newest, _), (older_slot, newest_slot) = damage_the_newest_checkpoint(killed)
    resumed = run(grains_bin, "resume", killed)
    assert resumed.returncode == 0, resumed.stderr
    assert (older, newest) == (12000, 15000) and f"resumed      at step {older}" in resumed.stdout
    assert (f"warning: '{killed}': the checkpoint in /grains/{newest_slot} (step {newest}) is damaged (its checksum "
            f"fails) and is passed over; resuming from the one in /grains/{older_slot} (step {older})\n"
            in resumed.stderr), resumed.stderr
    assert f"resuming '{killed}' at step {older} of" in resumed.stderr and f"at step {newest}" not in resumed.stderr
    assert_same_records(whole, killed)


def test_the_resume_past_a_damaged_checkpoint_keeps_the_good_slot_and_makes_the_other_anew(grains_bin, root, tmp_path):
    """The resumed run's next checkpoint goes into a slot made anew where the damaged one was: the one resumed from
    stays whole meanwhile, so a kill while that checkpoint is written leaves something to resume from. The damaged
    slot must not stay marked valid and newest: the next checkpoint would go over the good one, and the file end with
    a damaged slot marked valid."""
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", root / "models/aggregation.toml", "--out", whole, *CLOUD).returncode == 0
    killed = killed_copy(whole, tmp_path / "killed.h5")
    (older, _), (newest, _), _ = damage_the_newest_checkpoint(killed)
    assert run(grains_bin, "resume", killed, "--quiet").returncode == 0
    with h5py.File(killed) as f:
        slots = {k: f["grains"][k] for k in ("checkpoint_0", "checkpoint_1") if f["grains"][k].attrs["valid"] == 1}
        assert sorted(int(d.attrs["step"]) for d in slots.values()) == [older, newest]
        for d in slots.values():
            d[()]   # reads back: its checksum holds
    assert_same_records(whole, killed)


def short_type1_programme(grains_bin, root, tmp_path):
    """`grains consolidate` of 100 type-1 disks to P* = 0.02, its stages stopped short of equilibrium by their budget
    of 2000 steps, to its end as whole.h5 and t.csv; returns (whole, the table's path, the table's text)."""
    programme = [root / "models/consolidation-type1.toml", "--set", "particles.count=100", "--set",
                 "programme.top_pressure=0.02", "--set", "programme.stage_budget=2000", "--quiet"]
    whole, table = tmp_path / "whole.h5", tmp_path / "t.csv"
    assert run(grains_bin, "consolidate", *programme[:1], "--out", whole, "--table", table, *programme[1:]).returncode == 0
    return whole, table, table.read_text()


def test_a_programme_whose_newest_checkpoint_is_damaged_says_which_stage_it_resumes_from(grains_bin, root, tmp_path):
    """A programme's checkpoints are named by step and stage: the damaged one passed over, and the stage end the
    resume goes on from."""
    whole, table, whole_table = short_type1_programme(grains_bin, root, tmp_path)
    killed = killed_copy(whole, tmp_path / "killed.h5")
    (older, older_stage), (newest, newest_stage), (older_slot, newest_slot) = damage_the_newest_checkpoint(killed)
    assert older_stage >= 0 and newest_stage == older_stage + 1
    resumed = run(grains_bin, "resume", killed)
    assert resumed.returncode == 0, resumed.stderr
    assert (f"warning: '{killed}': the checkpoint in /grains/{newest_slot} (step {newest}, after stage {newest_stage}) is "
            f"damaged (its checksum fails) and is passed over; resuming from the one in /grains/{older_slot} (step "
            f"{older}, after stage {older_stage})\n" in resumed.stderr), resumed.stderr
    assert f"resuming '{killed}' 0 steps into stage {older_stage + 1} (step {older}," in resumed.stderr, resumed.stderr
    assert table.read_text() == whole_table
    assert_same_records(whole, killed)


def test_a_programme_killed_while_writing_a_checkpoint_repeats_no_warning(grains_bin, root, tmp_path):
    """Killed while writing a stage's checkpoint (that slot left invalid, the stage's warning already in the
    file): the resume goes back to the stage before and rewrites the stage, its warning once."""
    whole, table, whole_table = short_type1_programme(grains_bin, root, tmp_path)
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        warnings = [w.decode() for w in f["grains/warnings"][()]]
        assert len(warnings) == 4   # every stage short of its budget
        newest = max(("checkpoint_0", "checkpoint_1"), key=lambda k: f["grains"][k].attrs["step"])
        f["grains"][newest].attrs["valid"] = 0.0
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    with h5py.File(killed) as f:
        assert [w.decode() for w in f["grains/warnings"][()]] == warnings
    assert status(killed) == status(whole) == "complete; 4 stage(s) did not reach equilibrium"
    assert table.read_text() == whole_table
    assert_same_records(whole, killed)


def test_a_signal_in_the_last_stretch_of_a_run_leaves_it_complete(grains_bin, root, tmp_path):
    """A run whose signal arrives while it takes its last steps has reached its end: complete, its final
    records kept, no checkpoint (one stretch here: records only at the start and the end).
    The signal is read between chunks of steps, the first of one step: one step of 40,000 self-gravitating
    particles (a direct sum of 8e8 pairs, about a second, after the first record's potential energy, as long)
    is the run's only stretch."""
    out = tmp_path / "cloud.h5"
    cmd = [grains_bin, "run", root / "models/aggregation.toml", "--out", out, "--quiet", "--set", "particles.count=40000",
           "--set", "time.steps=1", "--set", "output.observables_every=1000000", "--set", "output.snapshots_every=0",
           "--set", "run.threads=1"]
    code, _, err = interrupted(cmd, out, 0.2)
    assert code == 0, err
    assert status(out) == "complete"
    with h5py.File(out) as f:
        assert list(f["observables/kinetic_energy/step"][()]) == [0, 1] and "checkpoint_0" not in f["grains"]


def test_a_programme_resumed_from_a_stage_end_past_a_checkpoint_multiple_ends_as_the_unbroken_one(grains_bin, root,
                                                                                                  tmp_path):
    """Stages of 1000 steps and output.checkpoint_every = 1000: every multiple falls on a stage's end, where the
    stage's own checkpoint is written. A resume from that checkpoint cannot know a multiple was pending there, so the
    unbroken programme must not write another at the next stage's first check (the two files would hold different
    checkpoints)."""
    whole, whole_table, killed, killed_table, rows = killed_programme(
        grains_bin, tmp_path, cohesionless_programme(root, 1.8e-5, 1000), lambda rows: rows[:3])
    assert len(rows) == 4   # three stages of 1000 steps, none in equilibrium
    with h5py.File(killed, "r+") as f:
        steps = {k: int(f["grains"][k].attrs["step"]) for k in ("checkpoint_0", "checkpoint_1")}
        # Killed right after stage 1's end: a checkpoint written after it never made it to the file.
        for k, step in steps.items():
            if step > 2000:
                f["grains"][k].attrs["valid"] = 0.0
    assert 2000 in steps.values(), steps
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert "resumed      at step 2000, 0 steps into stage 2" in resumed.stdout
    assert killed_table.read_text() == whole_table.read_text()
    assert_same_records(whole, killed)


@pytest.mark.parametrize("checkpoint_every", [2100, 2900])
def test_a_programme_resumed_right_after_or_before_a_stage_end_writes_the_unbroken_trace(grains_bin, root, tmp_path,
                                                                                         checkpoint_every):
    """Every stage's end has a trace row (its stage record's state), written by the stage structure alone: resumed
    from the first check after stage 1's end (step 2100) or from the last check before the last stage's end (2900),
    the programme writes the unbroken one's trace, each stage end's row once."""
    programme = cohesionless_programme(root, 1.8e-5, 1000)
    programme[programme.index("output.checkpoint_every=1000")] = f"output.checkpoint_every={checkpoint_every}"
    programme += ["--set", "programme.trace_every=100"]
    whole, whole_table, killed, killed_table, rows = killed_programme(grains_bin, tmp_path, programme, lambda rows: rows[:3])
    assert len(rows) == 4   # three stages of 1000 steps, none in equilibrium
    with h5py.File(killed) as f:
        steps = sorted(int(f["grains"][k].attrs["step"]) for k in ("checkpoint_0", "checkpoint_1"))
        assert list(f["grains/trace/stage/step"][()]) == list(range(100, 3001, 100))   # a row at every check, ends too
        assert list(f["grains/trace/stage/value"][()]) == [0] * 10 + [1] * 10 + [2] * 10
    assert steps == [2000, checkpoint_every]   # stage 1's end, then the one inside stage 2
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert f"resumed      at step {checkpoint_every}, {checkpoint_every - 2000} steps into stage 2" in resumed.stdout
    assert killed_table.read_text() == whole_table.read_text()
    assert_same_records(whole, killed)


def test_a_run_that_fails_says_so_in_its_file_and_is_not_resumed(grains_bin, root, tmp_path):
    """A run stopped by an error must not keep the status "running" of a killed run: resume would then blame a
    missing checkpoint, or with checkpoints repeat the error."""
    out = tmp_path / "blown.h5"
    failed = run(grains_bin, "run", root / "models/gas.toml", "--set", "time.dt=10", "--set", "time.steps=200",
                 "--set", "run.threads=1", "--set", "output.checkpoint_every=2", "--out", out, "--quiet")
    # It blows up: a particle flung ~1e8 cell lengths in step 3 (the check of the wrapped positions stops it a step
    # before the non-finite value of step 4).
    assert failed.returncode == 1 and "cell lengths from the periodic cell on axis 0 at step 3" in failed.stderr
    assert status(out).startswith("failed after step 2: particle 1 is"), status(out)
    again = run(grains_bin, "resume", out)
    assert again.returncode == 1 and "ended with an error" in again.stderr and "resuming would repeat it" in again.stderr


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="needs two cores for the automatic thread count to differ")
def test_a_run_resumed_on_fewer_cores_keeps_its_thread_count_and_its_results(grains_bin, root, tmp_path):
    """The automatic thread count follows the cores (one per 2000 particles at most): 4096 particles run on two
    threads. Resumed where only one core is free, it takes its recorded count again: one thread would sum in another
    order and give other last bits."""
    whole = tmp_path / "whole.h5"
    gas = ["--set", "particles.count=4096", "--set", "run.threads=0", "--set", "time.steps=600",
           "--set", "output.checkpoint_every=300", "--set", "output.observables_every=100"]
    done = run(grains_bin, "run", root / "models/gas.toml", "--out", whole, "--quiet", *gas)
    assert done.returncode == 0, done.stderr
    assert "2 thread(s)" in run(grains_bin, "check", root / "models/gas.toml", *gas).stdout + done.stdout
    killed = killed_copy(whole, tmp_path / "killed.h5")
    one_core = subprocess.run([grains_bin, "resume", killed], capture_output=True, text=True,
                              preexec_fn=lambda: os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}))
    assert one_core.returncode == 0, one_core.stderr
    assert_same_records(whole, killed)
    assert "2 thread(s)" in one_core.stdout


def held_by_another_process(path):
    """Whether a process holds a writer's lock on the file (flock, as HDF5 takes it)."""
    with open(path, "rb") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
            return False
        except BlockingIOError:
            return True


@pytest.mark.parametrize("hdf5_locks", [True, False], ids=["hdf5-locks", "hdf5-locking-off"])
@pytest.mark.parametrize("writer", ["run", "resume"])
def test_resuming_a_file_another_process_writes_is_refused_with_that_reason(grains_bin, root, tmp_path, writer, hdf5_locks):
    """Also where HDF5 takes no locks (HDF5_USE_FILE_LOCKING=FALSE, for file systems without them): there the
    writer takes HDF5's lock itself, and two resumes of one stopped run both ran to "complete" before."""
    env = {k: v for k, v in os.environ.items() if k != "HDF5_USE_FILE_LOCKING"}
    if not hdf5_locks:
        env["HDF5_USE_FILE_LOCKING"] = "FALSE"
    out = tmp_path / "live.h5"
    long_run = [grains_bin, "run", root / "models/gas.toml", "--out", out, "--quiet", "--set", "time.steps=100000000",
                "--set", "run.threads=1"]
    if writer == "resume":   # a run stopped by Ctrl-C, resumed by the live process
        code, _, err = interrupted(long_run, out, 0.5)
        assert code == 130 and status(out).startswith("interrupted"), err
    command = long_run if writer == "run" else [grains_bin, "resume", out, "--quiet"]
    live = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        deadline = time.monotonic() + 60
        while not (out.exists() and held_by_another_process(out)) and time.monotonic() < deadline and live.poll() is None:
            time.sleep(0.05)
        assert live.poll() is None, live.communicate()[1]
        second = subprocess.run([grains_bin, "resume", out], capture_output=True, text=True, env=env)
        assert second.returncode != 0 and "another process is writing it" in second.stderr, second.stderr
    finally:
        live.kill()
        live.communicate()


def test_a_scene_edited_in_the_file_since_its_checkpoint_is_refused(grains_bin, root, tmp_path):
    """The stored scene is what a resume rebuilds the run from: edited in the file (another restitution), it was
    taken, and the run went on with other physics. Each checkpoint now records the scene's check sum."""
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", root / "models/collision.toml", "--out", whole, "--quiet", "--set",
               "output.checkpoint_every=100").returncode == 0
    killed = killed_copy(whole, tmp_path / "killed.h5")
    with h5py.File(killed, "r+") as f:
        scene = f["parameters/scene.toml"][()].decode()
        edited = scene.replace("restitution = 0.5", "restitution = 0.9")
        assert edited != scene
        kind = f["parameters/scene.toml"].dtype
        del f["parameters/scene.toml"]
        f["parameters"].create_dataset("scene.toml", data=edited.encode(), dtype=kind)
        f["parameters"].attrs["scene.toml"] = edited
    r = run(grains_bin, "resume", killed)
    assert r.returncode != 0 and "is not the one its checkpoints were written with" in r.stderr, r.stderr
    untouched = killed_copy(whole, tmp_path / "untouched.h5")
    assert run(grains_bin, "resume", untouched, "--quiet").returncode == 0
    assert_same_records(whole, untouched)
