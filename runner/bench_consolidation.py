"""Consolidation benchmarks (not part of the test suite).

    python runner/bench_consolidation.py throughput [--steps 20000]
    python runner/bench_consolidation.py cycle [--count 1400]
    python runner/bench_consolidation.py settings [--count 300] [--seeds 3] [--jobs 2]

throughput: particle-steps per second on the 1400 cohesive disks of models/consolidation-rr.toml
  (friction, rolling resistance, barostat on), with the barostat off, and with CVODE restarted every
  step instead of keeping its history; the CVODE share of the wall time, CVODE's own time and right-hand sides
  per particle step for each (the rates of short runs swing by more than CVODE's whole time).
cycle: one full type-2 preparation + loading + unloading cycle (models/consolidation.toml): stages,
  steps, particle-steps per second, the CVODE share, and stages that missed equilibrium.
settings: what the equilibrium tolerance, the CVODE tolerances, I_a and n_c cost (wall time, steps) and
  change (Phi at equilibrium) on cohesionless packings, each against the tightest setting on the same
  samples (several seeds: one packing's path dependence is as large as the settings' effect).
"""
import argparse
import concurrent.futures
import csv
import pathlib
import re
import statistics
import sys
import tempfile
import time

import h5py

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import child_runs  # noqa: E402
import tool_args  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def grains(args, binary):
    """Runs grains: what it printed and the wall time; a failed run ends the benchmark with grains' own reason."""
    t = time.perf_counter()
    stdout = child_runs.run_grains("bench_consolidation.py", [binary, *args])
    return stdout, time.perf_counter() - t


def throughput(a):
    # CVODE's own time and right-hand sides per particle step compare keeping its history with restarting it: the
    # rates of the two differ by more than CVODE's whole time, run to run.
    print("| variant | particle-steps/s | CVODE share | CVODE us per particle step | CVODE right-hand sides per particle step |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        scene = ROOT / "models" / "consolidation-rr.toml"
        # Without the barostat the scene reads none of its cell keys, nor its programme's: grains refuses them,
        # so the sections go.
        no_cell = pathlib.Path(d) / "no-cell.toml"
        no_cell.write_text(re.sub(r"(?ms)^\[(cell|programme)\]\n.*?(?=^\[|\Z)", "", scene.read_text()))
        for name, file, extra in (("barostat on", scene, []), ("barostat off", no_cell, []),
                                  ("CVODE restarted every step", scene, ["cell.restart_cvode_every_step=true"])):
            out = pathlib.Path(d) / "t.h5"
            sets = [x for e in [f"time.steps={a.steps}", f"output.observables_every={a.steps}", *extra] for x in ("--set", e)]
            stdout, _ = grains(["run", file, "--out", out, "--quiet", *sets], a.grains)
            rate = float(re.search(r"\(([0-9.e+]+) particle-steps/s", stdout).group(1))
            wall = float(re.search(r"wall time\s+([0-9.]+) s", stdout).group(1))
            share = per_step = rhs = "-"
            with h5py.File(out) as f:
                if "cvode_seconds" in f["observables"]:
                    seconds = f['observables/cvode_seconds/value'][-1]
                    share = f"{100 * seconds / wall:.1f} %"
                    per_step = f"{1e6 * seconds / a.steps:.2f}"
                    rhs = f"{f['observables/cvode_rhs_evaluations/value'][-1] / a.steps:.2f}"
            print(f"| {name} | {rate:.3g} | {share} | {per_step} | {rhs} |")


def cycle(a):
    with tempfile.TemporaryDirectory() as d:
        stdout, wall = grains(["consolidate", ROOT / "models" / "consolidation.toml", "--quiet", "--table",
                               pathlib.Path(d) / "c.csv", "--out", pathlib.Path(d) / "c.h5", "--set",
                               f"particles.count={a.count}"], a.grains)
    print(stdout)
    print(f"cycle wall time {wall:.1f} s")


def settings(a):
    """Each setting on the same --seeds samples, --jobs runs at a time; Phi and its change against the
    tightest setting per sample, so that the packings' own spread (path dependence) shows beside it."""
    tight_tolerances = ["cell.tolerance_force=1e-6", "cell.tolerance_torque=1e-6", "cell.tolerance_stress=1e-6",
                        "cell.tolerance_kinetic=5e-9"]
    variants = [("tightest (all tightened below)", tight_tolerances + ["cell.rtol=1e-8", "cell.atol=1e-12",
                                                                   "cell.inertia_number=0.01", "time.steps_per_contact=100"]),
                ("defaults", []),
                ("equilibrium tolerances /10", tight_tolerances),
                ("equilibrium tolerances x10", ["cell.tolerance_force=1e-4", "cell.tolerance_torque=1e-4",
                                                "cell.tolerance_stress=1e-4", "cell.tolerance_kinetic=5e-7"]),
                ("CVODE rtol 1e-8", ["cell.rtol=1e-8"]),
                ("CVODE rtol 1e-4", ["cell.rtol=1e-4"]),
                ("CVODE atol 1e-12", ["cell.atol=1e-12"]),
                ("CVODE atol 1e-6", ["cell.atol=1e-6"]),
                ("I_a = 0.01", ["cell.inertia_number=0.01"]),
                ("I_a = 0.2", ["cell.inertia_number=0.2"]),
                ("n_c = 100", ["time.steps_per_contact=100"]),
                ("n_c = 25", ["time.steps_per_contact=25"])]
    seeds = list(range(1, a.seeds + 1))

    def one(job):
        (name, extra), seed = job
        with tempfile.TemporaryDirectory() as d:
            table = pathlib.Path(d) / "s.csv"
            # Four times the default stage budget for every setting: the tightest one's stages ran past the default
            # (2.13e6 and 2.28e6 steps at 300 disks), and the reference must have reached its equilibrium
            sets = [x for e in [f"particles.count={a.count}", f"particles.seed={seed}", "programme.stage_budget=8000000",
                                *extra] for x in ("--set", e)]
            _, wall = grains(["consolidate", ROOT / "models" / "cohesionless.toml", "--quiet", "--table", table, "--out",
                              pathlib.Path(d) / "s.h5", *sets], a.grains)
            row = list(csv.DictReader(table.open()))[-1]
        print(f"  {name}, seed {seed}: {wall:.0f} s, {row['steps']} steps, Phi {float(row['phi']):.5f}"
              f"{'' if row['reached'] == '1' else ' (not in equilibrium)'}", flush=True)
        return float(row["phi"]), int(row["steps"]), wall, row["reached"] == "1"

    jobs = [(v, seed) for v in variants for seed in seeds]
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = {(v[0], seed): r for (v, seed), r in zip(jobs, pool.map(one, jobs))}
    print(f"\n{a.count} cohesionless disks to P / K_N = 1e-5, seeds {seeds[0]}-{seeds[-1]}, {a.jobs} runs at a time; "
          "mean over the seeds (sd of the per-seed change in brackets)")
    print("| setting | wall s | steps | Phi | Phi - Phi(tightest) | not in equilibrium |")
    print("|---|---|---|---|---|---|")
    tight = [results[(variants[0][0], s)][0] for s in seeds]
    for v in variants:
        r = [results[(v[0], s)] for s in seeds]
        change = [x[0] - t for x, t in zip(r, tight)]
        spread = f" ({statistics.stdev(change):.4f})" if len(seeds) > 1 else ""
        print(f"| {v[0]} | {statistics.mean(x[2] for x in r):.0f} | {statistics.mean(x[1] for x in r):,.0f} | "
              f"{statistics.mean(x[0] for x in r):.4f} | {statistics.mean(change):+.4f}{spread} | "
              f"{sum(not x[3] for x in r)} of {len(seeds)} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["throughput", "cycle", "settings"])
    ap.add_argument("--steps", type=int, help="throughput: steps of each run (default 20000)")
    ap.add_argument("--count", type=int)
    ap.add_argument("--seeds", type=int, help="settings: samples per setting (particles.seed 1, 2, ...; default 3)")
    ap.add_argument("--jobs", type=int, help="settings: runs at a time (one thread each; default 2)")
    ap.add_argument("--grains", default=str(ROOT / "build" / "runner" / "grains"), help="the grains binary (default: build/runner/grains)")
    a = ap.parse_args()
    tool_args.require_counts(ap, steps=a.steps, count=a.count, seeds=a.seeds, jobs=a.jobs)
    # Each benchmark reads only its own options: one given to another is refused, not ignored.
    reads = {"throughput": {"steps"}, "cycle": {"count"}, "settings": {"count", "seeds", "jobs"}}[a.what]
    for name in ("steps", "count", "seeds", "jobs"):
        if getattr(a, name) is not None and name not in reads:
            ap.error(f"--{name}: not read by {a.what} (it reads {', '.join('--' + r for r in sorted(reads))})")
    a.steps, a.seeds, a.jobs = a.steps or 20000, a.seeds or 3, a.jobs or 2
    a.count = a.count or (1400 if a.what == "cycle" else 300)
    tool_args.require_binary(ap, "--grains", a.grains)
    {"throughput": throughput, "cycle": cycle, "settings": settings}[a.what](a)


if __name__ == "__main__":
    main()
