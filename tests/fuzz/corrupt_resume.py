"""`grains resume` of damaged output files: truncations and byte flips of a real checkpointed run's file.

Not a test (it runs for as long as asked): a mutation fuzzer by script, since libFuzzer cannot drive HDF5 files well.
A short run of a small scene is made once and marked as killed (status `running`, as a SIGKILL leaves it); each trial
copies it, damages the copy (cut short; bytes flipped anywhere; bytes flipped inside a checkpoint's data, or its
attributes' neighbourhood) and resumes it. A refusal (exit status 1 with a message) and a resumed run are both fine;
a signal, a sanitizer's report, an exit status of neither kind or a run past the time limit is a finding, and its file
is kept.

    python tests/fuzz/corrupt_resume.py --grains build-fuzz/runner/grains --trials 300 --out /tmp/resume-fuzz
"""
import argparse
import os
import random
import shutil
import subprocess
import sys
import time
from pathlib import Path

import h5py

ROOT = Path(__file__).resolve().parents[2]


def base_file(grains, folder):
    """A gas of 64 grains, 450 steps, a checkpoint every 100 (the last at 400): as a killed run leaves it (status `running`)."""
    whole = folder / "whole.h5"
    # --overwrite: a second session in the same --out finds the last one's file, made resumable below, and replaces it.
    subprocess.run([grains, "run", ROOT / "models/gas-friction.toml", "--out", whole, "--set", "particles.count=64",
                    "--set", "time.steps=450", "--set", "output.checkpoint_every=100", "--set", "run.threads=1",
                    "--quiet", "--overwrite"], check=True, env=environment())
    with h5py.File(whole, "r+") as f:
        f["grains"].attrs.modify("status", "running")   # in the type grains wrote it (a str would be variable length)
        # where the checkpoints' bytes lie in the file, for flips aimed at them
        spans = []
        for name in ("grains/checkpoint_0", "grains/checkpoint_1"):
            d = f.get(name)
            if isinstance(d, h5py.Dataset):   # chunked: each chunk's place
                for k in range(d.id.get_num_chunks()):
                    chunk = d.id.get_chunk_info(k)
                    spans.append((chunk.byte_offset, min(chunk.size, d.nbytes)))
    return whole, spans


def environment():
    env = dict(os.environ, OMP_WAIT_POLICY="passive", ASAN_OPTIONS="detect_leaks=0",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    return env


def damage(data, spans, rng):
    kind = rng.choice(["truncate", "flip", "flip-checkpoint", "zero-run"])
    data = bytearray(data)
    if kind == "truncate":
        return bytes(data[: rng.randrange(len(data))]), kind
    if kind == "flip-checkpoint" and spans:
        start, length = rng.choice(spans)
        for _ in range(rng.randint(1, 8)):
            data[start + rng.randrange(max(length, 1))] ^= 1 << rng.randrange(8)
        return bytes(data), kind
    if kind == "zero-run":
        at = rng.randrange(len(data))
        data[at : at + rng.randint(1, 4096)] = bytes(min(len(data) - at, rng.randint(1, 4096)))
        return bytes(data), kind
    for _ in range(rng.randint(1, 16)):
        data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    return bytes(data), "flip"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grains", required=True)
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=120)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    whole, spans = base_file(args.grains, args.out)
    original = whole.read_bytes()
    print(f"{len(original)} bytes, {len(spans)} checkpoint datasets", flush=True)
    rng = random.Random(args.seed)
    outcomes = {}
    for trial in range(args.trials):
        damaged, kind = damage(original, spans, rng)
        copy = args.out / "trial.h5"
        copy.write_bytes(damaged)
        start = time.time()
        try:
            p = subprocess.run([args.grains, "resume", copy, "--quiet"], capture_output=True, text=True,
                               timeout=args.timeout, env=environment())
            code, err = p.returncode, p.stderr
        except subprocess.TimeoutExpired:
            code, err = "timeout", ""
        sanitizer = "Sanitizer" in err or "runtime error:" in err
        fine = code in (0, 1) and not sanitizer and (code == 0 or "error" in err.lower())
        key = f"{kind}: {'fine' if fine else 'FINDING'} (exit {code})"
        outcomes[key] = outcomes.get(key, 0) + 1
        if not fine:
            keep = args.out / f"finding-{trial}.h5"
            shutil.copy(copy, keep)   # the damaged file as it was given (resume may have changed the copy)
            keep.write_bytes(damaged)
            (args.out / f"finding-{trial}.txt").write_text(f"exit {code}\n{err}")
            print(f"trial {trial}: {kind}: exit {code}, {time.time() - start:.1f} s: {err.strip()[-400:]}", flush=True)
        elif trial % 25 == 0:
            print(f"trial {trial}: {kind}: exit {code}: {err.strip().splitlines()[-1][:200] if err.strip() else ''}", flush=True)
    for key, n in sorted(outcomes.items()):
        print(f"{n:5d}  {key}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
