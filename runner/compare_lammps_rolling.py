"""Rolling resistance side by side with LAMMPS' `pair granular` (hooke, damping velocity, tangential
linear_history, rolling sds, twisting none): the same initial states run by both codes.

    python runner/compare_lammps_rolling.py [--out DIR] [--steps 20000] [--seeds 8] [--dims 2 3] [--pairs-only]
    (bash runner/with_lammps.sh compare_lammps_rolling.py installs LAMMPS and builds grains first)

The two rolling laws (physics.md section 5; LAMMPS' pair_granular.cpp, `rolling sds`):
- grains: theta_R accumulates the half-step relative rotation (w_j - w_i) dt (3D: its part normal to n; the
  spring is turned into the new tangent plane keeping its length), the moment on j is -K_R theta_R, its
  opposite acts on i, |K_R theta_R| <= mu_R K_N delta, and a sliding spring is shortened to the bound.
- LAMMPS: the rolling displacement accumulates v_rl dt, v_rl = R_eff (w_i - w_j) x n with n from j to i and
  R_eff = R_i R_j / (R_i + R_j); f_r = -k_roll xi_r - gamma_roll v_rl, capped at mu_roll F_ncrit (the spring
  set to -(F_rcrit f_r/|f_r| + gamma_roll v_rl) / k_roll), and the torque on i is R_eff n x f_r (on j its
  opposite). So the moment on i is -k_roll R_eff^2 (the rolling part of the integrated w_i - w_j), grains'.
The laws are the same for
    k_roll = K_R / R_eff^2,   mu_roll = mu_R / R_eff,   gamma_roll = c_r / R_eff^2 = beta c_n R_i R_j / R_eff^2
(per type pair; beta = rolling.damping_ratio), and where they cannot be made the same:
- the bound's force: LAMMPS' F_ncrit = |K_N delta - c_n v_n| (its hooke law: the dashpot counts, in absolute
  value), grains' the elastic part K_N delta alone. The same only without a normal dashpot (e_N = 1) or with
  v_n = 0; the packings run both e_N = 1 (the bounds are the same) and the paper's e_N = 0.015.
- the rolling dashpot: grains' acts outside the bound (on the twist too, in 3D) and never enters the spring;
  LAMMPS' sits inside the cap and its share is stored in the spring on sliding. The same while the spring
  sticks (case disks-damped), not while it slides (disks-damped-rolling); 0 in both elsewhere.
- the effective radius: one K_R and one mu_R for every grains contact, LAMMPS' coefficients per type pair. A
  polydisperse packing needs one atom type per size; here the packings are bidisperse (two types, three pairs).
- the history's turn into the new tangent plane (3D): grains turns theta_R, LAMMPS turns R_eff theta_R x n,
  the same turn to first order in the contact's rotation per step (and exactly in 2D); LAMMPS skips it below
  a 1e-10 relative threshold.
- friction: LAMMPS' contact velocity uses the radii R_i, R_j, grains' the lever arms R - delta/2 (both apply
  the torque with R - delta/2); its Coulomb bound is mu F_ncrit (above), grains' mu K_N delta.
- the normal dashpot acts on the half-step velocity in LAMMPS, on a predicted end-of-step velocity in grains,
  and grains charges the kink of a contact's start and end inside the step (docs/accuracy.md).
2D: LAMMPS' `fix nve/sphere disc` turns disks with I = m R^2 / 2, as grains does (the chains check it).

1. Chains, against each other and against the closed form: four grains in a periodic box, each pressed into
   both neighbours by delta = 1e-3 (F_n = 100, and no normal motion: the forces balance), given alternating
   spins. Every contact then has the same relative spin u = w_j - w_i; while it sticks theta'' = -Omega^2
   theta, Omega^2 = 2 K_R (1/I_A + 1/I_B) (two contacts per grain), the spring reaches the bound mu_R F_n, u
   falls at 2 mu_R F_n (1/I_A + 1/I_B) until it stops, and the spring, left at the bound, swings back
   elastically between +-mu_R F_n / K_R. Cases: equal disks rolling with no slip (friction idle), the same
   below the bound, with a rolling dashpot below and beyond it, disks of diameters 1 and 0.6 without friction
   (R_eff 0.1875 against 0.25), spheres with a twist about n (free in both), and equal disks with equal spins
   (friction alone: sliding, and stuck, where the codes' contact velocities differ).
2. Packings: 300 bidisperse disks (2D, solid fraction 0.85) and 250 bidisperse spheres (3D, 0.66), diameters
   1 and 0.7 (1:1), jammed by LAMMPS (frictionless, damped), then given Gaussian velocities and spins (--seeds
   draws); K_N = 1e5, K_R = 1e-4 K_N a^2, mu_R / a = 0, 0.005 and 0.5, mu = 0 (rolling alone) and 0.5, e_N = 1
   and (2D) 0.015. Both codes start from the one state; compared are how fast their trajectories part (the rms
   difference of velocities and spins) and the kinetic energies over time. A control runs LAMMPS with one
   type's coefficients for every pair (R_eff = 1/4: the mapping a single atom type would give).

Writes summary.md into --out.
"""
import argparse
import math
import pathlib
import shutil
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import tool_args  # noqa: E402
from compare_lammps import grains_scene, lammps_data, lammps_thermo, make_out_after_runs, out_folder_problem, run, write_table  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
KN = 1e5               # K_N (adhesion.stiffness)
KR_RATIO = 1e-4        # K_R / (K_N a^2), a = 1 the largest diameter
OVERLAP = 1e-3         # the chains' overlap: F_n = 100
DT = 1e-4


def zeta(e):
    return -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)


def grains_law(mu, mu_r, e_n, beta=0.0):
    """The consolidation law without adhesion (F0 = 0) as scene text: K_N, e_N, mu, k_t = K_N, no tangential
    dashpot, K_R = KR_RATIO K_N a^2, mu_R (0: no rolling module), the rolling dashpot c_r = beta c_n R_i R_j;
    no overlap clamp in reach."""
    law = (f"[contact]\noverlap_limit = 0.5\n[adhesion]\nenabled = true\nforce = 0.0\nrange = 0.0\n"
           f"stiffness = {KN!r}\nrestitution = {e_n!r}\n")
    if mu > 0:
        law += f"[friction]\ncoefficient = {mu!r}\nstiffness_ratio = 1.0\ndamping_ratio = 0.0\n"
    if mu_r > 0:
        law += f"[rolling]\ncoefficient = {mu_r!r}\nstiffness_ratio = {KR_RATIO!r}\ndamping_ratio = {beta!r}\n"
    return law


def lammps_pair(radii, masses, mu, mu_r, e_n, beta=0.0, a=1.0):
    """`pair_style granular` and one pair_coeff per type pair giving grains' law (grains_law): types 1, 2, ...
    with radii[t - 1] and masses[t - 1]. c_n = 2 zeta sqrt(m* K_N) per type pair (damping velocity);
    k_roll = K_R / R_eff^2 and mu_roll = mu_R / R_eff (the moment is R_eff |f_r|); gamma_roll = c_r / R_eff^2
    = beta c_n (R_i + R_j)^2 / (R_i R_j), the same dashpot while the spring sticks (2D; in 3D grains' acts on
    the twist too), not while it slides (LAMMPS caps spring and dashpot together)."""
    kr = KR_RATIO * KN * a * a
    radii, masses = [float(r) for r in radii], [float(m) for m in masses]
    lines = ["pair_style granular"]
    for s in range(len(radii)):
        for t in range(s, len(radii)):
            reff = radii[s] * radii[t] / (radii[s] + radii[t])
            mstar = masses[s] * masses[t] / (masses[s] + masses[t])
            cn = 2 * zeta(e_n) * math.sqrt(mstar * KN) if e_n < 1 else 0.0
            tangential = f"tangential linear_history {KN!r} 0.0 {mu!r}"
            gamma_roll = beta * cn * radii[s] * radii[t] / reff ** 2
            rolling = f"rolling sds {kr / reff ** 2!r} {gamma_roll!r} {mu_r / reff!r}" if mu_r > 0 else "rolling none"
            lines.append(f"pair_coeff {s + 1} {t + 1} hooke {KN!r} {cn!r} damping velocity {tangential} {rolling} twisting none")
    return "\n".join(lines)


def lammps_header(dim, data):
    return f"""units lj
dimension {dim}
atom_style sphere
atom_modify map array
boundary p p p
comm_modify vel yes
read_data {data}
"""


def lammps_integrator(dim):
    if dim == 2:
        return "fix 1 all nve/sphere disc\nfix 2 all enforce2d\n"
    return "fix 1 all nve/sphere\n"


# --- 1. Pair tests -------------------------------------------------------------------------------------------

def chain_case(name, dim, diameters, masses, spins, mu, mu_r, e_n=1.0, beta=0.0):
    """Four grains A B A B along x, each overlapping both neighbours by OVERLAP."""
    return dict(name=name, dim=dim, diameters=np.array(diameters * 2, dtype=float), masses=np.array(masses * 2, dtype=float),
                spins=np.array(spins, dtype=float), mu=mu, mu_r=mu_r, e_n=e_n, beta=beta)


def chain_state(case):
    d = case["diameters"]
    gaps = 0.5 * (d + np.roll(d, -1)) - OVERLAP          # centre distance to the right-hand neighbour
    x = np.concatenate(([0.5 * gaps[-1]], 0.5 * gaps[-1] + np.cumsum(gaps[:-1])))
    length = gaps.sum()
    pos = np.zeros((4, case["dim"]))
    pos[:, 0] = x
    return pos, length


def moment_of_inertia(dim, m, d):
    return (0.5 if dim == 2 else 0.4) * m * (d / 2) ** 2


def stick_slip(u0, omega, decel, t):
    """One spring and one inertia from a relative speed u0 with the spring relaxed: u = u0 cos(Omega t) while it
    sticks; if the spring reaches its bound theta_b = decel / Omega^2 (when |u0| / Omega > theta_b), u falls at
    decel until it stops, and the spring, left at the bound, swings back: u = -theta_b Omega sin(Omega t')."""
    bound = decel / omega ** 2
    if abs(u0) / omega <= bound:
        return u0 * np.cos(omega * t)
    t1 = math.asin(bound * omega / abs(u0)) / omega
    u1 = u0 * math.cos(omega * t1)
    t2 = t1 + abs(u1) / decel
    s = np.sign(u0)
    return np.where(t < t1, u0 * np.cos(omega * t),
                    np.where(t < t2, u1 - s * decel * (t - t1), -s * bound * omega * np.sin(omega * (t - t2))))


def chain_closed_form(case, t, velocity_radius=None):
    """Spins of grains A and B (about z) from the closed form. Rolling (alternating spins): one relative spin
    u = w_B - w_A, Omega^2 = 2 K_R (1/I_A + 1/I_B), decel = 2 mu_R F_n (1/I_A + 1/I_B), with I_A w_A + I_B w_B
    kept. Sliding (equal disks, equal spins w = u, no rolling): the tangential spring xi' = -2 R' w, torque
    -R' k_t xi per contact, so Omega^2 = 4 R'^2 k_t / I, decel = 2 R' mu F_n / I, with grains' lever arm and
    contact-velocity radius R' = R - delta / 2. LAMMPS' contact velocity uses R (velocity_radius): xi' = -2 R w,
    Omega^2 = 4 R R' k_t / I."""
    dim, d, m = case["dim"], case["diameters"], case["masses"]
    ia, ib = moment_of_inertia(dim, m[0], d[0]), moment_of_inertia(dim, m[1], d[1])
    wa, wb = case["spins"][0][-1], case["spins"][1][-1]
    fn = KN * OVERLAP
    if wa == wb:   # sliding
        lever = d[0] / 2 - OVERLAP / 2
        radius = lever if velocity_radius is None else velocity_radius
        u = stick_slip(wa, math.sqrt(4 * lever * radius * KN / ia), 2 * lever * case["mu"] * fn / ia, t)
        return u, u
    inv = 1 / ia + 1 / ib
    omega = math.sqrt(2 * KR_RATIO * KN * inv)
    if case["beta"] > 0:   # the rolling dashpot: only while the springs stick (elastic cases)
        mstar = case["masses"][0] * case["masses"][1] / (case["masses"][0] + case["masses"][1])
        cr = case["beta"] * 2 * zeta(case["e_n"]) * math.sqrt(mstar * KN) * d[0] * d[1] / 4
        gamma = cr * inv   # u'' + 2 gamma u' + Omega^2 u = 0, u(0) = u0, theta(0) = 0
        damped = math.sqrt(omega ** 2 - gamma ** 2)
        u = (wb - wa) * np.exp(-gamma * t) * (np.cos(damped * t) - gamma / damped * np.sin(damped * t))
        if np.abs(np.cumsum(u) * (t[1] - t[0])).max() * KR_RATIO * KN > case["mu_r"] * fn:
            u = np.full_like(t, np.nan)   # it slides: no closed form here
    else:
        u = stick_slip(wb - wa, omega, 2 * case["mu_r"] * fn * inv, t)
    w_a = (ia * wa + ib * wb - ib * u) / (ia + ib)
    return w_a, w_a + u


def crossing_frequency(t, y):
    """Angular frequency of an oscillation from its zero crossings (linear interpolation between samples)."""
    k = np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    crossings = t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
    return math.pi * (len(crossings) - 1) / (crossings[-1] - crossings[0])


def run_chain(binary, work, case, steps, every):
    name, dim = case["name"], case["dim"]
    pos, length = chain_state(case)
    width = 4.0
    lengths = [length, width] + ([width] if dim == 3 else [])
    v = np.zeros((4, dim))
    spins3 = np.array([[0, 0, s[0]] if dim == 2 else s for s in case["spins"]], dtype=float)
    # LAMMPS
    flat = np.c_[pos, np.zeros(4)] if dim == 2 else pos
    lammps_data(work / f"{name}.data", flat, np.c_[v, np.zeros(4)] if dim == 2 else v, (0.0, -width / 2, -0.5 if dim == 2 else -width / 2),
                (length, width / 2, 0.5 if dim == 2 else width / 2), diameters=case["diameters"], masses=case["masses"],
                types=[1, 2, 1, 2], spins=spins3)
    radii = [case["diameters"][0] / 2, case["diameters"][1] / 2]
    (work / f"{name}.lmp").write_text(lammps_header(dim, f"{name}.data")
                                      + lammps_pair(radii, case["masses"][:2], case["mu"], case["mu_r"], case["e_n"], case["beta"]) + f"""
neighbor 0.1 bin
neigh_modify every 1 delay 0
timestep {DT!r}
{lammps_integrator(dim)}dump 1 all custom {every} {name}.dump id omegax omegay omegaz
dump_modify 1 sort id format float %.17g
thermo {steps}
run {steps}
""")
    run(["lmp", "-in", f"{name}.lmp", "-log", "none"], work)
    frames = (work / f"{name}.dump").read_text().split("ITEM: ATOMS id omegax omegay omegaz\n")[1:]
    lmp = np.array([np.array(f.split("ITEM:")[0].split(), dtype=float).reshape(4, 4)[:, 1:] for f in frames])
    # grains (positions shifted into the box's lower corner at the origin)
    table = work / f"{name}.txt"
    write_table(table, pos + np.r_[0.0, width / 2, [width / 2] * (dim - 2)], v, case["diameters"], case["masses"])
    spins = "angular_velocities = [" + ", ".join("[" + ", ".join(repr(float(c)) for c in s) + "]" for s in case["spins"]) + "]\n"
    scene = grains_scene(work, name, table, lengths, True, grains_law(case["mu"], case["mu_r"], case["e_n"], case["beta"]), steps, every, DT, 0.1,
                         particles_extra=spins, snapshots_every=every)
    out = work / f"{name}.h5"
    run([binary, "run", scene, "--quiet", "--out", out, "--set", "run.threads=1"], work)
    with h5py.File(out, "r") as f:
        w = f["particles/all/angular_velocity/value"][:]
        step = f["particles/all/angular_velocity/step"][:]
    g = np.zeros((len(w), 4, 3))
    if dim == 2:
        g[:, :, 2] = w
    else:
        g[:] = w
    if len(g) != len(lmp):
        raise RuntimeError(f"{name}: {len(g)} grains frames against {len(lmp)} LAMMPS frames")
    t = step * DT
    wa, wb = chain_closed_form(case, t)
    exact = np.zeros_like(g)
    exact[:, 0::2, 2] = wa[:, None]
    exact[:, 1::2, 2] = wb[:, None]
    if dim == 3:   # the twist about n (x) is free: those spins keep their values
        exact[:, :, 0] = case["spins"][None, :, 0]
        exact[:, :, 1] = case["spins"][None, :, 1]
    exact_lammps = exact.copy()
    if case["spins"][0][-1] == case["spins"][1][-1]:
        exact_lammps[:, :, 2] = chain_closed_form(case, t, case["diameters"][0] / 2)[0][:, None]
    return t, g, lmp, exact, exact_lammps


PAIR_CASES = [
    chain_case("disks-rolling", 2, [1.0, 1.0], [1.0, 1.0], [[2.0], [-2.0], [2.0], [-2.0]], 0.5, 0.005),
    chain_case("disks-elastic", 2, [1.0, 1.0], [1.0, 1.0], [[0.3], [-0.3], [0.3], [-0.3]], 0.5, 0.005),
    chain_case("disks-damped", 2, [1.0, 1.0], [1.0, 1.0], [[0.3], [-0.3], [0.3], [-0.3]], 0.5, 0.005, 0.5, 0.01),
    chain_case("disks-damped-rolling", 2, [1.0, 1.0], [1.0, 1.0], [[2.0], [-2.0], [2.0], [-2.0]], 0.5, 0.005, 0.5, 0.01),
    chain_case("disks-unequal", 2, [1.0, 0.6], [1.0, 0.36], [[2.0], [-1.0], [2.0], [-1.0]], 0.0, 0.005),
    chain_case("spheres-rolling", 3, [1.0, 1.0], [1.0, 1.0],
               [[0.5, 0.0, 2.0], [-0.5, 0.0, -2.0], [0.5, 0.0, 2.0], [-0.5, 0.0, -2.0]], 0.5, 0.005),
    chain_case("disks-sliding", 2, [1.0, 1.0], [1.0, 1.0], [[2.0], [2.0], [2.0], [2.0]], 0.5, 0.005),
    chain_case("disks-sticking", 2, [1.0, 1.0], [1.0, 1.0], [[0.1], [0.1], [0.1], [0.1]], 0.5, 0.005),
]


# --- 2. Packings ---------------------------------------------------------------------------------------------

PACK = {2: dict(n=300, phi=0.85, gas=0.3), 3: dict(n=250, phi=0.66, gas=0.15)}   # count, jammed and initial solid fraction
PACK_SEED = 20261205
PACK_D = (1.0, 0.7)


def volume(dim, d):
    return np.pi / 4 * d ** 2 if dim == 2 else np.pi / 6 * d ** 3


def mass(dim, d):
    """Density 4/pi (2D) or 6/pi (3D): a grain of diameter 1 has mass 1."""
    return volume(dim, d) / volume(dim, 1.0)


def packing(work, dim):
    """Bidisperse grains (PACK_D, 1:1) jammed by LAMMPS: a random gas shrunk by fix deform to the solid fraction
    PACK[dim]["phi"] with a frictionless damped law, then relaxed. (positions, diameters, types, box length,
    the types' radii, the types' masses)."""
    n, phi, gas = PACK[dim]["n"], PACK[dim]["phi"], PACK[dim]["gas"]
    rng = np.random.default_rng(PACK_SEED)
    types = np.array([1 + (k % 2) for k in range(n)])
    d = np.array([PACK_D[t - 1] for t in types])
    final = float(volume(dim, d).sum() / phi) ** (1 / dim)
    start = float(volume(dim, d).sum() / gas) ** (1 / dim)
    x = np.zeros((n, dim))
    for k, dk in enumerate(d):   # random insertion without overlaps
        while True:
            x[k] = rng.uniform(0, start, dim)
            r = x[:k] - x[k]
            r -= start * np.round(r / start)
            if np.all(np.linalg.norm(r, axis=1) > 0.5 * (dk + d[:k])):
                break
    flat = np.c_[x, np.zeros(n)] if dim == 2 else x
    lo, hi = (0.0, 0.0, -0.5 if dim == 2 else 0.0), (start, start, 0.5 if dim == 2 else start)
    lammps_data(work / f"gas{dim}.data", flat, np.zeros((n, 3)), lo, hi, diameters=d, masses=mass(dim, d), types=types)
    axes = " ".join(f"{a} final 0.0 {final!r}" for a in "xyz"[:dim])
    (work / f"jam{dim}.lmp").write_text(lammps_header(dim, f"gas{dim}.data") + f"""pair_style granular
pair_coeff * * hooke {KN!r} 200.0 damping velocity tangential linear_nohistory 0.0 0.0
neighbor 0.1 bin
neigh_modify every 1 delay 0
timestep {DT!r}
{lammps_integrator(dim)}fix 3 all viscous 2.0
fix 4 all deform 1 {axes} remap x
run 40000
unfix 4
run 20000
write_data jammed{dim}.data
""")
    run(["lmp", "-in", f"jam{dim}.lmp", "-log", "none"], work)
    lines = (work / f"jammed{dim}.data").read_text().splitlines()
    at = lines.index(next(l for l in lines if l.startswith("Atoms")))
    rows = np.array([l.split()[:7] for l in lines[at + 2:at + 2 + n]], dtype=float)
    rows = rows[np.argsort(rows[:, 0])]
    box = next(l for l in lines if l.endswith("xlo xhi")).split()
    length = float(box[1]) - float(box[0])
    x = (rows[:, 4:4 + dim] - float(box[0])) % length
    return x, rows[:, 2], rows[:, 1].astype(int), length, [r / 2 for r in PACK_D], [float(mass(dim, r)) for r in PACK_D]


PACK_STEPS, PACK_EVERY, PACK_SNAP = 20000, 500, 50
PACK_SEEDS = 8


def lammps_pair_equal(radii, masses, mu, mu_r, e_n):
    """The control: the mapping of two grains of diameter 1 (R_eff = 1/4) for every type pair, as one atom type
    would have it: k_roll and mu_roll wrong by (0.25 / R_eff)^2 and 0.25 / R_eff for the smaller grains' pairs."""
    law = lammps_pair([0.5, 0.5], masses[:1] * 2, mu, mu_r, e_n).splitlines()[1].split(" hooke ", 1)[1]
    lines = ["pair_style granular"]
    for s in range(len(radii)):
        for t in range(s, len(radii)):
            mstar = masses[s] * masses[t] / (masses[s] + masses[t])
            cn = 2 * zeta(e_n) * math.sqrt(mstar * KN) if e_n < 1 else 0.0
            words = law.split()
            words[1] = repr(float(cn))
            lines.append(f"pair_coeff {s + 1} {t + 1} hooke " + " ".join(words))
    return "\n".join(lines)


def run_packing(binary, work, dim, state, mu, mu_r, e_n, steps, seed, control=False):
    """The jammed state with Gaussian velocities (rms 0.1 per axis) and spins (rms 3 per axis) drawn with `seed`,
    run by both codes: ((step, translational, rotational) per code, the snapshot steps, and (velocities, spins)
    per code every PACK_SNAP steps up to 2000)."""
    x, d, types, length, radii, masses = state
    n = len(x)
    spin_axes = 1 if dim == 2 else 3
    rng = np.random.default_rng([PACK_SEED, seed])
    m = mass(dim, d)
    v = rng.standard_normal((n, dim)) * 0.1
    v -= (m[:, None] * v).sum(axis=0) / m.sum()
    w = rng.standard_normal((n, spin_axes)) * 3.0
    name = f"pack{dim}-{mu:g}-{mu_r:g}-{e_n:g}-{seed}" + ("-control" if control else "")
    snaps = min(steps, 2000)
    pad = lambda a: np.c_[a, np.zeros(n)] if dim == 2 else a
    lo, hi = (0.0, 0.0, -0.5 if dim == 2 else 0.0), (length, length, 0.5 if dim == 2 else length)
    lammps_data(work / f"{name}.data", pad(x), pad(v), lo, hi, diameters=d, masses=m, types=types,
                spins=np.c_[np.zeros((n, 2)), w] if dim == 2 else w)
    pair = (lammps_pair_equal if control else lammps_pair)(radii, masses, mu, mu_r, e_n)
    rotation = ("""# erotate/sphere would use a sphere's I = 2/5 m r^2; the disks turn with I = 1/2 m r^2 (nve/sphere disc)
compute disc all property/atom radius omegaz
variable spin atom 0.25*mass*c_disc[1]^2*c_disc[2]^2
compute rot all reduce sum v_spin
""" if dim == 2 else "compute rot all erotate/sphere\n")
    columns = "vx vy omegaz" if dim == 2 else "vx vy vz omegax omegay omegaz"
    lmp = lammps_thermo(work, name, lammps_header(dim, f"{name}.data") + pair + f"""
neighbor 0.1 bin
neigh_modify every 1 delay 0
timestep {DT!r}
{lammps_integrator(dim)}{rotation}thermo_style custom step ke c_rot
thermo_modify norm no format float %.15g
thermo {PACK_EVERY}
dump 1 all custom {PACK_SNAP} {name}.dump id {columns}
dump_modify 1 sort id format float %.17g
run {snaps}
undump 1
run {steps - snaps}
""")
    lmp = lmp[np.r_[True, np.diff(lmp[:, 0]) > 0]]   # the second run repeats the first one's last row
    frames = (work / f"{name}.dump").read_text().split(f"ITEM: ATOMS id {columns}\n")[1:]
    width = dim + spin_axes
    lmp_snap = np.array([np.array(f.split("ITEM:")[0].split(), dtype=float).reshape(n, 1 + width)[:, 1:] for f in frames])
    table = work / f"{name}.txt"
    write_table(table, x, v, d, m)
    spins = "angular_velocities = [" + ", ".join("[" + ", ".join(repr(float(c)) for c in wk) + "]" for wk in w) + "]\n"
    scene = grains_scene(work, name, table, [length] * dim, True, grains_law(mu, mu_r, e_n), steps, PACK_EVERY, DT, 0.1,
                         particles_extra=spins, snapshots_every=PACK_SNAP)
    out = work / f"{name}.h5"
    run([binary, "run", scene, "--quiet", "--out", out, "--set", "run.threads=1"], work)
    with h5py.File(out, "r") as f:
        o = f["observables"]
        g = np.c_[o["translational_energy/step"][:], o["translational_energy/value"][:], o["rotational_energy/value"][:]]
        step = f["particles/all/velocity/step"][:]
        keep = step <= snaps
        spin = f["particles/all/angular_velocity/value"][keep]
        g_snap = np.concatenate((f["particles/all/velocity/value"][keep], spin[:, :, None] if dim == 2 else spin), axis=2)
    if len(lmp) != len(g) or not np.array_equal(lmp[:, 0], g[:, 0]):
        raise RuntimeError(f"{name}: the two codes' output steps differ")
    if g_snap.shape != lmp_snap.shape:
        raise RuntimeError(f"{name}: {g_snap.shape} grains snapshots against {lmp_snap.shape} LAMMPS'")
    return g, lmp, step[keep], g_snap, lmp_snap


def divergence(a, b, dim):
    """rms difference of the velocities and of the spins between two runs, over the rms of the first."""
    rms = lambda x: np.sqrt((x ** 2).sum(axis=(1, 2)))
    return rms(a[:, :, :dim] - b[:, :, :dim]) / rms(a[:, :, :dim]), rms(a[:, :, dim:] - b[:, :, dim:]) / rms(a[:, :, dim:])


# (e_N, mu, mu_R / a, control) per dimension: frictionless first (rolling alone, and at e_N = 1 with the same
# bounds), then with friction, then (2D) the paper's e_N.
PACK_CASES = {2: [(1.0, 0.0, 0.0, False), (1.0, 0.0, 0.005, False), (1.0, 0.0, 0.5, False), (1.0, 0.0, 0.5, True),
                  (1.0, 0.5, 0.0, False), (1.0, 0.5, 0.005, False), (1.0, 0.5, 0.5, False),
                  (0.015, 0.5, 0.0, False), (0.015, 0.5, 0.005, False), (0.015, 0.5, 0.5, False)],
              3: [(1.0, 0.0, 0.0, False), (1.0, 0.0, 0.005, False), (1.0, 0.0, 0.5, False), (1.0, 0.0, 0.5, True),
                  (1.0, 0.5, 0.005, False)]}
DIVERGENCE_TIMES = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2)
ENERGY_TIMES = (0.1, 0.25, 0.5, 1.0, 2.0)


def pack_report(binary, work, dim, steps, seeds):
    state = packing(work, dim)
    x, d, length = state[0], state[1], state[3]
    n = len(x)
    r = x[:, None, :] - x[None, :, :]
    r -= length * np.round(r / length)
    overlap = 0.5 * (d[:, None] + d[None, :]) - np.linalg.norm(r, axis=2)
    touching = overlap[np.triu_indices(n, 1)]
    touching = touching[touching > 0]
    grains = "disks" if dim == 2 else "spheres"
    report = ["", f"## {dim}D: {n} bidisperse {grains} (diameters 1 and 0.7, 1:1) jammed at solid fraction {PACK[dim]['phi']}",
              "", f"{len(touching)} contacts (z = {2 * len(touching) / n:.2f}), mean overlap {touching.mean():.1e}, largest "
              f"{touching.max():.1e}; {seeds} draws of Gaussian velocities (rms 0.1 per axis) and spins (rms 3 per axis); "
              f"dt = 1e-4, {steps} steps.", "",
              "(a) How fast the two codes' trajectories part: rms difference of the velocities and of the spins over their "
              "rms, the median over the draws (v / w). The control runs LAMMPS with one type's coefficients "
              "(R_eff = 1/4 for every pair: K_R 2.04 times and mu_R 1.43 times too large between small grains).", "",
              "| e_N | mu | mu_R / a | " + " | ".join(f"t = {t:g}" for t in DIVERGENCE_TIMES) + " |",
              "|---|---|---|" + "---|" * len(DIVERGENCE_TIMES)]
    energy = ["", f"(b) Kinetic energy per {grains[:-1]}: grains / LAMMPS, translational / rotational (the mean of the draws' "
              "ratios ± its standard error), and LAMMPS' own values (the mean over the draws).", "",
              "| e_N | mu | mu_R / a | " + " | ".join(f"t = {t:g}" for t in ENERGY_TIMES) + " |",
              "|---|---|---|" + "---|" * len(ENERGY_TIMES)]
    for e_n, mu, mu_r, control in PACK_CASES[dim]:
        runs = [run_packing(binary, work, dim, state, mu, mu_r, e_n, steps, seed, control) for seed in range(seeds)]
        label = f"| {e_n:g} | {mu:g} | {mu_r:g}{' (control)' if control else ''} |"
        t_snap = runs[0][2] * DT
        parted = [divergence(r[3], r[4], dim) for r in runs]
        dv, dw = np.median([p[0] for p in parted], axis=0), np.median([p[1] for p in parted], axis=0)
        cells = []
        for t in DIVERGENCE_TIMES:
            k = np.argmin(np.abs(t_snap - t))
            cells.append(f"{dv[k]:.1e} / {dw[k]:.1e}" if abs(t_snap[k] - t) < 1e-9 else "")
        report.append(label + " " + " | ".join(cells) + " |")
        t_e = runs[0][0][:, 0] * DT
        cells = []
        for t in ENERGY_TIMES:
            k = np.argmin(np.abs(t_e - t))
            if abs(t_e[k] - t) > 1e-9:
                cells.append("")
                continue
            rt = np.array([r[0][k, 1] / r[1][k, 1] for r in runs])
            rr = np.array([r[0][k, 2] / r[1][k, 2] for r in runs])
            lt = np.mean([r[1][k, 1] for r in runs]) / n
            lr = np.mean([r[1][k, 2] for r in runs]) / n
            sem = lambda a: a.std(ddof=1) / math.sqrt(len(a)) if len(a) > 1 else float("nan")
            cells.append(f"{rt.mean():.3f} ± {sem(rt):.3f} / {rr.mean():.3f} ± {sem(rr):.3f} ({lt:.2e} / {lr:.2e})")
        energy.append(label + " " + " | ".join(cells) + " |")
        print(f"{dim}D " + report[-1] + "\n" + energy[-1], flush=True)
    return report + energy


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("lammps-rolling"))
    ap.add_argument("--steps", type=int, default=PACK_STEPS, help="packing steps (dt = 1e-4)")
    ap.add_argument("--seeds", type=int, default=PACK_SEEDS, help="draws of the packing's velocities and spins")
    ap.add_argument("--binary", type=pathlib.Path, default=ROOT / "build" / "runner" / "grains")
    ap.add_argument("--pairs-only", action="store_true", help="only part 1 (seconds)")
    ap.add_argument("--dims", type=int, nargs="+", choices=(2, 3), default=[2, 3], help="the packings' dimensions")
    args = ap.parse_args()
    tool_args.require_counts(ap, steps=args.steps, seeds=args.seeds)
    if args.steps < 2000 or args.steps % PACK_EVERY:
        ap.error(f"--steps = {args.steps}: must be a multiple of {PACK_EVERY}, at least 2000")
    if problem := out_folder_problem(args.out, ["summary.md"]):
        ap.error(problem)
    args.binary = args.binary.resolve()   # the runs start in a scratch directory
    tool_args.require_binary(ap, "--binary", args.binary)
    if not shutil.which("lmp"):
        sys.exit(f"{ap.prog}: error: LAMMPS (`lmp`, Debian package lammps) is not installed; "
                 "bash runner/with_lammps.sh compare_lammps_rolling.py installs it")
    report = ["# Rolling resistance: grains against LAMMPS `pair granular` (rolling sds)", "",
              f"`python runner/compare_lammps_rolling.py --steps {args.steps} --seeds {args.seeds}`", "",
              f"## 1. Four-grain chains (delta = {OVERLAP:g}, F_n = {KN * OVERLAP:g}, K_R = {KR_RATIO * KN:g}, "
              f"mu_R = 0.005, dt = {DT:g})", "",
              "Largest difference of any spin component over the run, relative to the largest initial spin.", "",
              "| case | steps | grains - LAMMPS | grains - closed form | LAMMPS - closed form | LAMMPS - closed form "
              "with R in the contact velocity |", "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        for case in PAIR_CASES:
            steps, every = (1000, 1) if case["name"].startswith(("disks-sliding", "disks-sticking")) else (5000, 10)
            t, g, lmp, exact, exact_lammps = run_chain(args.binary, work, case, steps, every)
            scale = np.abs(case["spins"]).max()
            diffs = [np.abs(a - b).max() / scale for a, b in ((g, lmp), (g, exact), (lmp, exact), (lmp, exact_lammps))]
            report.append(f"| {case['name']} | {steps} | " + " | ".join("—" if math.isnan(x) else f"{x:.1e}" for x in diffs) + " |")
            if case["name"] == "disks-sliding":
                stop = [int(np.argmax(a[:, 0, 2] <= 0)) * every for a in (g, lmp, exact)]
                slide = [np.abs(a[:stop[2] // every, 0, 2] - b[:stop[2] // every, 0, 2]).max() / scale
                         for a, b in ((g, lmp), (g, exact), (lmp, exact))]
                amp = [np.abs(a[stop[2] // every + 50:, 0, 2]).max() for a in (g, lmp, exact)]
                sliding_note = (f"disks-sliding (equal spins: friction, no rolling): the spins stop at step {stop[0]} "
                                f"(grains), {stop[1]} (LAMMPS), {stop[2]} (closed form); while sliding they differ by "
                                f"{slide[0]:.1e} (grains - LAMMPS), {slide[1]:.1e} and {slide[2]:.1e} (each - closed form); "
                                f"the tangential springs then swing back with spin amplitudes {amp[0]:.5f}, {amp[1]:.5f} and "
                                f"{amp[2]:.5f}. Later differences are the phase of that stiff swing (Omega dt = 0.089): "
                                "velocity Verlet's own phase error and LAMMPS' contact velocity with R against grains' R - delta/2.")
            if case["name"] == "disks-sticking":
                # The stuck springs' frequency, from the spins' zero crossings, against the closed form's, which
                # velocity Verlet (leapfrog) turns into (2 / dt) asin(Omega dt / 2).
                lever, radius = 0.5 - OVERLAP / 2, 0.5
                ia = moment_of_inertia(2, 1.0, 1.0)
                measured = [crossing_frequency(t, a[:, 0, 2]) for a in (g, lmp)]
                predicted = [2 / DT * math.asin(math.sqrt(4 * lever * r * KN / ia) * DT / 2) for r in (lever, radius)]
                sticking_note = (f"disks-sticking (equal spins 0.1: the tangential springs never slide): the swing's angular "
                                 f"frequency is {measured[0]:.4f} in grains and {measured[1]:.4f} in LAMMPS (ratio "
                                 f"{measured[0] / measured[1]:.6f}); the closed form, with leapfrog's dispersion, gives "
                                 f"{predicted[0]:.4f} for grains' contact velocity (R - delta/2) and {predicted[1]:.4f} "
                                 f"for LAMMPS' (R): ratio {predicted[0] / predicted[1]:.6f}.")
            print(report[-1], flush=True)
        report += ["", sliding_note, "", sticking_note]
        if not args.pairs_only:
            report += ["", "## 2. Packings"]
            for dim in args.dims:
                report += pack_report(args.binary, work, dim, args.steps, args.seeds)
    print("\n".join(report))
    make_out_after_runs(ap, args.out)
    (args.out / "summary.md").write_text("\n".join(report) + "\n")


if __name__ == "__main__":
    main()
