"""Consolidation benchmarks (not part of the test suite).

    python runner/bench_consolidation.py throughput [--steps 20000]
    python runner/bench_consolidation.py cycle [--count 1400]
    python runner/bench_consolidation.py settings [--count 300]

throughput: particle-steps per second on the 1400 cohesive disks of models/consolidation-rr.toml
  (friction, rolling resistance, barostat on), with the barostat off, and with CVODE restarted every
  step instead of keeping its history; the CVODE share of the wall time for each.
cycle: one full type-2 preparation + loading + unloading cycle (models/consolidation.toml): stages,
  steps, particle-steps per second, the CVODE share, and stages that missed equilibrium.
settings: what the equilibrium tolerance, the CVODE tolerance, I_a and n_c cost (wall time, steps) and
  change (Phi at equilibrium) on a cohesionless packing, each against the tightest setting.
"""
import argparse
import csv
import pathlib
import re
import subprocess
import tempfile
import time

import h5py

ROOT = pathlib.Path(__file__).resolve().parents[1]


def grains(args, binary):
    t = time.perf_counter()
    r = subprocess.run([binary, *map(str, args)], capture_output=True, text=True, check=True)
    return r.stdout, time.perf_counter() - t


def throughput(a):
    print("| variant | particle-steps/s | CVODE share |")
    print("|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for name, extra in (("barostat on", []), ("barostat off", ["cell.enabled=false"]),
                            ("CVODE restarted every step", ["cell.restart_cvode_every_step=true"])):
            out = pathlib.Path(d) / "t.h5"
            sets = [x for e in [f"time.steps={a.steps}", f"output.observables_every={a.steps}", *extra] for x in ("--set", e)]
            stdout, _ = grains(["run", ROOT / "models" / "consolidation-rr.toml", "--out", out, "--quiet", *sets], a.grains)
            rate = float(re.search(r"\(([0-9.e+]+) particle-steps/s", stdout).group(1))
            wall = float(re.search(r"wall time\s+([0-9.]+) s", stdout).group(1))
            share = "-"
            with h5py.File(out) as f:
                if "cvode_seconds" in f["observables"]:
                    share = f"{100 * f['observables/cvode_seconds/value'][-1] / wall:.1f} %"
            print(f"| {name} | {rate:.3g} | {share} |")


def cycle(a):
    with tempfile.TemporaryDirectory() as d:
        stdout, wall = grains(["consolidate", ROOT / "models" / "consolidation.toml", "--quiet", "--table",
                               pathlib.Path(d) / "c.csv", "--out", pathlib.Path(d) / "c.h5", "--set",
                               f"particles.count={a.count}"], a.grains)
    print(stdout)
    print(f"cycle wall time {wall:.1f} s")


def settings(a):
    base = ["particles.count=%d" % a.count]
    variants = [("tightest", ["cell.tolerance_force=1e-6", "cell.tolerance_torque=1e-6", "cell.tolerance_stress=1e-6",
                              "cell.tolerance_kinetic=5e-9", "cell.rtol=1e-8", "cell.inertia_number=0.01",
                              "time.steps_per_contact=100"]),
                ("defaults", []),
                ("equilibrium tolerances x10", ["cell.tolerance_force=1e-4", "cell.tolerance_torque=1e-4",
                                                "cell.tolerance_stress=1e-4", "cell.tolerance_kinetic=5e-7"]),
                ("CVODE rtol 1e-4", ["cell.rtol=1e-4"]),
                ("I_a = 0.2", ["cell.inertia_number=0.2"]),
                ("n_c = 25", ["time.steps_per_contact=25"])]
    print("| setting | wall s | steps | Phi | Phi - Phi(tightest) |")
    print("|---|---|---|---|---|")
    reference = None
    with tempfile.TemporaryDirectory() as d:
        for name, extra in variants:
            table = pathlib.Path(d) / "s.csv"
            sets = [x for e in base + extra for x in ("--set", e)]
            _, wall = grains(["consolidate", ROOT / "models" / "cohesionless.toml", "--quiet", "--table", table, "--out",
                              pathlib.Path(d) / "s.h5", *sets], a.grains)
            row = list(csv.DictReader(table.open()))[-1]
            phi = float(row["phi"])
            reference = phi if reference is None else reference
            flag = "" if row["reached"] == "1" else " (not in equilibrium)"
            print(f"| {name} | {wall:.1f} | {row['steps']} | {phi:.5f}{flag} | {phi - reference:+.5f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["throughput", "cycle", "settings"])
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--count", type=int)
    ap.add_argument("--grains", default=str(ROOT / "build" / "runner" / "grains"))
    a = ap.parse_args()
    if a.count is None:
        a.count = 1400 if a.what == "cycle" else 300
    {"throughput": throughput, "cycle": cycle, "settings": settings}[a.what](a)


if __name__ == "__main__":
    main()
