"""Throughput of the consolidation contact law in 2D against LAMMPS, on the same disks.

    python runner/bench_cohesive.py [--steps 20000] [--cells 35] [--peers ../shared/peers]

The peer input ../shared/peers/disks2d.lmp (periodic 2D disks, d = 1, m = 1, on a hexagonal lattice
of reduced density 1.05, gran/hooke/history with k_n = 1e5, gamma_n = 50, mu = 0.5, dt = 1e-4, skin
0.1, temperature 0.01) is run with its region cut to --cells x 20 unit cells (35 -> 1400 disks).
grains runs the same disks (positions, masses, dt, skin, Gaussian velocities of the same temperature)
with the consolidation law at the paper's Table I values in units a = F0 = 1: adhesion (K_N = 1e5,
D0 = 1e-3, e_N = 0.015), friction mu = 0.5, K_T = K_N, and rolling resistance mu_R = 0.005, K_R = 1e-4
K_N a^2; then without rolling, and with the peer's own law (the frictional spring-dashpot, no adhesion:
k_n = 1e5 and gamma_n = 50 as e = 0.839 and t_c = 0.00704, k_t = 2/7 k_n, no tangential dashpot), to show what
each module costs. LAMMPS has neither adhesion nor rolling in gran/hooke/history, so its pair
work per contact is smaller. Both codes on one core, then two (--threads: at most the machine's cores). Each
code is timed after a warm-up of 1000 steps, the peer file's `run 1000` (grains: a run of 1000 + --steps steps
less one of 1000; timed from its first step, a short run read 1.6-1.7 times LAMMPS at --steps 300, 2.0-2.3 at
20000; grains' runs each taken three times, the fastest kept). The disks start on a lattice without contacts, which
form over the first thousands of steps, and grains' work per step grows with them: a short run times the
contact-free start (ratios of 5-10 at --steps 300); compare at the default 20000. Machines here are shared and noisy:
compare ratios within one run.
"""
import argparse
import math
import os
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import child_runs  # noqa: E402
import lammps_peers  # noqa: E402
import tool_args  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
DENSITY = 1.05    # the peer's `lattice hex 1.05`
TEMPERATURE = 0.01


def hex_lattice(cells_x, cells_y):
    """Centres of LAMMPS' 2D `lattice hex` (two disks per a x a sqrt(3) cell) and the box lengths."""
    a = math.sqrt(2 / (DENSITY * math.sqrt(3)))
    basis = [(0.0, 0.0), (0.5, 0.5)]
    x = [((i + bx) * a, (j + by) * a * math.sqrt(3)) for j in range(cells_y) for i in range(cells_x) for bx, by in basis]
    return np.array(x), (cells_x * a, cells_y * a * math.sqrt(3))


# grains refuses a periodic box no longer than twice the interaction reach, 2 R_max + the adhesion range D0 + the skin
# (1 + 0.001 + 0.1 here); along x the box is --cells lattice constants long, and fewer cells than this would end the
# benchmark, after its first LAMMPS run, in grains' message about box lengths, which does not name --cells.
REACH = 1.0 + 1e-3 + 0.1
MIN_CELLS = math.floor(2 * REACH / hex_lattice(1, 1)[1][0]) + 1


# disks2d.lmp's warm-up (`run 1000` before the timed `run 20000`): grains gets the same before its timed steps, or a
# short benchmark counts its start (first neighbour lists, caches, threads) against it alone.
WARMUP = 1000
# Each grains run of a rate is taken this often and the fastest kept: a run's start varies by milliseconds here (1000
# steps of 1400 disks took 8-17 ms), which is all a short benchmark's timed steps take (the host's noise only slows).
TRIES = 3


# disks2d.lmp's pair style; `peer_pair_style` reads the peer file's own line when it is there.
PEER_PAIR_STYLE = "pair_style gran/hooke/history 100000.0 NULL 50.0 NULL 0.5 0"


def peer_pair_style(peers):
    """The `pair_style` line of the peer's disks2d.lmp (this file's copy if the peer inputs are absent)."""
    path = peers / "disks2d.lmp"
    if not path.exists():
        return PEER_PAIR_STYLE
    lines = [line.strip() for line in path.read_text().splitlines() if line.strip().startswith("pair_style")]
    if len(lines) != 1:
        raise ValueError(f"{path}: expected one pair_style line, found {len(lines)}")
    return lines[0]


def hooke_history_law(pair_style, mstar=0.5, contact_extra=""):
    """grains' [contact] and [friction] tables for LAMMPS' `pair_style gran/hooke/history Kn Kt gamma_n gamma_t
    xmu dampflag`, for pairs of reduced mass m*. LAMMPS: Kt NULL is 2/7 Kn, gamma_t NULL is gamma_n / 2, its
    dashpots are m* gamma v, and dampflag 0 drops the tangential one (gamma_t = 0). With zeta = m* gamma_n /
    (2 sqrt(m* k_n)): e = exp(-pi zeta / sqrt(1 - zeta^2)), t_c = pi / (sqrt(k_n / m*) sqrt(1 - zeta^2)), from
    which grains' calibration gives back k_n and c_n. contact_extra: further [contact] lines."""
    words = pair_style.split()
    if words[:2] != ["pair_style", "gran/hooke/history"] or len(words) != 8:
        raise ValueError(f"not a gran/hooke/history pair style with six values: {pair_style!r}")
    kn, gamma_n, mu = float(words[2]), float(words[4]), float(words[6])
    kt = 2 / 7 * kn if words[3] == "NULL" else float(words[3])
    gamma_t = gamma_n / 2 if words[5] == "NULL" else float(words[5])
    if int(words[7]) == 0:
        gamma_t = 0.0
    zeta = mstar * gamma_n / (2 * math.sqrt(mstar * kn))
    root = math.sqrt(1 - zeta * zeta)
    e, tc = math.exp(-math.pi * zeta / root), math.pi / (math.sqrt(kn / mstar) * root)
    return (f"[contact]\nrestitution = {e!r}\nduration = {tc!r}\n{contact_extra}"
            f"[friction]\ncoefficient = {mu!r}\nstiffness_ratio = {kt / kn!r}\ndamping_ratio = {gamma_t / gamma_n!r}\n")


def disk_state(work, cells_x):
    """The peer's disks (its lattice, unit diameter and mass) with Gaussian velocities of its temperature,
    written as a grains particle table: (table, centres, velocities, box lengths)."""
    centres, lengths = hex_lattice(cells_x, 20)
    rng = np.random.default_rng(4928459)
    v = rng.standard_normal(centres.shape) * math.sqrt(TEMPERATURE)   # kT = m <v_x^2>, m = 1
    v -= v.mean(axis=0)
    table = work / f"disks-{cells_x}.txt"
    with open(table, "w") as f:
        for (x, y), (vx, vy) in zip(centres, v):
            f.write(f"{x:.17g} {y:.17g} 1 1 {vx:.17g} {vy:.17g}\n")
    return table, centres, v, lengths


def grains_scene(work, cells_x, variant, pair_style):
    table, centres, _, lengths = disk_state(work, cells_x)
    law = {
        "adhesion+friction+rolling": "[adhesion]\nenabled = true\n[friction]\ncoefficient = 0.5\n[rolling]\ncoefficient = 0.005\n",
        "adhesion+friction": "[adhesion]\nenabled = true\n[friction]\ncoefficient = 0.5\n",
        "spring-dashpot+friction": hooke_history_law(pair_style),
    }[variant]
    scene = work / f"{variant}-{cells_x}.toml"
    scene.write_text(f"""[scene]
name = "cohesive-disks"
dimension = 2
[particles]
layout = "file"
file = "{table}"
[box]
lengths = [{lengths[0]!r}, {lengths[1]!r}]
[time]
dt = 1e-4
[neighbours]
skin = 0.1
{law}""")
    return scene, len(centres)


def grains_run(binary, scene, steps, threads, work):
    """(wall seconds of the stepping, contacts at the end, pair loop build) of a grains run of `steps` steps."""
    out = work / "run.h5"
    child_runs.run_grains("bench_cohesive.py", [binary, "run", scene, "--quiet", "--out", out, "--set", f"time.steps={steps}",
                                                "--set", f"run.threads={threads}", "--set", "output.snapshots_every=0",
                                                "--set", f"output.observables_every={steps}", "--set", "output.xdmf=false"])
    with h5py.File(out, "r") as f:
        contacts = float(f["observables/contacts/value"][-1])
        build = f["grains"].attrs.get("pair_loop_build", b"?")   # which vector build of the pair loop ran
        build = build.decode() if isinstance(build, bytes) else str(build)
        return float(f["grains"].attrs["wall_seconds"]), contacts, build


def grains_rate(binary, scene, steps, threads, work, particles):
    """grains' particle-steps per second over `steps` steps after WARMUP ones, as LAMMPS is timed: the wall time of a
    run of WARMUP + steps less that of a run of WARMUP (grains times a run from its first step), each the fastest of
    TRIES."""
    warm = min(grains_run(binary, scene, WARMUP, threads, work)[0] for _ in range(TRIES))
    runs = [grains_run(binary, scene, WARMUP + steps, threads, work) for _ in range(TRIES)]
    total, contacts, build = min(runs)
    if not total > warm:
        sys.exit(f"bench_cohesive.py: grains' {steps} timed steps took no measurable time ({total:.3g} s with the "
                 f"{WARMUP}-step warm-up, {warm:.3g} s without): give more --steps")
    return steps * particles / (total - warm), contacts, build


def lammps_rate(peers, cells_x, steps, threads, work):
    script = (peers / "disks2d.lmp").read_text()
    script = re.sub(r"region box block 0 105 0 20", f"region box block 0 {cells_x} 0 20", script)
    script = re.sub(r"run 20000", f"run {steps}", script)
    inp = work / "disks2d.lmp"
    inp.write_text(script)
    cmd = ["lmp", "-in", str(inp), "-log", "none"]
    if threads > 1:
        cmd = ["mpirun", "--allow-run-as-root", "-np", str(threads)] + cmd
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=work)
    if done.returncode != 0:   # mpirun's reason (too few slots, say) was captured and hidden behind a traceback
        said = "; ".join(line.strip() for line in (done.stderr + done.stdout).splitlines() if line.strip())[-600:]
        sys.exit(f"bench_cohesive.py: {' '.join(cmd[:4] if threads > 1 else cmd[:1])} ended with status "
                 f"{done.returncode}: {said or 'it said nothing'}")
    text = done.stdout
    loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", text)
    if not loops:
        raise RuntimeError("could not read LAMMPS' loop time:\n" + text[-2000:])
    seconds, n_steps, atoms = loops[-1]   # the timed run, after the 1000-step warm-up
    return int(n_steps) * int(atoms) / float(seconds)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--cells", type=int, default=35, help="hexagonal cells along x (x 20 along y, 2 disks each)")
    ap.add_argument("--peers", type=pathlib.Path, default=None,
                    help="folder of the LAMMPS peer inputs (default: the workspace's shared/peers; without them, grains only)")
    ap.add_argument("--binary", type=pathlib.Path, default=ROOT / "build" / "runner" / "grains")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds (each grains law right after a LAMMPS run, each round); medians and the range of the ratios")
    args = ap.parse_args()
    args.peers = lammps_peers.peers_folder(ap, args.peers, "disks2d.lmp", ROOT.parent / "shared" / "peers")
    tool_args.require_binary(ap, "--binary", args.binary)
    tool_args.require_counts(ap, steps=args.steps, repeat=args.repeat)
    if args.cells < MIN_CELLS:
        ap.error(f"--cells = {args.cells}: must be at least {MIN_CELLS}: grains needs the periodic box along x "
                 f"({args.cells} x {hex_lattice(1, 1)[1][0]:.4g}) longer than twice the interaction reach, {2 * REACH:.4g}")
    try:
        tool_args.require_counts(ap, threads=min(int(t) for t in args.threads.split(",")))
    except ValueError:
        ap.error(f"--threads {args.threads}: give core counts separated by commas, such as 1,2")
    # more ranks than cores: mpirun refuses them (after the runs before), and a rate on shared cores says nothing
    cores = len(os.sched_getaffinity(0))
    if (most := max(int(t) for t in args.threads.split(","))) > cores:
        ap.error(f"--threads {args.threads}: {most} is more than the {cores} core(s) this machine gives the benchmark")
    have_lammps = shutil.which("lmp") and (args.peers / "disks2d.lmp").exists()
    if not have_lammps:
        print(f"note: {lammps_peers.peer_missing(args.peers, 'disks2d.lmp')}: grains only, no ratios", file=sys.stderr)
    runs = {}   # (variant, threads) -> [(grains, LAMMPS of the same round, contacts)]
    pair_style = peer_pair_style(args.peers)
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        for r in range(max(1, args.repeat)):
            for threads in (int(t) for t in args.threads.split(",")):
                for variant in ("adhesion+friction+rolling", "adhesion+friction", "spring-dashpot+friction"):
                    # LAMMPS right before each grains run: on this noisy host a rate measured a minute
                    # earlier can be half or twice the one of the moment.
                    lmp = lammps_rate(args.peers, args.cells, args.steps, threads, work) if have_lammps else float("nan")
                    scene, n = grains_scene(work, args.cells, variant, pair_style)
                    g, contacts, build = grains_rate(args.binary, scene, args.steps, threads, work, n)
                    runs.setdefault((variant, threads), []).append((g, lmp, contacts))
                    print(f"{variant:26s} {threads} core(s), round {r + 1}: grains {g:.3g} (contacts at the end "
                          f"{contacts:.0f})  LAMMPS gran/hooke/history {lmp:.3g}  ratio {g / lmp:.2f}", flush=True)
    rounds = max(1, args.repeat)
    print(f"\nparticle-steps per second, {n} periodic 2D disks, {args.steps} steps after a {WARMUP}-step warm-up" +
          (f", medians of {rounds} rounds" if rounds > 1 else "") + f"; grains' pair loop: {build}")
    # best / best: each code's fastest run (the host's noise only ever slows a run down).
    print("| grains law | cores | grains | LAMMPS gran/hooke/history | grains / LAMMPS | range | best / best |")
    print("|---|---|---|---|---|---|---|")
    for (variant, threads), results in runs.items():
        ratios = [g / lmp for g, lmp, _ in results]
        g = statistics.median(x for x, _, _ in results)
        lmp = statistics.median(x for _, x, _ in results)
        best = max(x for x, _, _ in results) / max(x for _, x, _ in results)
        print(f"| {variant} | {threads} | {g:.3g} | {lmp:.3g} | {statistics.median(ratios):.2f} | "
              f"{min(ratios):.2f}-{max(ratios):.2f} | {best:.2f} |")

if __name__ == "__main__":
    main()
