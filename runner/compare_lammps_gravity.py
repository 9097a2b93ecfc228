"""The self-gravitating aggregation scene side by side with LAMMPS: the same initial states run by both codes.

    python runner/compare_lammps_gravity.py [--seeds 2024 1 2] [--free-fall-times 3] [--out DIR]
    (bash runner/with_lammps.sh compare_lammps_gravity.py installs LAMMPS and builds grains first)

LAMMPS has no softened gravity. In the aggregation scene `pair_style table spline` holds it: a file of 20,000
exact values of E = -G m^2 / sqrt(d^2 + eps^2) and F = -G m^2 d / (d^2 + eps^2)^{3/2}, log-spaced from 1e-3 to the
cutoff, which LAMMPS splines onto its own table of TABLE_POINTS entries evenly spaced in d^2 and interpolates by
cubic splines. `pair_write` measures that table against the formula (the first table of summary.md): evenly
spaced in d^2, it is poor well inside the softening length and accurate wherever the spheres actually are (d >
0.5; the closest centres recorded are in the tables). The cutoff (CUTOFF) is larger than the cloud (the widest
separation at the end is in the tables), the boundary shrink-wrapped (`s s s`), every pair a neighbour
(`neighbor nsq`); `thermo pe` is then W.

Contacts: `hybrid/overlay` with `gran/hooke k_n 0 gamma_n 0 0 0 limit_damping`. gran/hooke's force is
k_n delta - m_eff gamma_n v_n with m_eff the pair's reduced mass: its gamma_n is a damping per unit reduced mass,
and its k_n is not scaled. grains' global calibration (physics.md section 2) takes one k_n and c_n from the
smallest reduced mass m*; so k_n is the same number, gamma_n = c_n / m* = -2 ln e / t_c, and the two are the
same law for every pair of equal masses (as here; with unequal masses LAMMPS' damping would be grains'
per-pair c_n with the global k_n, neither of grains' modes). `limit_damping` sets a negative normal force to
zero, which is physics.md's non-adhesion clamp max(0, k_n delta - c_n v_n) (part 1 checks it on one collision).
grains' overlap clamp (delta_used <= 0.1 R) has no LAMMPS counterpart: the like-for-like runs set
contact.overlap_limit = 1 (never reached), and one further grains run per seed keeps the scene's 0.1 to show
what it changes. Both codes integrate with velocity Verlet (nve/sphere); the integrators differ in the normal
dashpot's velocity (LAMMPS: the half-step velocity; grains: a predicted end-of-step velocity) and grains charges
a contact's start and end inside the step (docs/accuracy.md), so the contact trajectories part at first order
in dt, and then the N-body chaos takes over.

1. Kepler: two unit masses on an orbit of eccentricity 1/2 (apocentre 1.5, pericentre 0.5), 2000 steps an
   orbit, contacts off: the separation vector after 1 and 10 orbits in both codes. One head-on collision
   (e = 0.5, t_c = 0.02, no gravity) at relative speed 1 and 30 or 3000 steps per contact: the realised
   restitution with and without limit_damping against grains' and the clamped law's exact value. The cold
   collapse of models/collapse.toml (contacts off) from grains' initial state: K and W over 1.5 t_ff, the time of
   maximum compression (K's peak), the rms distance between the codes' particles. Its softening length
   (eps = 0.002) is far below what a table even in d^2 resolves and pairs pass closer than 1e-4, so LAMMPS takes
   it from `pair_style table bitmap` (points evenly spaced in log d^2 where LAMMPS' bit pattern of d^2 puts them:
   pair_write lays them out, the values written are the formula's; about 1.4e-7 relative error at every d).
2. models/aggregation.toml (1000 spheres, e = 0.5, t_c = 0.02, 30 steps per contact, G = 1, eps0 = 0.1,
   direct gravity) from the initial state grains' random layout makes with each seed (the scene's is 2024).
   First two checks on the first seed: contacts off for 1000 steps (gravity alone: the codes should agree to
   rounding until the chaos grows it), and contacts on (like for like) to 0.05 t_ff at 30 and 300 steps per
   contact (an integration difference shrinks with dt, a model difference would not). Then each seed up to
   --free-fall-times t_ff: K, W, Q = K / |W| every 100 steps, the rms distance between the two codes' particles,
   and the clusters (physics.md section 8: linked when d < R_i + R_j + 1e-3 R_min, computed for LAMMPS from its
   positions dumped every 100 steps; grains' own, checked every 100 steps as the scene does, and the same rule on
   grains' last snapshot must give grains' count), t_agg (first f_max >= 0.9), N_c / N and D_f of the largest
   cluster (grains' rule: the slope of log N(r) over 20 radii from two diameters to the radius holding 90 %) at
   the end.

Writes summary.md and lammps-gravity.png into --out. One seed took 3.7 processor minutes (LAMMPS 1.5 of them),
so the default three about 8 (2026-12-05).
"""
import argparse
import math
import os
import pathlib
import re
import shutil
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import scene_check  # noqa: E402
import tool_args  # noqa: E402
from compare_lammps import grains_scene, lammps_data, make_out_after_runs, out_folder_problem, run, write_table  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCENE = ROOT / "models" / "aggregation.toml"
E, TC, STEPS_PER_CONTACT = 0.5, 0.02, 30     # the scene's contact law
DT = TC / STEPS_PER_CONTACT
G, EPS0, DIAMETER = 1.0, 0.1, 1.0
EPS = EPS0 * DIAMETER / 2                    # eps = eps0 R_min
TOL = 1e-3 * DIAMETER / 2                    # the cluster tolerance, 1e-3 R_min
CUTOFF = 60.0                                # the table's cutoff: above every separation (checked)
TABLE_FILE_POINTS, TABLE_POINTS = 20000, 2 ** 20
EVERY = 100                                  # steps between records (grains' analysis.every)


def kn_cn():
    """grains' global calibration for the smallest reduced mass m* = 1/2 (unit masses): (k_n, c_n, m*)."""
    m_star = 0.5
    return m_star * (math.pi ** 2 + math.log(E) ** 2) / TC ** 2, -2 * m_star * math.log(E) / TC, m_star


def gravity_table(path, eps, r_lo, cutoff, points=TABLE_FILE_POINTS, mass=1.0, r=None, header=None):
    """LAMMPS' table file of softened gravity between equal masses: exact E and F at log-spaced r (or at the
    given r under the given N line), the end slopes of F (FPRIME) for LAMMPS' spline through them."""
    gm2 = G * mass * mass
    r = np.geomspace(r_lo, cutoff, points) if r is None else r
    s = r * r + eps * eps
    slope = lambda x: -gm2 * (eps * eps - 2 * x * x) / (x * x + eps * eps) ** 2.5   # dF/dr
    header = header or f"N {points} FPRIME {slope(r_lo)!r} {slope(cutoff)!r}"
    with open(path, "w") as f:
        f.write(f"# softened gravity, G = {G!r}, m = {mass!r}, eps = {eps!r}\nGRAVITY\n{header}\n\n")
        for k, (rk, ek, fk) in enumerate(zip(r, -gm2 / np.sqrt(s), -gm2 * r / s ** 1.5), 1):
            f.write(f"{k} {rk:.17g} {ek:.17g} {fk:.17g}\n")


def pair_write(work, style, table, cutoff, points, out):
    """What LAMMPS interpolates: `pair_write` of one atom type under `pair_style` style with the GRAVITY entry of
    the file `table` in `work` up to `cutoff`, at `points` (pair_write's count, spacing and range), into the
    file `out` in `work`; returns its text."""
    (work / out).unlink(missing_ok=True)   # pair_write appends
    (work / "pair_write.lmp").write_text(f"""units lj
atom_style atomic
boundary f f f
region b block -1 1 -1 1 -1 1
create_box 1 b
mass 1 1.0
pair_style {style}
pair_coeff 1 1 {table} GRAVITY {cutoff!r}
pair_write 1 1 {points} {out} GRAVITY
""")
    run(["lmp", "-in", "pair_write.lmp", "-log", "none"], work)
    return (work / out).read_text()


def bitmap_table(work, path, eps, r_lo, cutoff, bits, mass):
    """A table for `pair_style table bitmap BITS`: its 2^bits points sit where LAMMPS' bit pattern of d^2 puts
    them (evenly spaced in log d^2, so the relative error is the same at every d, far inside the softening
    too). LAMMPS' pair_write lays them out (from any table); the values written are then the formula's."""
    gravity_table(work / "layout.table", eps, r_lo, cutoff, mass=mass)
    lines = pair_write(work, "table linear 1000", "layout.table", cutoff, f"{bits} bitmap {r_lo!r} {cutoff!r}",
                       "layout.txt").splitlines()
    at = next(k for k, l in enumerate(lines) if l.startswith("N "))
    r = np.array([float(l.split()[1]) for l in lines[at + 1:] if l.strip()])
    gravity_table(path, eps, r_lo, cutoff, mass=mass, r=r, header=lines[at])


def table_error(work, table, eps, cutoff, bands, style=None, mass=1.0):
    """The table LAMMPS interpolates (`pair_style` style, by default the aggregation's), against the formula:
    the largest relative errors of F and E in each band of separations (pair_write at 200,000 points evenly
    spaced in r)."""
    pair_write(work, style or f"table spline {TABLE_POINTS}", table.name, cutoff,
               f"200000 r {bands[0][0] * 1.001!r} {cutoff * (1 - 1e-9)!r}", "written.txt")
    d = np.loadtxt(work / "written.txt", skiprows=5)
    r, e, f = d[:, 1], d[:, 2], d[:, 3]
    s = r * r + eps * eps
    gm2 = G * mass * mass
    ef, ee = np.abs(f / (-gm2 * r / s ** 1.5) - 1), np.abs(e / (-gm2 / np.sqrt(s)) - 1)
    return [(lo, hi, ef[(r >= lo) & (r < hi)].max(), ee[(r >= lo) & (r < hi)].max()) for lo, hi in bands]


def lammps_script(data, table, dt, steps, contacts, every, dump=True, cutoff=CUTOFF, style=None):
    """Softened gravity from `table` (None: none) up to `cutoff` (`pair_style` style, by default the
    aggregation's) and, with contacts = (k_n, gamma_n, limit_damping), gran/hooke; thermo (K, W) and, with
    `dump`, the positions every `every` steps."""
    styles, coeffs = [], []
    if table is not None:
        styles.append(style or f"table spline {TABLE_POINTS}")
        coeffs.append(f"{table} GRAVITY {cutoff!r}")
    if contacts is not None:
        kn, gn, limit = contacts
        styles.append(f"gran/hooke {kn!r} 0.0 {gn!r} 0.0 0.0 0{' limit_damping' if limit else ''}")
        coeffs.append("")
    if len(styles) == 1:
        pair = f"pair_style {styles[0]}\npair_coeff * * {coeffs[0]}"
    else:
        names = [s.split()[0] for s in styles]
        pair = f"pair_style hybrid/overlay {' '.join(styles)}\n" + "\n".join(f"pair_coeff * * {n} {c}" for n, c in zip(names, coeffs))
    cutoff = cutoff if table is not None else 2 * DIAMETER
    dumps = (f"dump 1 all custom {every} positions.dump id x y z\ndump_modify 1 sort id format float %.17g\n" if dump else "")
    return f"""units lj
atom_style sphere
boundary s s s
comm_modify vel yes cutoff {cutoff + 1.0!r}
read_data {data}
{pair}
neighbor 1.0 nsq
neigh_modify every 1 delay 0 check yes
fix 1 all nve/sphere
timestep {dt!r}
thermo_style custom step ke pe
thermo_modify norm no format float %.15g lost error
thermo {every}
{dumps}run {steps}
"""


def lammps_run(work, name, script):
    """Runs a script; (its thermo rows step, K, W; its dumped positions, frames x N x 3)."""
    (work / "positions.dump").unlink(missing_ok=True)   # a run without dumps must not read an older one's
    (work / f"{name}.lmp").write_text(script)
    text = run(["lmp", "-in", f"{name}.lmp", "-log", "none"], work)
    rows = np.array(re.findall(r"^\s+(\d+)\s+([-0-9.eE+]+)\s+([-0-9.eE+]+)\s*$", text, re.MULTILINE), dtype=float)
    frames = []
    if (work / "positions.dump").exists():
        for frame in (work / "positions.dump").read_text().split("ITEM: TIMESTEP")[1:]:
            lines = frame.strip().splitlines()
            n = int(lines[2])
            frames.append(np.array([l.split() for l in lines[8:8 + n]], dtype=float)[:, 1:4])
    return rows, np.array(frames)


def grains_run(binary, work, scene):
    """grains' observables (a dict of name -> (steps, values)), its snapshots' steps and positions, and the
    file's attributes."""
    out = work / (scene.stem + ".h5")
    run([binary, "run", scene, "--quiet", "--out", out, "--set", "run.threads=1"], work)
    with h5py.File(out, "r") as f:
        o = f["observables"]
        obs = {k: (o[k]["step"][:], o[k]["value"][:]) for k in o}
        steps = f["particles/all/velocity/step"][:]   # the positions' steps (H5MD: position has no own)
        return obs, steps, f["particles/all/position/value"][:], {k: float(v[()]) if np.ndim(v) == 0 else v for k, v in f.attrs.items()}


def clusters(x, radius=DIAMETER / 2, tol=TOL):
    """physics.md section 8 for equal spheres, linked when d < 2R + tol: (the clusters' sizes, each particle's
    index into them)."""
    n = len(x)
    parent = np.arange(n)

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    reach2 = (2 * radius + tol) ** 2
    for i in range(n - 1):
        d2 = ((x[i + 1:] - x[i]) ** 2).sum(axis=1)
        for j in np.nonzero(d2 < reach2)[0] + i + 1:
            a, b = root(i), root(j)
            if a != b:
                parent[b] = a
    labels = np.array([root(i) for i in range(n)])
    _, inverse, sizes = np.unique(labels, return_inverse=True, return_counts=True)
    return sizes, inverse


def fractal_dimension(x, samples=20):
    """grains' D_f (engine/analysis/fractal_dimension.cpp) of equal spheres x."""
    r = np.sort(np.linalg.norm(x - x.mean(axis=0), axis=1))
    r_lo, r_hi = 2 * DIAMETER, r[max(int(math.ceil(0.9 * len(x))), 1) - 1]
    if not r_hi > r_lo:
        return float("nan")
    rk = r_lo * (r_hi / r_lo) ** (np.arange(samples) / (samples - 1))
    n = np.searchsorted(r, rk * (1 + 1e-12), side="right")
    return float(np.polyfit(np.log(rk), np.log(np.maximum(n, 1)), 1)[0])


def largest_distance(x):
    return max(float(np.sqrt(((x[i + 1:] - x[i]) ** 2).sum(axis=1).max())) for i in range(len(x) - 1))


def grains_law(overlap_limit, gravity=True, contacts=True, softening=EPS0):
    """The scene's law as grains scene text, with this overlap clamp; gravity and contacts may be left out."""
    law = ""
    if contacts:
        law += f"[contact]\nrestitution = {E!r}\nduration = {TC!r}\noverlap_limit = {overlap_limit!r}\n[friction]\ncoefficient = 0.0\n"
    else:
        law += "[contact]\nenabled = false\n"
    if gravity:
        law += f"[gravity]\nenabled = true\nG = {G!r}\nsoftening = {softening!r}\nsolver = \"direct\"\n"
    if gravity and contacts:
        law += f"[analysis]\ncluster_tolerance = 1e-3\naggregation_threshold = 0.9\nevery = {EVERY}\n"
    return law


# ---------------------------------------------------------------------------------------------------------
# 1. Kepler, and one collision.
# ---------------------------------------------------------------------------------------------------------
KEPLER_STEPS = 2000   # an orbit
KEPLER_CUTOFF = 4.0   # the table's d^2 spacing at d = 0.5 (pericentre) is then 1.5e-5


def kepler(binary, work):
    """The separation vectors after 1 and 10 orbits: {orbits: (grains, LAMMPS)}, and the orbit's period."""
    diameter = 0.01                               # point-like: eps = eps0 R = 5e-4
    ra, a, mu = 1.5, 1.0, 2 * G                   # apocentre, semi-major axis, G (m1 + m2)
    va = math.sqrt(mu * (2 / ra - 1 / a))
    period = 2 * math.pi * math.sqrt(a ** 3 / mu)
    x = np.array([[-ra / 2, 0, 0], [ra / 2, 0, 0]])
    v = np.array([[0, -va / 2, 0], [0, va / 2, 0]])
    dt, steps = period / KEPLER_STEPS, 10 * KEPLER_STEPS
    write_table(work / "kepler.txt", x, v, diameters=[diameter] * 2)
    lammps_data(work / "kepler.data", x, v, (-3, -3, -3), (3, 3, 3), diameters=[diameter] * 2)
    gravity_table(work / "kepler.table", EPS0 * diameter / 2, 1e-4, KEPLER_CUTOFF)
    _, lp = lammps_run(work, "kepler", lammps_script("kepler.data", "kepler.table", dt, steps, None, KEPLER_STEPS,
                                                     cutoff=KEPLER_CUTOFF))
    scene = grains_scene(work, "kepler", work / "kepler.txt", [6.0] * 3, False, grains_law(1.0, contacts=False),
                         steps, KEPLER_STEPS, dt, 0.1, snapshots_every=KEPLER_STEPS)
    _, _, gp, _ = grains_run(binary, work, scene)
    return {k: (gp[k, 1] - gp[k, 0], lp[k, 1] - lp[k, 0]) for k in (1, 10)}, period, x[1] - x[0]


def collision(binary, work, dt):
    """One head-on collision at relative speed 1, no gravity, at time step dt: the realised e of grains and of
    LAMMPS with and without limit_damping, and the exact e of the clamped law (the force ends when k delta = c v_n)."""
    x = np.array([[-0.55, 0, 0], [0.55, 0, 0]])
    v = np.array([[0.5, 0, 0], [-0.5, 0, 0]])
    steps = int(round(0.2 / dt))
    write_table(work / "pair.txt", x, v)
    lammps_data(work / "pair.data", x, v, (-3, -3, -3), (3, 3, 3))
    kn, cn, m_star = kn_cn()
    realised = {}
    for limit in (True, False):
        rows, _ = lammps_run(work, "pair", lammps_script("pair.data", None, dt, steps, (kn, cn / m_star, limit), steps, dump=False))
        realised[limit] = math.sqrt(rows[-1, 1] / 0.25)   # K = 1/2 m* v_rel^2 in the centre-of-mass frame
    scene = grains_scene(work, "pair", work / "pair.txt", [6.0] * 3, False, grains_law(1.0, gravity=False), steps, steps, dt, 0.2)
    obs, _, _, _ = grains_run(binary, work, scene)
    g = math.sqrt(obs["kinetic_energy"][1][-1] / 0.25)
    return g, realised[True], realised[False], clamped_restitution(E)


def clamped_restitution(e):
    """The realised restitution of a head-on collision under the clamped law calibrated for e: the overlap
    delta = (v0 / w) e^{-z w0 t} sin(w t) ends its force k delta + c d(delta)/dt at w t1 = pi - atan2(2 z sqrt(1 - z^2),
    1 - 2 z^2), and the pair leaves at that moment's overlap rate."""
    z = -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)
    s = math.sqrt(1 - z * z)
    phase = math.pi - math.atan2(2 * z * s, 1 - 2 * z * z)   # w t1
    return -math.exp(-z * phase / s) * (math.cos(phase) - z / s * math.sin(phase))


COLLAPSE = ROOT / "models" / "collapse.toml"
COLLAPSE_DIAMETER, COLLAPSE_MASS, COLLAPSE_EPS0, COLLAPSE_DT, COLLAPSE_STEPS = 0.01, 0.001, 0.4, 0.0005, 6200
COLLAPSE_CUTOFF, COLLAPSE_BITS, COLLAPSE_EVERY, COLLAPSE_INNER = 10.0, 20, 20, 1e-7


def collapse(binary, work):
    """models/collapse.toml (contacts off) from grains' initial state in both codes, with a bitmap table
    (the scene's eps = 0.002 is far below what a table even in d^2 resolves, and pairs come closer than eps).
    Returns the table's error bands and, per code, t / t_ff, K, W, and the rms distance between the codes."""
    out = work / "collapse-initial.h5"
    run([binary, "run", COLLAPSE, "--quiet", "--out", out, "--set", "time.steps=0", "--set", "output.xdmf=false"], work)
    with h5py.File(out, "r") as f:
        x = f["particles/all/position/value"][0]
    v = np.zeros_like(x)
    n, eps = len(x), COLLAPSE_EPS0 * COLLAPSE_DIAMETER / 2
    t_ff = free_fall_time(x, COLLAPSE_MASS)
    write_table(work / "collapse.txt", x, v, diameters=[COLLAPSE_DIAMETER] * n, masses=[COLLAPSE_MASS] * n)
    lammps_data(work / "collapse.data", x, v, (-1.5,) * 3, (1.5,) * 3, diameters=[COLLAPSE_DIAMETER] * n, masses=[COLLAPSE_MASS] * n)
    style = f"table bitmap {COLLAPSE_BITS}"
    bitmap_table(work, work / "collapse.table", eps, COLLAPSE_INNER, COLLAPSE_CUTOFF, COLLAPSE_BITS, COLLAPSE_MASS)
    bands = [(COLLAPSE_INNER, eps), (eps, 0.01), (0.01, 0.1), (0.1, 1.0), (1.0, COLLAPSE_CUTOFF)]
    errors = table_error(work, work / "collapse.table", eps, COLLAPSE_CUTOFF, bands, style=style, mass=COLLAPSE_MASS)
    rows, frames = lammps_run(work, "collapse", lammps_script("collapse.data", "collapse.table", COLLAPSE_DT, COLLAPSE_STEPS, None,
                                                             COLLAPSE_EVERY, cutoff=COLLAPSE_CUTOFF, style=style))
    law = grains_law(1.0, contacts=False, softening=COLLAPSE_EPS0)
    scene = grains_scene(work, "collapse", work / "collapse.txt", [3.0] * 3, False, law, COLLAPSE_STEPS, COLLAPSE_EVERY,
                         COLLAPSE_DT, 0.01, snapshots_every=COLLAPSE_EVERY)
    obs, _, pos, _ = grains_run(binary, work, scene)
    grains_ff = float(obs["free_fall_time"][1][0])
    if abs(grains_ff / t_ff - 1) > 1e-12:
        raise RuntimeError(f"collapse: t_ff {t_ff} here, {grains_ff} in grains")
    t = rows[:, 0] * COLLAPSE_DT / t_ff
    return dict(errors=errors, t=t, t_ff=t_ff, grains=(obs["kinetic_energy"][1], obs["gravity_potential_energy"][1]),
                lammps=(rows[:, 1], rows[:, 2]), rms=np.sqrt(((pos - frames) ** 2).sum(axis=2).mean(axis=1)),
                closest=min(_closest(p) for p in frames), widest=max(largest_distance(frames[-1]), largest_distance(pos[-1])))


# ---------------------------------------------------------------------------------------------------------
# 2. The aggregation scene.
# ---------------------------------------------------------------------------------------------------------
def initial_state(binary, work, seed):
    """The positions grains' random layout makes for models/aggregation.toml with this seed (at rest)."""
    out = work / f"initial-{seed}.h5"
    run([binary, "run", SCENE, "--quiet", "--out", out, "--set", f"particles.seed={seed}", "--set", "time.steps=0",
         "--set", "output.xdmf=false"], work)
    with h5py.File(out, "r") as f:
        return f["particles/all/position/value"][0]


def free_fall_time(x, mass=1.0):
    """physics.md section 8: sqrt(R0^3 / (G M)), R0 the largest distance from the centre of mass (equal masses)."""
    return math.sqrt(np.linalg.norm(x - x.mean(axis=0), axis=1).max() ** 3 / (G * mass * len(x)))


def aggregation_time(steps, fmax):
    """The first recorded time with f_max >= 0.9, or nan."""
    hit = np.nonzero(np.asarray(fmax) >= 0.9)[0]
    return steps[hit[0]] * DT if len(hit) else float("nan")


def aggregation(binary, work, seed, free_fall_times):
    """One seed in both codes (like for like: overlap_limit = 1 and limit_damping) and grains with the scene's
    overlap_limit = 0.1. Returns a dict of curves (t / t_ff, K, W, f_max, N_c) per run and the end values."""
    x = initial_state(binary, work, seed)
    n = len(x)
    t_ff = free_fall_time(x)
    steps = int(math.ceil(free_fall_times * t_ff / DT / EVERY)) * EVERY
    v = np.zeros_like(x)
    lo, hi = x.min(axis=0) - DIAMETER, x.max(axis=0) + DIAMETER
    write_table(work / "cloud.txt", x, v)
    lammps_data(work / "cloud.data", x, v, lo, hi)
    gravity_table(work / "cloud.table", EPS, 1e-3, CUTOFF)
    kn, cn, m_star = kn_cn()
    result = {"seed": seed, "t_ff": t_ff, "steps": steps, "n": n}

    start = children_seconds()
    rows, frames = lammps_run(work, "cloud", lammps_script("cloud.data", "cloud.table", DT, steps, (kn, cn / m_star, True), EVERY))
    result["lammps_seconds"] = children_seconds() - start
    fl, nl = [], []
    for p in frames:
        sizes, _ = clusters(p)
        fl.append(sizes.max() / n)
        nl.append(len(sizes))
    last_sizes, labels = clusters(frames[-1])
    result["lammps"] = dict(t=rows[:, 0] * DT / t_ff, K=rows[:, 1], W=rows[:, 2], fmax=np.array(fl), nc=np.array(nl),
                            t_agg=aggregation_time(rows[:, 0], fl) / t_ff, nc_end=len(last_sizes) / n,
                            df=fractal_dimension(frames[-1][labels == np.argmax(last_sizes)]),
                            spread=largest_distance(frames[-1]), closest=min(_closest(p) for p in frames))
    for name, limit in (("grains", 1.0), ("grains, overlap clamp 0.1 R", 0.1)):
        scene = grains_scene(work, f"cloud-{limit}", work / "cloud.txt", list(hi - lo), False, grains_law(limit), steps,
                             EVERY, DT, 0.2, snapshots_every=EVERY)
        start = children_seconds()
        obs, snap_steps, pos, _ = grains_run(binary, work, scene)
        seconds = children_seconds() - start
        st = obs["kinetic_energy"][0]
        fmax = obs["largest_cluster_fraction"][1]
        sizes, labels = clusters(pos[-1])
        if len(sizes) != int(obs["cluster_count"][1][-1]):
            raise RuntimeError(f"seed {seed}: clusters() finds {len(sizes)} in grains' last state, grains {obs['cluster_count'][1][-1]}")
        result[name] = dict(t=st * DT / t_ff, K=obs["kinetic_energy"][1], W=obs["gravity_potential_energy"][1], fmax=fmax,
                            nc=obs["cluster_count"][1], t_agg=aggregation_time(st, fmax) / t_ff, nc_end=len(sizes) / n,
                            df=float(obs["fractal_dimension"][1][-1]), df_here=fractal_dimension(pos[-1][labels == np.argmax(sizes)]),
                            clamped=float(obs["clamped_contacts_total"][1][-1]), spread=largest_distance(pos[-1]),
                            closest=min(_closest(p) for p in pos), seconds=seconds)
        if limit == 1.0:
            if len(pos) != len(frames) or not np.array_equal(snap_steps, rows[:len(snap_steps), 0]):
                raise RuntimeError(f"seed {seed}: the two codes' snapshots differ in number or steps")
            result["rms"] = np.sqrt(((pos - frames) ** 2).sum(axis=2).mean(axis=1))
    return result


def children_seconds():
    """Processor seconds of the finished child processes (the codes' runs) so far."""
    t = os.times()
    return t.children_user + t.children_system


def _closest(x):
    """The smallest centre distance in x."""
    return min(float(np.sqrt(((x[i + 1:] - x[i]) ** 2).sum(axis=1).min())) for i in range(len(x) - 1))


def gravity_only(binary, work, seed, steps=1000):
    """The cloud of `seed` with contacts off in both codes: (steps, rms distance, relative K difference)."""
    x = initial_state(binary, work, seed)
    v = np.zeros_like(x)
    lo, hi = x.min(axis=0) - DIAMETER, x.max(axis=0) + DIAMETER
    write_table(work / "bare.txt", x, v)
    lammps_data(work / "bare.data", x, v, lo, hi)
    gravity_table(work / "bare.table", EPS, 1e-3, CUTOFF)
    rows, frames = lammps_run(work, "bare", lammps_script("bare.data", "bare.table", DT, steps, None, EVERY))
    scene = grains_scene(work, "bare", work / "bare.txt", list(hi - lo), False, grains_law(1.0, contacts=False), steps,
                         EVERY, DT, 0.2, snapshots_every=EVERY)
    obs, _, pos, _ = grains_run(binary, work, scene)
    rms = np.sqrt(((pos - frames) ** 2).sum(axis=2).mean(axis=1))
    k = obs["kinetic_energy"][1]
    return rows[1:, 0], rms[1:], np.abs(k[1:] / rows[1:, 1] - 1)


def early_parting(binary, work, seed, free_fall_fraction, per_contact):
    """The rms distance between the codes' particles at free_fall_fraction t_ff, contacts on (like for like),
    at `per_contact` steps per contact: how it scales with dt tells an integration difference (it shrinks)
    from a model difference (it does not)."""
    x = initial_state(binary, work, seed)
    v = np.zeros_like(x)
    lo, hi = x.min(axis=0) - DIAMETER, x.max(axis=0) + DIAMETER
    dt = TC / per_contact
    steps = int(round(free_fall_fraction * free_fall_time(x) / dt))
    write_table(work / "early.txt", x, v)
    lammps_data(work / "early.data", x, v, lo, hi)
    gravity_table(work / "early.table", EPS, 1e-3, CUTOFF)
    kn, cn, m_star = kn_cn()
    _, frames = lammps_run(work, "early", lammps_script("early.data", "early.table", dt, steps, (kn, cn / m_star, True), steps))
    scene = grains_scene(work, "early", work / "early.txt", list(hi - lo), False, grains_law(1.0), steps, steps, dt, 0.2)
    _, _, pos, _ = grains_run(binary, work, scene)
    return float(np.sqrt(((pos[-1] - frames[-1]) ** 2).sum(axis=1).mean()))


RUNS = ("grains", "lammps", "grains, overlap clamp 0.1 R")
LABEL = {"grains": "grains", "lammps": "LAMMPS", "grains, overlap clamp 0.1 R": "grains, clamp 0.1 R"}


def parting_time(result, threshold):
    """t / t_ff when the codes' rms distance first exceeds `threshold`."""
    hit = np.nonzero(result["rms"] > threshold)[0]
    return result["grains"]["t"][hit[0]] if len(hit) else float("nan")


def q_peak(run):
    q = run["K"] / np.abs(run["W"])
    k = int(np.argmax(q))
    return q[k], run["t"][k]


def mean_sd(values):
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return "nan"
    # Fixed decimals: the figures are all of order 0.001-3, and D_f = 3.001 must not print as "3".
    return f"{v.mean():.3f} ± {v.std(ddof=1):.3f}" if len(v) > 1 else f"{v[0]:.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[2024, 1, 2], help="particles.seed of each cloud (the scene's is 2024)")
    ap.add_argument("--free-fall-times", type=float, default=3.0, help="how long each cloud runs, in t_ff")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("lammps-gravity"))
    ap.add_argument("--binary", type=pathlib.Path, default=ROOT / "build" / "runner" / "grains")
    args = ap.parse_args()
    if not 0 < args.free_fall_times < math.inf:
        ap.error(f"--free-fall-times {args.free_fall_times}: must be a finite number > 0")
    if len(set(args.seeds)) != len(args.seeds):
        ap.error(f"--seeds {' '.join(map(str, args.seeds))}: each seed once")
    if any(s < 0 for s in args.seeds):
        ap.error(f"--seeds {' '.join(map(str, args.seeds))}: particles.seed is a number >= 0")
    if problem := out_folder_problem(args.out, ["summary.md", "lammps-gravity.png"]):
        ap.error(problem)
    args.binary = args.binary.resolve()   # the runs start in a scratch directory
    tool_args.require_binary(ap, "--binary", args.binary)
    for seed in args.seeds:   # the engine's range (to 9.2e18), which it checked only when the seed's first run began
        try:
            scene_check.resolve(args.binary, SCENE, [f"particles.seed={seed}"])
        except scene_check.SceneError as error:
            ap.error(f"--seeds {seed}: grains refuses it: {scene_check.engine_refusal(error)}")
    if not shutil.which("lmp"):
        sys.exit(f"{ap.prog}: error: LAMMPS (`lmp`, Debian package lammps) is not installed; bash runner/with_lammps.sh compare_lammps_gravity.py installs it")
    kn, cn, m_star = kn_cn()
    report = ["# The aggregation scene against LAMMPS on identical initial states", "",
              f"`python runner/compare_lammps_gravity.py --seeds {' '.join(map(str, args.seeds))} --free-fall-times "
              f"{args.free_fall_times:g}`. LAMMPS: `pair_style hybrid/overlay table spline {TABLE_POINTS} gran/hooke "
              f"{kn:.6g} 0 {cn / m_star:.6g} 0 0 0 limit_damping` (gamma_n = c_n / m* = -2 ln e / t_c), `nve/sphere`, "
              f"boundary `s s s`, table cutoff {CUTOFF:g}. grains: the scene's law with `contact.overlap_limit = 1` "
              f"(like for like) and, in a third run, the scene's 0.1.", ""]
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        # The table.
        gravity_table(work / "cloud.table", EPS, 1e-3, CUTOFF)
        bands = [(1e-3, 0.1), (0.1, 0.5), (0.5, 0.9), (0.9, 1.0), (1.0, 5.0), (5.0, CUTOFF)]
        report += [f"## LAMMPS' table against the formula (eps = {EPS:g}; {TABLE_FILE_POINTS} exact points in the file, "
                   f"{TABLE_POINTS} in LAMMPS' spline, even in d^2)", "",
                   "| d | largest relative error of F | of E |", "|---|---|---|"]
        for lo, hi, ef, ee in table_error(work, work / "cloud.table", EPS, CUTOFF, bands):
            report.append(f"| [{lo:g}, {hi:g}) | {ef:.1e} | {ee:.1e} |")

        # 1. Kepler and one collision.
        orbits, period, start = kepler(args.binary, work)
        report += ["", f"## Kepler: two unit masses, eccentricity 1/2, period {period:.4f}, {KEPLER_STEPS} steps an orbit "
                   f"(table cutoff {KEPLER_CUTOFF:g})", "",
                   "| orbits | grains: separation | LAMMPS: separation | distance between them | distance from the start |",
                   "|---|---|---|---|---|"]
        for k, (g, l) in orbits.items():
            report.append(f"| {k} | ({g[0]:.9f}, {g[1]:.6e}) | ({l[0]:.9f}, {l[1]:.6e}) | {np.linalg.norm(g - l):.1e} | "
                          f"{np.linalg.norm(g - start):.1e} |")
        report += ["", "## One head-on collision, e = 0.5, t_c = 0.02, relative speed 1, no gravity: realised restitution", "",
                   "| steps per contact | grains | LAMMPS, limit_damping | LAMMPS, without | the clamped law, exact |", "|---|---|---|---|---|"]
        for per in (STEPS_PER_CONTACT, 100 * STEPS_PER_CONTACT):
            g, limited, plain, exact = collision(args.binary, work, TC / per)
            report.append(f"| {per} | {g:.5f} | {limited:.5f} | {plain:.5f} | {exact:.5f} |")
        col = collapse(args.binary, work)
        kg, wg = col["grains"]
        kl, wl = col["lammps"]
        report += ["", f"## The cold collapse of models/collapse.toml, contacts off (t_ff = {col['t_ff']:.4f}, eps = "
                   f"{COLLAPSE_EPS0 * COLLAPSE_DIAMETER / 2:g})", "",
                   f"LAMMPS: `pair_style table bitmap {COLLAPSE_BITS}` (2^{COLLAPSE_BITS} points evenly spaced in log d^2 from "
                   f"{COLLAPSE_INNER:g} to {COLLAPSE_CUTOFF:g}, exact values at them; a table even in d^2 cannot resolve "
                   f"this softening length). Its largest relative errors:", "",
                   "| d | F | E |", "|---|---|---|"]
        report += [f"| [{lo:g}, {hi:g}) | {ef:.1e} | {ee:.1e} |" for lo, hi, ef, ee in col["errors"]]
        report += ["", f"Closest pair LAMMPS recorded (every {COLLAPSE_EVERY} steps): {col['closest']:.2e}; widest separation at "
                   f"the end: {col['widest']:.2f}. Kinetic energy peak (maximum compression): grains at "
                   f"{col['t'][np.argmax(kg)]:.4f} t_ff, LAMMPS at {col['t'][np.argmax(kl)]:.4f} t_ff "
                   f"(K = {kg.max():.5f} and {kl.max():.5f}).", "",
                   "| t / t_ff | K, grains | K, LAMMPS | relative difference | W, grains | W, LAMMPS | relative difference | rms distance |",
                   "|---|---|---|---|---|---|---|---|"]
        for k in range(0, len(col["t"]), max(1, len(col["t"]) // 20)):
            dk = kg[k] / kl[k] - 1 if kl[k] > 0 else 0.0
            report.append(f"| {col['t'][k]:.3f} | {kg[k]:.6g} | {kl[k]:.6g} | {dk:.1e} | {wg[k]:.6g} | {wl[k]:.6g} | "
                          f"{wg[k] / wl[k] - 1:.1e} | {col['rms'][k]:.1e} |")
        print("part 1: done", flush=True)

        # 2. The cloud: gravity alone, then the early parting with contacts, then the whole runs.
        steps, rms, dk = gravity_only(args.binary, work, args.seeds[0])
        report += ["", f"## The scene's cloud (seed {args.seeds[0]}), contacts off in both codes", "",
                   "| step | rms distance between the codes' particles | relative difference of K |", "|---|---|---|"]
        for s, r, d in zip(steps, rms, dk):
            if s % 200 == 0:
                report.append(f"| {int(s)} | {r:.1e} | {d:.1e} |")
        fraction = 0.05
        early = {per: early_parting(args.binary, work, args.seeds[0], fraction, per) for per in (STEPS_PER_CONTACT, 10 * STEPS_PER_CONTACT)}
        report += ["", f"## The same cloud with contacts (like for like): rms distance between the codes at {fraction:g} t_ff", "",
                   "| steps per contact | rms distance |", "|---|---|"]
        report += [f"| {per} | {d:.2e} |" for per, d in early.items()]
        print("part 2, checks: done", flush=True)

        results = []
        for seed in args.seeds:
            results.append(aggregation(args.binary, work, seed, args.free_fall_times))
            r = results[-1]
            print(f"seed {seed}: t_agg / t_ff grains {r['grains']['t_agg']:.3f}, LAMMPS {r['lammps']['t_agg']:.3f}; "
                  f"processor seconds grains {r['grains']['seconds']:.0f}, LAMMPS {r['lammps_seconds']:.0f}", flush=True)

    report += ["", f"## The aggregation scene, {len(results)} seeds, up to {args.free_fall_times:g} t_ff", "",
               "Per seed and run: t_ff; Q's peak (value, at t / t_ff); f_max at 0.75 t_ff; t_agg / t_ff (first f_max >= 0.9, "
               "checked every 100 steps); at the end N_c / N and D_f of the largest cluster; the smallest centre distance "
               "recorded (every 100 steps); the largest separation at the end (the table's cutoff is "
               f"{CUTOFF:g}); contact-steps grains clamped; processor seconds.", "",
               "| seed | run | t_ff | Q peak | at t/t_ff | f_max(0.75 t_ff) | t_agg / t_ff | N_c / N | D_f | closest | widest | clamped | seconds |",
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        for name in RUNS:
            run_ = r[name]
            q, tq = q_peak(run_)
            f75 = np.interp(0.75, run_["t"], run_["fmax"])
            clamped = f"{run_['clamped']:.0f}" if "clamped" in run_ else "—"
            seconds = run_["seconds"] if "seconds" in run_ else r["lammps_seconds"]
            report.append(f"| {r['seed']} | {LABEL[name]} | {r['t_ff']:.4f} | {q:.4f} | {tq:.3f} | {f75:.3f} | {run_['t_agg']:.3f} | "
                          f"{run_['nc_end']:.3f} | {run_['df']:.3f} | {run_['closest']:.4f} | {run_['spread']:.1f} | {clamped} | {seconds:.0f} |")
    report += ["", "Mean ± sample standard deviation over the seeds:", "",
               "| run | Q peak | at t/t_ff | f_max(0.75 t_ff) | t_agg / t_ff | N_c / N | D_f |", "|---|---|---|---|---|---|---|"]
    for name in RUNS:
        runs = [r[name] for r in results]
        report.append(f"| {LABEL[name]} | {mean_sd([q_peak(x)[0] for x in runs])} | {mean_sd([q_peak(x)[1] for x in runs])} | "
                      f"{mean_sd([np.interp(0.75, x['t'], x['fmax']) for x in runs])} | {mean_sd([x['t_agg'] for x in runs])} | "
                      f"{mean_sd([x['nc_end'] for x in runs])} | {mean_sd([x['df'] for x in runs])} |")
    report += ["", "When the two like-for-like runs part (t / t_ff at which the rms distance between the codes' particles first "
               "exceeds the threshold), and the largest relative difference of K and of W before 0.5 t_ff:", "",
               "| seed | 1e-6 d | 1e-3 d | 0.1 d | 1 d | K | W |", "|---|---|---|---|---|---|---|"]
    for r in results:
        g, l = r["grains"], r["lammps"]
        before = g["t"] <= 0.5
        dk = np.abs(g["K"][before][1:] / l["K"][before][1:] - 1).max()
        dw = np.abs(g["W"][before] / l["W"][before] - 1).max()
        report.append(f"| {r['seed']} | " + " | ".join(f"{parting_time(r, th * DIAMETER):.3f}" for th in (1e-6, 1e-3, 0.1, 1.0))
                      + f" | {dk:.1e} | {dw:.1e} |")
    print("\n".join(report))
    make_out_after_runs(ap, args.out)
    (args.out / "summary.md").write_text("\n".join(report) + "\n")
    plot(col, results, args.out / "lammps-gravity.png")
    print(f"\nwrote {args.out / 'summary.md'} and {args.out / 'lammps-gravity.png'}")


def plot(col, results, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 2, figsize=(10, 10.5))
    (c_ax, cd_ax), (q_ax, f_ax), (n_ax, d_ax) = axes
    (kg, wg), (kl, wl) = col["grains"], col["lammps"]
    c_ax.plot(col["t"], kg, "-", color="C0", label="K, grains")
    c_ax.plot(col["t"], kl, "--", color="C1", label="K, LAMMPS")
    c_ax.plot(col["t"], -wg, "-", color="C2", label="|W|, grains")
    c_ax.plot(col["t"], -wl, "--", color="C3", label="|W|, LAMMPS")
    c_ax.set_title("cold collapse (collapse.toml), contacts off", fontsize=9)
    c_ax.set_xlabel("t / t_ff")
    c_ax.legend(fontsize=7)
    cd_ax.semilogy(col["t"][1:], np.abs(kg[1:] / kl[1:] - 1), "-", color="C0", lw=1, label="|K_grains / K_LAMMPS - 1|")
    cd_ax.semilogy(col["t"], np.abs(wg / wl - 1), "-", color="C2", lw=1, label="|W_grains / W_LAMMPS - 1|")
    cd_ax.semilogy(col["t"][1:], col["rms"][1:], "-", color="k", lw=1, label="rms distance grains - LAMMPS")
    cd_ax.set_title("cold collapse: the codes' differences", fontsize=9)
    cd_ax.set_xlabel("t / t_ff")
    cd_ax.legend(fontsize=7)
    style = {"grains": "-", "lammps": "--", "grains, overlap clamp 0.1 R": ":"}
    for k, r in enumerate(results):
        colour = f"C{k}"
        for name in RUNS:
            run_ = r[name]
            label = f"seed {r['seed']}, {LABEL[name]}"
            q_ax.semilogy(run_["t"][1:], (run_["K"] / np.abs(run_["W"]))[1:], style[name], color=colour, lw=1, label=label)
            f_ax.plot(run_["t"], run_["fmax"], style[name], color=colour, lw=1)
            n_ax.plot(run_["t"], run_["nc"] / r["n"], style[name], color=colour, lw=1)
        d_ax.semilogy(r["grains"]["t"][1:], r["rms"][1:] / DIAMETER, "-", color=colour, lw=1, label=f"seed {r['seed']}")
    q_ax.set_ylabel("Q = K / |W|")
    q_ax.set_title("aggregation: grains (solid; dotted: overlap clamp 0.1 R), LAMMPS (dashed)", fontsize=9)
    q_ax.legend(fontsize=5, ncol=2)
    f_ax.set_ylabel("largest cluster fraction f_max")
    f_ax.axhline(0.9, color="grey", lw=0.5)
    n_ax.set_ylabel("N_c / N")
    n_ax.set_xlabel("t / t_ff")
    d_ax.set_ylabel("rms distance grains - LAMMPS / d")
    d_ax.set_xlabel("t / t_ff")
    d_ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
