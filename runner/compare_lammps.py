"""The physics side by side with LAMMPS: the same initial states run by both codes, compared number by number.

    python runner/compare_lammps.py [--steps 5000] [--out DIR] [--peers ../shared/peers]

1. The `gas` scene (17,576 spheres, e = 0.9, t_c = 0.05, dt = 0.001), frictionless and frictional:
   ../shared/peers/gas_data.py writes one initial state, both codes start from it (grains through
   particles.layout = "file"), and the translational and rotational kinetic energy per particle are
   compared every 250 steps.
2. What one collision dissipates, averaged over impact parameters: 400 separate pairs of spheres at
   relative speed 1 with impact parameters b = d sqrt((k + 1/2) / 400) (uniform in b^2, as collisions in a
   gas), each pair far from the others, at the gas's dt and at dt / 100. In a homogeneous cooling gas the
   cooling rate is proportional to this dissipation (Haff's law, T(t) = T0 / (1 + t / tau)^2), so its
   ratio between the codes predicts the ratio of their gas temperatures.

3. The 2D disks of ../shared/peers/disks2d.lmp (1400 disks on its hexagonal lattice, gran/hooke/history
   k_n = 1e5, gamma_n = 50, k_t = 2/7 k_n, mu = 0.5, nve/sphere disc, dt = 1e-4; its dampflag 0 drops the
   tangential dashpot, so grains runs c_t = 0) from one state with Gaussian velocities of temperature
   0.01: both energies every 1000 steps.

LAMMPS' last pair_style word, dampflag, decides whether its tangential dashpot exists: the frictional
gas (the peer README's gamma_t = gamma_n / 2) needs 1. Until 2026-12-04 this script passed 0, and the
codes' frictional collisions differed by 14 %, which was wrongly put down to (b) below.

The models differ in two places. (a) physics.md section 2's non-adhesion clamp: grains never lets the
dashpot pull (F_n = max(0, k delta - c v_n)); LAMMPS' gran/hooke does, at the end of each contact, so
the clamped contact returns more energy (a head-on e = 0.9 collision realises e = 0.902). (b) A sliding
contact with a tangential dashpot: LAMMPS sets its spring to k_t xi = -(F_t + c_t v_t), which stores the
dashpot's share as stretch; grains only ever shortens the spring to the Coulomb bound (the passive
rule, contact_forces.hpp). On part 2's pairs at dt / 100 the two rules dissipate the same to 1e-5
(measured in a scratch build). LAMMPS' half-step dashpot velocity also shifts its realised e at
dt = t_c / 50; part 2 at dt / 100 shows both codes converged.

Writes summary.md (the tables) and lammps-comparison.png into --out. Needs LAMMPS (`lmp`, Debian's
`lammps`): `bash runner/with_lammps.sh compare_lammps.py` installs it, builds grains and runs this.
"""
import argparse
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

from bench_cohesive import disk_state, hooke_history_law, peer_pair_style

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import run_files  # noqa: E402
import tool_args  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
DIAMETER, MASS = 1.0, 1.0
TC, E, DT = 0.05, 0.9, 0.001
FRICTION = {"coefficient": 0.5, "stiffness_ratio": 2 / 7, "damping_ratio": 0.5}   # the peer README's frictional variant
EVERY = 250
PAIRS = 400


def out_folder_problem(out, names):
    """Why --out cannot be the folder the files `names` are written into, or None. The LAMMPS comparisons check it
    before their runs (minutes long), which ended in a traceback where --out named a file or a place no folder can
    be made, and make the folder only to write into it (make_out_after_runs), so that a failed run leaves none behind."""
    out = pathlib.Path(out)
    if out.is_dir():
        if not os.access(out, os.W_OK | os.X_OK):
            return f"--out {out}: no permission to write into this folder"
        for name in names:
            if kind := run_files.not_a_regular_file(out / name):
                return f"--out {out}: {out / name} is {kind}: move it out of the way, or give another --out"
        return None
    if os.path.lexists(out):
        kind = run_files.not_a_regular_file(out) or ("a file" if out.exists() else "a link to nothing")
        return f"--out {out} is {kind}, not a folder: give a folder (made if missing)"
    place = next(p for p in out.absolute().parents if p.exists())   # the folder it would be made in
    if not place.is_dir():
        return f"--out {out}: no folder can be made there: {place} is {run_files.not_a_regular_file(place) or 'a file'}"
    if not os.access(place, os.W_OK | os.X_OK):
        return f"--out {out}: no folder can be made there: no permission to write into {place}"
    return None


def make_out_after_runs(ap, out):
    """Makes the --out folder (out_folder_problem found nothing against it before the runs)."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        ap.exit(1, f"{ap.prog}: error: --out {out}: cannot make the folder ({error.strerror}); the tables are printed above\n")


def run(cmd, cwd):
    done = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return done.stdout


def lammps_pair_style(friction):
    """gas.lmp's pair style (k_n, gamma_n from e and t_c for m* = 1/2), or the peer README's frictional
    variant with FRICTION's values. The last word, dampflag, must be 1 for a tangential dashpot: 0 drops it."""
    kn = 0.5 * (math.pi ** 2 + math.log(E) ** 2) / TC ** 2
    gn = -2 * math.log(E) / TC
    if friction:
        damped = 1 if FRICTION["damping_ratio"] > 0 else 0
        return (f"pair_style gran/hooke/history {kn!r} {FRICTION['stiffness_ratio'] * kn!r} {gn!r} "
                f"{FRICTION['damping_ratio'] * gn!r} {FRICTION['coefficient']!r} {damped}")
    return f"pair_style gran/hooke {kn!r} 0.0 {gn!r} 0.0 0.0 0"


def lammps_script(data, friction, boundary, steps, every, dt):
    """gas.lmp's model (k_n, gamma_n from e and t_c for m* = 1/2) with the totals of both energies as output."""
    return f"""units lj
atom_style sphere
dimension 3
boundary {boundary}
comm_modify vel yes
read_data {data}
{lammps_pair_style(friction)}
pair_coeff * *
neighbor 0.2 bin
neigh_modify delay 0 every 1 check yes
fix 1 all nve/sphere
timestep {dt!r}
compute rot all erotate/sphere
thermo_style custom step ke c_rot
thermo_modify norm no format float %.15g
thermo {every}
run {steps}
"""


def lammps_thermo(work, name, script):
    """Runs a LAMMPS script whose thermo output is `step <translational> <rotational>`; their rows as an array."""
    (work / f"{name}.lmp").write_text(script)
    text = run(["lmp", "-in", f"{name}.lmp", "-log", "none"], work)
    rows = re.findall(r"^\s+(\d+)\s+([-0-9.eE+]+)\s+([-0-9.eE+]+)\s*$", text, re.MULTILINE)
    return np.array(rows, dtype=float)


def lammps_energies(work, name, data, friction, boundary, steps, every, dt):
    """(step, translational, rotational) totals from LAMMPS' thermo output."""
    return lammps_thermo(work, name, lammps_script(data, friction, boundary, steps, every, dt))


def grains_scene(work, name, table, lengths, periodic, law, steps, every, dt, skin, particles_extra="", snapshots_every=0):
    """A grains scene of the particles in `table` (file layout), the contact law given as scene text.
    particles_extra: further [particles] lines (such as angular_velocities); snapshots_every: 0 = none."""
    scene = work / f"{name}.toml"
    scene.write_text(f"""[scene]
name = "{name}"
dimension = {len(lengths)}
[particles]
layout = "file"
file = "{table.name}"
{particles_extra}[box]
periodic = {str(periodic).lower()}
lengths = [{", ".join(repr(float(l)) for l in lengths)}]
[time]
dt = {dt!r}
steps = {steps}
[neighbours]
skin = {skin!r}
[output]
observables_every = {every}
snapshots_every = {snapshots_every}
xdmf = false
{law}""")
    return scene


def gas_law(friction):
    """gas.lmp's law (and the peer README's frictional variant) as grains scene text."""
    law = f"[contact]\nrestitution = {E!r}\nduration = {TC!r}\noverlap_limit = 1.0\n"
    if friction:
        law += "[friction]\n" + "".join(f"{k} = {v!r}\n" for k, v in FRICTION.items())
    return law


def grains_energies(binary, work, scene):
    out = work / (scene.stem + ".h5")
    run([binary, "run", scene, "--quiet", "--out", out, "--set", "run.threads=1"], work)
    with h5py.File(out, "r") as f:
        o = f["observables"]
        return np.c_[o["translational_energy/step"][:], o["translational_energy/value"][:], o["rotational_energy/value"][:]]


def write_table(path, x, v, diameters=None, masses=None):
    """grains' file layout: x y [z] diameter mass vx vy [vz] (as many coordinates as x has columns);
    every particle DIAMETER and MASS unless diameters and masses are given."""
    x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
    d = np.full(len(x), DIAMETER) if diameters is None else np.asarray(diameters, dtype=float)
    m = np.full(len(x), MASS) if masses is None else np.asarray(masses, dtype=float)
    with open(path, "w") as f:
        for p, u, dk, mk in zip(x, v, d, m):
            f.write(" ".join(f"{c:.17g}" for c in (*p, dk, mk, *u)) + "\n")


def lammps_data(path, x, v, lo, hi, diameters=None, masses=None, types=None, spins=None):
    """LAMMPS' data file (atom_style sphere) of the particles: every particle DIAMETER and MASS of type 1 and
    without spin unless diameters, masses, types (1, 2, ...) and spins (n x 3) are given. read_data makes a
    sphere's mass from the density, in 2D too (4/3 pi r^3 rho): the density written gives back the mass."""
    n = len(x)
    d = np.full(n, DIAMETER) if diameters is None else np.asarray(diameters, dtype=float)
    m = np.full(n, MASS) if masses is None else np.asarray(masses, dtype=float)
    t = np.ones(n, dtype=int) if types is None else np.asarray(types, dtype=int)
    w = np.zeros((n, 3)) if spins is None else np.asarray(spins, dtype=float)
    with open(path, "w") as f:
        f.write(f"grains compare_lammps\n\n{n} atoms\n{t.max()} atom types\n\n")
        for a in range(3):
            f.write(f"{float(lo[a])!r} {float(hi[a])!r} {'xyz'[a]}lo {'xyz'[a]}hi\n")
        f.write("\nAtoms\n\n")
        for i, p in enumerate(x, 1):
            density = m[i - 1] / (math.pi / 6 * d[i - 1] ** 3)
            f.write(f"{i} {t[i - 1]} {float(d[i - 1])!r} {float(density)!r} {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n")
        f.write("\nVelocities\n\n")
        for i, u in enumerate(v, 1):
            f.write(f"{i} {u[0]:.17g} {u[1]:.17g} {u[2]:.17g} {w[i - 1][0]:.17g} {w[i - 1][1]:.17g} {w[i - 1][2]:.17g}\n")


def read_lammps_data(path):
    lines = path.read_text().splitlines()
    atoms, vels = lines.index("Atoms"), lines.index("Velocities")
    n = int(next(l for l in lines if l.endswith(" atoms")).split()[0])
    xlo, xhi = next(l for l in lines if l.endswith("xlo xhi")).split()[:2]
    a = np.array([l.split() for l in lines[atoms + 2:atoms + 2 + n]], dtype=float)
    v = np.array([l.split() for l in lines[vels + 2:vels + 2 + n]], dtype=float)
    length = float(xhi) - float(xlo)
    return a[:, 4:7], v[:, 1:4], length


def pair_ensemble():
    """PAIRS head-on-to-grazing pairs along x, 10 diameters apart, relative speed 1 along x."""
    b = DIAMETER * np.sqrt((np.arange(PAIRS) + 0.5) / PAIRS)
    x, v = [], []
    for k, bk in enumerate(b):
        centre = 10.0 * k
        x += [(centre - 0.6, -bk / 2, 0.0), (centre + 0.6, bk / 2, 0.0)]
        v += [(0.5, 0.0, 0.0), (-0.5, 0.0, 0.0)]
    return np.array(x), np.array(v)


DISK_CELLS, DISK_STEPS, DISK_DT, DISK_EVERY = 35, 20000, 1e-4, 1000


def disks(binary, work, pair_style):
    """Part 3: disks2d.lmp's law and lattice, one initial state, (step, translational, rotational) per code."""
    table, centres, v, lengths = disk_state(work, DISK_CELLS)
    # In 2D too read_data gives a sphere's mass (density 4/3 pi r^3): lammps_data's density makes it 1.
    flat = lambda a: np.c_[a, np.zeros(len(a))]   # z = 0
    lammps_data(work / "disks.data", flat(centres), flat(v), (0.0, 0.0, -0.5), (lengths[0], lengths[1], 0.5))
    lmp = lammps_thermo(work, "disks", f"""units lj
dimension 2
atom_style sphere
boundary p p p
comm_modify vel yes
read_data disks.data
{pair_style}
pair_coeff * *
neighbor 0.1 bin
neigh_modify every 1 delay 0
timestep {DISK_DT!r}
fix 3 all nve/sphere disc
fix 4 all enforce2d
# erotate/sphere would use a sphere's I = 2/5 m r^2; the disks turn with I = 1/2 m r^2 (nve/sphere disc)
compute disc all property/atom radius omegaz
variable spin atom 0.25*mass*c_disc[1]^2*c_disc[2]^2
compute rot all reduce sum v_spin
thermo_style custom step ke c_rot
thermo_modify norm no format float %.15g
thermo {DISK_EVERY}
run {DISK_STEPS}
""")
    law = hooke_history_law(pair_style, contact_extra="overlap_limit = 1.0\n")
    scene = grains_scene(work, "disks", table, lengths, True, law, DISK_STEPS, DISK_EVERY, DISK_DT, 0.1)
    g = grains_energies(binary, work, scene)
    if len(lmp) != len(g) or not np.array_equal(lmp[:, 0], g[:, 0]):
        raise RuntimeError("disks: the two codes' output steps differ")
    return g, lmp, len(centres)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=5000, help="gas steps (dt = 0.001)")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("lammps-comparison"))
    ap.add_argument("--peers", type=pathlib.Path, default=ROOT.parent / "shared" / "peers")
    ap.add_argument("--binary", type=pathlib.Path, default=ROOT / "build" / "runner" / "grains")
    args = ap.parse_args()
    tool_args.require_counts(ap, steps=args.steps)
    if problem := out_folder_problem(args.out, ["summary.md", "lammps-comparison.png"]):
        ap.error(problem)
    tool_args.require_binary(ap, "--binary", args.binary)
    if not (args.peers / "gas_data.py").is_file():
        ap.error(f"--peers {args.peers}: no gas_data.py there (the shared peer inputs)")
    args.binary = args.binary.resolve()   # the runs start in a scratch directory
    if not shutil.which("lmp"):
        sys.exit(f"{ap.prog}: error: LAMMPS (`lmp`, Debian package lammps) is not installed; bash runner/with_lammps.sh compare_lammps.py installs it")
    report = ["# grains against LAMMPS on identical initial states", "",
              f"`python runner/compare_lammps.py --steps {args.steps}`; LAMMPS `gran/hooke(/history)` + `nve/sphere`.", ""]

    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        # 1. The gas.
        run([sys.executable, args.peers / "gas_data.py", "26", "0.3", work / "gas.data"], work)
        x, v, length = read_lammps_data(work / "gas.data")
        n = len(x)
        write_table(work / "gas.txt", x, v)
        gas = {}
        for friction in (False, True):
            name = "gas-friction" if friction else "gas"
            lmp = lammps_energies(work, name, "gas.data", friction, "p p p", args.steps, EVERY, DT)
            g = grains_energies(args.binary, work, grains_scene(work, name, work / "gas.txt", [length] * 3, True, gas_law(friction),
                                                                args.steps, EVERY, DT, 0.2))
            if len(lmp) != len(g) or not np.array_equal(lmp[:, 0], g[:, 0]):
                raise RuntimeError(f"{name}: the two codes' output steps differ")
            gas[name] = (g, lmp)
            print(f"{name}: done", flush=True)
        report += [f"## The gas scene, {n} spheres, the same initial state (gas_data.py), kinetic energy per particle", "",
                   "| t | grains | LAMMPS | grains / LAMMPS | grains, frictional: translational | rotational | LAMMPS, "
                   "frictional: translational | rotational | grains / LAMMPS, translational | rotational |",
                   "|---|---|---|---|---|---|---|---|---|---|"]
        g0, l0 = gas["gas"]
        g1, l1 = gas["gas-friction"]
        for k in range(0, len(g0), max(1, len(g0) // 10)):
            t = g0[k, 0] * DT
            rot = g1[k, 2] / l1[k, 2] if l1[k, 2] > 0 else float("nan")
            report.append(f"| {t:.2f} | {g0[k, 1] / n:.5f} | {l0[k, 1] / n:.5f} | {g0[k, 1] / l0[k, 1]:.4f} | "
                          f"{g1[k, 1] / n:.5f} | {g1[k, 2] / n:.5f} | {l1[k, 1] / n:.5f} | {l1[k, 2] / n:.5f} | "
                          f"{g1[k, 1] / l1[k, 1]:.4f} | {rot:.4f} |")

        # 2. One collision, averaged over impact parameters.
        px, pv = pair_ensemble()
        lo, hi = (-5.0, -5.0, -5.0), (10.0 * PAIRS + 5.0, 5.0, 5.0)
        write_table(work / "pairs.txt", px, pv)
        lammps_data(work / "pairs.data", px, pv, lo, hi)
        initial = 0.5 * MASS * (pv ** 2).sum()
        rows = {}
        for friction in (False, True):
            for dt in (DT, DT / 100):
                steps = int(round(1.0 / dt))
                name = f"pairs-{'friction' if friction else 'plain'}-{steps}"
                lmp = lammps_energies(work, name, "pairs.data", friction, "f f f", steps, steps, dt)[-1]
                g = grains_energies(args.binary, work, grains_scene(work, name, work / "pairs.txt",
                                                                    [hi[a] - lo[a] for a in range(3)], False,
                                                                    gas_law(friction), steps, steps, dt, 0.2))[-1]
                rows[(friction, dt)] = ((initial - g[1] - g[2]) / initial, (initial - lmp[1] - lmp[2]) / initial)
        report += ["", f"## One collision, {PAIRS} pairs, impact parameters uniform in b^2, relative speed 1", "",
                   "Fraction of the kinetic energy dissipated (translational + rotational).", "",
                   "| law | dt | grains | LAMMPS | grains / LAMMPS |", "|---|---|---|---|---|"]
        for (friction, dt), (g, lmp) in rows.items():
            report.append(f"| {'frictional' if friction else 'frictionless'} | {dt:g} | {g:.5f} | {lmp:.5f} | {g / lmp:.4f} |")

        # 3. The 2D disks.
        dg, dl, nd = disks(args.binary, work, peer_pair_style(args.peers))
        report += ["", f"## The 2D disks of disks2d.lmp, {nd} disks, one initial state, kinetic energy per disk", "",
                   "| t | grains: translational | rotational | LAMMPS: translational | rotational | grains / LAMMPS: "
                   "translational | rotational |", "|---|---|---|---|---|---|---|"]
        for k in range(len(dg)):
            rot = dg[k, 2] / dl[k, 2] if dl[k, 2] > 0 else float("nan")
            report.append(f"| {dg[k, 0] * DISK_DT:.2f} | {dg[k, 1] / nd:.6f} | {dg[k, 2] / nd:.6f} | {dl[k, 1] / nd:.6f} | "
                          f"{dl[k, 2] / nd:.6f} | {dg[k, 1] / dl[k, 1]:.4f} | {rot:.4f} |")

    # Haff's law with the measured ratio of the dissipation per collision (at the gas's dt) predicts the
    # ratio of the frictionless gases' energies: T = T0 / (1 + t / tau)^2, 1 / tau proportional to it.
    g0, l0 = gas["gas"]
    t_end = g0[-1, 0] * DT
    tau_lammps = t_end / (math.sqrt(l0[0, 1] / l0[-1, 1]) - 1)   # LAMMPS' own tau from its end point
    rate = rows[(False, DT)][0] / rows[(False, DT)][1]
    predicted = ((1 + t_end / tau_lammps) / (1 + rate * t_end / tau_lammps)) ** 2
    report += ["", f"Frictionless gas at t = {t_end:g}: grains / LAMMPS = {g0[-1, 1] / l0[-1, 1]:.4f} measured; "
               f"Haff's law with LAMMPS' tau ({tau_lammps:.3f}) and the collisions' dissipation ratio ({rate:.4f}) "
               f"predicts {predicted:.4f}."]
    print("\n".join(report))
    make_out_after_runs(ap, args.out)
    (args.out / "summary.md").write_text("\n".join(report) + "\n")
    plot(gas, n, args.out / "lammps-comparison.png")
    print(f"\nwrote {args.out / 'summary.md'} and {args.out / 'lammps-comparison.png'}")


def plot(gas, n, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 7), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    for name, colour in (("gas", "C0"), ("gas-friction", "C3")):
        g, lmp = gas[name]
        t = g[:, 0] * DT
        top.semilogy(t, g[:, 1] / n, "-", color=colour, label=f"{name}: grains, translational")
        top.semilogy(t, lmp[:, 1] / n, "o", mfc="none", color=colour, label=f"{name}: LAMMPS, translational")
        bottom.plot(t, g[:, 1] / lmp[:, 1], "-", color=colour, label=f"{name}, translational")
        if name == "gas-friction":
            top.semilogy(t[1:], g[1:, 2] / n, "--", color=colour, label=f"{name}: grains, rotational")
            top.semilogy(t[1:], lmp[1:, 2] / n, "s", mfc="none", color=colour, label=f"{name}: LAMMPS, rotational")
            bottom.plot(t[1:], g[1:, 2] / lmp[1:, 2], "--", color=colour, label=f"{name}, rotational")
    top.set_ylabel("kinetic energy per particle")
    top.legend(fontsize=7)
    top.set_title("The gas scene from one initial state: grains against LAMMPS")
    bottom.axhline(1, color="grey", lw=0.5)
    bottom.set_xlabel("t")
    bottom.set_ylabel("grains / LAMMPS")
    bottom.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
