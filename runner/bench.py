"""Side-by-side throughput benchmark: grains against LAMMPS on the `gas` scene.

    python runner/bench.py [--steps 3000] [--repeat 1] [--peers ../shared/peers] [--no-lammps]

Runs the frictionless and frictional gas (17,576 spheres) with grains and LAMMPS (Debian's `lmp`,
the peer inputs in ../shared/peers), on one core and on two, in one session, and prints particle-steps
per second and the grains/LAMMPS ratio for each. Machines here are shared and noisy: compare the
ratios, not the absolute numbers, and only within one run. With --repeat R every configuration runs R
times, grains and LAMMPS back to back each time; the table gives the medians and the range of the R
back-to-back ratios, and the ratio of each code's fastest run (best / best).
"""
import argparse
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

import h5py

from compare_lammps import lammps_pair_style

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import child_runs  # noqa: E402
import lammps_peers  # noqa: E402
import tool_args  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent


def grains_rate(binary, scene, steps, threads, workdir):
    out = workdir / f"{scene}-{threads}.h5"
    child_runs.run_grains("bench.py", [binary, "run", ROOT / "models" / f"{scene}.toml", "--quiet", "--out", out,
                                       "--set", f"time.steps={steps}", "--set", f"run.threads={threads}",
                                       "--set", "output.snapshots_every=0", "--set", f"output.observables_every={steps}",
                                       "--set", "output.xdmf=false"])
    with h5py.File(out, "r") as f:
        build = f["grains"].attrs.get("pair_loop_build", b"?")   # which vector build of the pair loop ran
        build = build.decode() if isinstance(build, bytes) else str(build)
        return float(f["grains"].attrs["particle_steps_per_second"]), build


def lammps_rate(peers, steps, threads, friction, workdir):
    data = workdir / "gas.data"
    if not data.exists():
        subprocess.run([sys.executable, str(peers / "gas_data.py"), "26", "0.3", str(data)], check=True)
    script = (peers / "gas.lmp").read_text()
    if friction:   # the peer README's frictional variant: k_t = 2/7 k_n, gamma_t = gamma_n / 2, mu = 0.5
        script = re.sub(r"pair_style gran/hooke .*", lammps_pair_style(True), script)
    inp = workdir / ("gas-friction.lmp" if friction else "gas.lmp")
    inp.write_text(script)
    cmd = ["lmp", "-in", str(inp), "-var", "data", str(data), "-var", "steps", str(steps), "-log", "none"]
    if threads > 1:
        cmd = ["mpirun", "--allow-run-as-root", "-np", str(threads)] + cmd
    text = subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=workdir).stdout
    m = re.search(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", text)
    if not m:
        raise RuntimeError("could not read LAMMPS' loop time:\n" + text[-2000:])
    seconds, n_steps, atoms = float(m.group(1)), int(m.group(2)), int(m.group(3))
    return n_steps * atoms / seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--peers", type=pathlib.Path, default=None,
                    help="folder of the LAMMPS peer inputs (default: the workspace's shared/peers; without them, grains only)")
    ap.add_argument("--binary", type=pathlib.Path, default=ROOT / "build" / "runner" / "grains")
    ap.add_argument("--no-lammps", action="store_true", help="grains only")
    ap.add_argument("--repeat", type=int, default=1, help="runs of every configuration (medians reported)")
    args = ap.parse_args()
    args.peers = lammps_peers.peers_folder(ap, args.peers, "gas.lmp", ROOT.parent / "shared" / "peers")
    tool_args.require_binary(ap, "--binary", args.binary)
    tool_args.require_counts(ap, steps=args.steps, repeat=args.repeat)
    have_lammps = not args.no_lammps and shutil.which("lmp") and (args.peers / "gas.lmp").exists()
    if not args.no_lammps and not have_lammps:
        print(f"note: {lammps_peers.peer_missing(args.peers, 'gas.lmp')}: grains only, no ratios", file=sys.stderr)

    runs = {}   # (scene, threads) -> [(grains, LAMMPS)] in run order
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        for r in range(max(1, args.repeat)):
            for scene, friction in (("gas", False), ("gas-friction", True)):
                for threads in (1, 2):
                    g, build = grains_rate(args.binary, scene, args.steps, threads, work)
                    lmp = lammps_rate(args.peers, args.steps, threads, friction, work) if have_lammps else float("nan")
                    runs.setdefault((scene, threads), []).append((g, lmp))
                    print(f"{scene:13s} {threads} core(s), run {r + 1}: grains {g:.3g}  LAMMPS {lmp:.3g}  ratio {g / lmp:.2f}",
                          flush=True)
    rows = []
    for (scene, threads), pairs in runs.items():
        ratios = [g / lmp for g, lmp in pairs]
        rows.append((scene, threads, statistics.median(g for g, _ in pairs), statistics.median(l for _, l in pairs),
                     statistics.median(ratios), min(ratios), max(ratios),
                     max(g for g, _ in pairs) / max(l for _, l in pairs)))
    n = max(1, args.repeat)
    print(f"\nparticle-steps per second, gas scene (17,576 spheres), {args.steps} steps" + (f", medians of {n} runs" if n > 1 else "") +
          f"; grains' pair loop: {build}")
    # The host's noise only ever slows a run down, so each code's fastest run is the best estimate of its
    # undisturbed speed: "best / best" is the ratio of the two.
    print("| scene | cores | grains | LAMMPS | grains / LAMMPS | range | best / best |")
    print("|---|---|---|---|---|---|---|")
    for scene, threads, g, lmp, ratio, low, high, best in rows:
        print(f"| {scene} | {threads} | {g:.3g} | {lmp:.3g} | {ratio:.2f} | {low:.2f}-{high:.2f} | {best:.2f} |")
    by = {(s, t): g for s, t, g, *_ in rows}
    print(f"\nfrictionless / frictional (grains, 1 core): {by[('gas', 1)] / by[('gas-friction', 1)]:.2f}")
    print(f"two cores / one core (grains, frictionless): {by[('gas', 2)] / by[('gas', 1)]:.2f}")


if __name__ == "__main__":
    main()
