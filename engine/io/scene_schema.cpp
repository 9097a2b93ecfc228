// The scene format: every key, its type, dimension (so its unit), default, allowed range and meaning, in one table.
// docs/scene-reference.md is generated from this table (`grains scene-reference`).
#include <algorithm>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "io/file_name.hpp"
#include "io/scene.hpp"

namespace grains {
namespace {
constexpr double inf = 1e308;
// Sizes and masses whose products (reduced masses, stiffnesses, G m m) neither overflow nor vanish: the bounds
// that protocols/initial_state.cpp checks every particle's size and mass against, drawn or derived ones too.
constexpr double size_min = 1e-100, size_max = 1e100, mass_min = 1e-150, mass_max = 1e150;
using K = ValueKind;
// The keys' dimensions (io/scene_units.hpp): L, M, T and the space's measure, a volume in 3D and an area in 2D.
constexpr Dimension pure{}, length{.length = 1}, mass{.mass = 1}, duration{.time = 1}, rate{.time = -1},
    speed{.length = 1, .time = -1}, force{.length = 1, .mass = 1, .time = -2},
    energy{.length = 2, .mass = 1, .time = -2}, stiffness{.mass = 1, .time = -2}, density{.mass = 1, .space = -1},
    gravitational_constant{.length = 3, .mass = -1, .time = -2};
constexpr std::nullopt_t not_a_quantity = std::nullopt;
}  // namespace

const std::vector<SchemaEntry>& scene_schema() {
  static const std::vector<SchemaEntry> schema = {
      // --- scene ---
      {"scene.name", K::text, not_a_quantity, "\"unnamed\"", 0, 0, false, false, "",
       "Short name, used for the default output file names (`<name>.h5`, `<name>-stages.h5`, `<name>-stages.csv`).", true},
      {"scene.description", K::text, not_a_quantity, "\"\"", 0, 0, false, false, "", "Free text stored with the output."},
      {"scene.dimension", K::integer, pure, "3", 2, 3, false, false, "", "2 = disks in the plane, 3 = spheres."},

      // --- particles ---
      {"particles.layout", K::text, not_a_quantity, "\"lattice\"", 0, 0, false, false, "lattice|random|list|file",
       "Initial positions: `lattice` (simple cubic/square, centred cells), `random` (non-overlapping random "
       "insertion), `list` (explicit `positions`), `file` (whitespace table, see `particles.file`)."},
      {"particles.count", K::integer, pure, "", 1, 1e9, false, false, "",
       "Number of particles (lattice/random). For `lattice` it must be n^D. Listed or file particles are counted: a count given with them must agree."},
      {"particles.seed", K::integer, pure, "1", 0, 9.2e18, false, false, "", "Seed of every random choice in the set-up."},
      {"particles.diameter", K::real, length, "1.0", size_min, size_max, false, false, "", "Diameter of every particle (size distribution `constant`)."},
      {"particles.size_distribution", K::text, not_a_quantity, "\"constant\"", 0, 0, false, false, "constant|uniform",
       "`uniform`: diameters uniform in [diameter_min, diameter_max]."},
      {"particles.diameter_min", K::real, length, "0.5", size_min, size_max, false, false, "", "Smallest diameter (size distribution `uniform`)."},
      {"particles.diameter_max", K::real, length, "1.0", size_min, size_max, false, false, "",
       "Largest diameter (size distribution `uniform`), at least `diameter_min`."},
      {"particles.density", K::real, density, "1.0", 0, inf, true, false, "",
       "Mass per volume (3D) or per area (2D); m = density * volume unless `mass` is given (every mass so made within "
       "[1e-150, 1e150], as `mass`)."},
      {"particles.mass", K::real, mass, "", mass_min, mass_max, false, false, "", "If set, the mass of every particle, whatever its size."},
      {"particles.solid_fraction", K::real, pure, "", 0, 1, true, true, "",
       "Sets the box size (a cube or square of the particles' total volume / value) when `box.lengths` is absent, "
       "whatever the layout: listed or file particles too."},
      {"particles.track_orientation", K::boolean, not_a_quantity, "true", 0, 0, false, false, "",
       "Integrate each particle's orientation (3D: a unit quaternion turned by the exact rotation of omega dt; 2D: "
       "an angle) and write it to the output. No force depends on it (the grains are round), so a scene that does not "
       "look at orientations may set false: the step then skips that update (in the frictional gas about a tenth of "
       "the work) and the output has no orientation."},
      {"particles.velocity", K::text, not_a_quantity, "\"zero\"", 0, 0, false, false, "zero|gaussian|list",
       "Initial velocities: zero (for a particle file with velocity columns: the file's), Gaussian (zero total momentum, "
       "scaled to `kinetic_energy`), or explicit `velocities`; these two take the place of a file's (a warning says so)."},
      {"particles.kinetic_energy", K::real, energy, "1.5", 0, inf, false, false, "",
       "Translational kinetic energy per particle for `velocity = \"gaussian\"`."},
      {"particles.positions", K::real_matrix, length, "", 0, 0, false, false, "", "Layout `list`: one [x, y(, z)] per particle."},
      {"particles.velocities", K::real_matrix, speed, "", 0, 0, false, false, "", "Velocity `list`: one vector per particle."},
      {"particles.angular_velocities", K::real_matrix, rate, "", 0, 0, false, false, "",
       "Optional, any layout: one [wx, wy, wz] (3D) or [w] (2D) per particle, in the particles' order (the rows of "
       "`positions` or of the file; lattice and random layouts number their particles themselves)."},
      {"particles.diameters", K::real_array, length, "", size_min, size_max, false, false, "", "Layout `list`: one diameter per particle (else `diameter`)."},
      {"particles.masses", K::real_array, mass, "", mass_min, mass_max, false, false, "", "Layout `list`: one mass per particle (else from density)."},
      {"particles.file", K::text, not_a_quantity, "", 0, 0, false, false, "",
       "Layout `file`: path (relative to the scene) of a table with columns x y [z] diameter mass [vx vy [vz] [w | wx wy wz]] "
       "(the spin columns, [w] in 2D, only after the velocity columns, and not with `angular_velocities`); `#` starts a comment. Diameters "
       "within [1e-100, 1e100] and masses within [1e-150, 1e150], as `diameters` and `masses`."},

      // --- box ---
      {"box.lengths", K::real_array, length, "", 0, inf, true, false, "",
       "Box edge lengths, one per axis; default: from `particles.solid_fraction` (cube/square), or open."},
      {"box.lower", K::real_array, length, "", -inf, inf, false, false, "", "Lower corner; default the origin."},
      {"box.periodic", K::boolean, not_a_quantity, "true", 0, 0, false, false, "",
       "Periodic on every axis. `false` = open space (no walls; the box only sets the initial layout)."},

      // --- normal contact ---
      {"contact.enabled", K::boolean, not_a_quantity, "true", 0, 0, false, false, "", "Linear spring-dashpot normal contact (physics.md section 2)."},
      {"contact.restitution", K::real, pure, "0.9", 0, 1, true, false, "", "Normal restitution coefficient e in (0, 1]."},
      {"contact.duration", K::real, duration, "", 0, inf, true, false, "",
       "Contact duration t_c of the reference collision (required when contacts are on)."},
      {"contact.calibration", K::text, not_a_quantity, "\"global\"", 0, 0, false, false, "global|per-pair|exact",
       "`global`: one (k_n, c_n) from the smallest reduced mass; `per-pair`: k and c from each pair's reduced mass "
       "(constant e and t_c); `exact`: global, with the damping solved so the clamped collision realises e exactly, and k_n "
       "so that its force pulse (until the clamped force falls to zero) lasts t_c: softer than physics.md section 2's "
       "k_n (by 29 % at e = 0.5), the surfaces parting later than t_c."},
      {"contact.overlap_limit", K::real, pure, "0.1", 0, 1, true, false, "",
       "f_max: overlaps beyond f_max * min(R_i, R_j) are clamped, counted and reported."},

      // --- friction ---
      {"friction.coefficient", K::real, pure, "0.0", 0, inf, false, false, "",
       "Coulomb coefficient mu; 0 leaves the friction module out entirely."},
      {"friction.stiffness_ratio", K::real, pure, "1.0", 0, inf, true, false, "", "k_t / k_n."},
      {"friction.damping_ratio", K::real, pure, "0.0", 0, inf, false, false, "", "c_t / c_n."},

      // --- adhesion (consolidation scene) ---
      {"adhesion.enabled", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "Adhesive normal law of physics.md section 6 instead of the restitution-calibrated spring-dashpot: "
       "F_N = K_N delta - F0 - c_n v_n while overlapping, -F0 (1 - h / D0) for gaps 0 <= h < D0, nothing beyond. "
       "`contact.restitution`, `duration` and `calibration` are not used; `contact.overlap_limit` still applies. "
       "Friction is bounded by the elastic part K_N delta. The defaults are the paper's Table I in units a = 1, F0 = 1 "
       "(`range` relative to a, so in any units)."},
      {"adhesion.force", K::real, force, "1.0", 0, inf, false, false, "",
       "F0: the constant attraction of contacting grains, the largest tensile force a bond carries. 0 = the cohesionless "
       "reference (same law, no attraction). Must stay below K_N `contact.overlap_limit` R_min, the largest elastic force "
       "a clamped contact gives (R_min the smallest radius): a bond rests at the overlap F0 / K_N, beyond the clamp "
       "no overlap balances F0 and bonded grains sink through each other, so such a value is refused."},
      {"adhesion.range", K::real, length, "", 0, inf, false, false, "",
       "D0 (length): the attraction fades linearly to zero as the gap grows from 0 to D0; default 1e-3 a (the paper's "
       "D0 / a = 1e-3), a = the size distribution's largest diameter (for listed or file particles the largest given)."},
      {"adhesion.stiffness", K::real, stiffness, "1e5", 0, inf, true, false, "",
       "K_N (force / length), the same for every pair (paper: kappa = a K_N / F0 = 1e5). The time step is "
       "dt = t_c / time.steps_per_contact with t_c = pi sqrt(m*_min / K_N), m*_min the smallest reduced mass."},
      {"adhesion.restitution", K::real, pure, "0.015", 0, 1, true, false, "",
       "e_N: sets the normal damping c_n = 2 zeta sqrt(m* K_N) per pair as if F0 = 0, zeta = -ln e / sqrt(pi^2 + ln^2 e); "
       "the dashpot acts only while grains overlap (paper: 0.015)."},

      // --- rolling resistance ---
      {"rolling.coefficient", K::real, length, "0.0", 0, inf, false, false, "",
       "mu_R (length): the rolling moment is bounded by mu_R K_N delta (physics.md section 5; paper: mu_R / a = 0 or "
       "0.005). 0 leaves the rolling module out entirely. Needs `adhesion.enabled` (the consolidation law)."},
      {"rolling.stiffness_ratio", K::real, pure, "1e-4", 0, inf, true, false, "",
       "K_R / (K_N a^2), a = the size distribution's largest diameter (`particles.diameter_max` or `diameter`; for listed "
       "or file particles the largest given), as in P* (paper: 1e-4). Not tied to `rolling.coefficient`: physics.md "
       "section 5 derives both from one length l (K_R = K_N l^2, mu_R = mu l), whose l = a / 100 gives the paper's 1e-4 "
       "with mu_R / a = 0.005 at mu = 0.5; for the paper's large rolling resistance (mu_R / a = 0.5, its section V E) "
       "the same reading would give l = a and a ratio of 1, where the paper names no other K_R: this key stays 1e-4 "
       "unless set."},
      {"rolling.damping_ratio", K::real, pure, "0.0", 0, 1, false, false, "",
       "c_r / (c_n R_i R_j): a dashpot -c_r (w_j - w_i) on the relative spin of touching grains (3D: rolling and "
       "twisting), consolidation law only, with or without rolling resistance. Not in the paper (it damps normal "
       "motion only). Without it rolling mechanisms of a loose network, which no normal or sliding motion "
       "reveals, stay undamped and the equilibrium criteria are not met; with it they are, but it also slows the "
       "rolling rearrangements of a compaction and lowers Phi (docs/history/speed-and-reproduction-log.md: the rolling quench), so `grains consolidate` "
       "switches it on only in settled stages (`programme.quench_damping`). At most 1, and less where the explicit "
       "dashpot is not stable: a grain's spin feels the dashpots of all its contacts, stable while about z c_r dt / I "
       "< 2. The paper's disks (diameters a/2 to a) hold 1; a periodic FCC of equal spheres, the densest packing, blew "
       "up at 1 (its spin energy 1e206 times in 20,000 steps; its limit 0.99), random dense spheres held 1, and a small "
       "grain among large ones holds less. The start-up check, and a check when a host or the programme sets it, warns "
       "and names the largest value it can vouch for, cautiously (as many contacts as fit about a grain, spins "
       "alternating on each: 0.55-0.65 for the 3D scenes, 0.86 for the 2D ones at 25 steps per contact, where 1-1.25 "
       "held). In a pressure-controlled cell also the tunable parameter `rolling.damping_ratio`, "
       "which a host may change between steps."},

      // --- drag ---
      {"drag.rate", K::real, rate, "0.0", 0, inf, false, false, "",
       "gamma (1 / time): every step multiplies each velocity (relative to the cell's affine flow, if any) and spin "
       "by exp(-gamma dt), a drag on every grain. In no paper's law: a relaxation aid that damps every motion alike, "
       "the slow collective modes of a loose network (its softest elastic modes and grains swinging about single "
       "contacts) that the contact dashpots hardly see. 0 leaves it out. Also the tunable parameter `drag.rate`, "
       "which `grains consolidate` switches on in settled stages (`programme.quench_drag`)."},

      // --- self-gravity ---
      {"gravity.enabled", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "Softened Newtonian self-gravity between all pairs (physics.md section 7). Open boxes only (`box.periodic = false`). "
       "In 2D too the 3D law, G m_i m_j / (d^2 + eps^2), acts in the plane (not a 2D logarithmic potential): the 3D "
       "references (cold collapse at pi / (2 sqrt 2) t_ff, D_f = 3 of a compact aggregate) do not apply there."},
      {"gravity.G", K::real, gravitational_constant, "1.0", 0, inf, true, false, "", "Gravitational constant G."},
      {"gravity.softening", K::real, pure, "0.1", 0, inf, false, false, "",
       "eps0: softening length eps = softening * R_min (R_min = smallest particle radius)."},
      {"gravity.solver", K::text, not_a_quantity, "\"direct\"", 0, 0, false, false, "direct|tree",
       "`direct`: exact O(N^2) summation; `tree`: Barnes-Hut octree/quadtree (monopole + quadrupole cells, one walk per group of "
       "up to 64 particles, rebuilt every step) with `opening_angle`."},
      {"gravity.opening_angle", K::real, pure, "0.5", 0, 1.5, false, false, "",
       "Barnes-Hut opening angle theta (tree solver): a cell of two or more particles is used whole for a group of "
       "particles when its centre of mass is farther from the group's bounding box than max(s / theta, b_max), s the "
       "longest edge of the box bounding the cell's particle centres and b_max the distance from the centre of mass to "
       "that box's farthest corner (so the group lies outside the cell's particles); otherwise the cell is opened. A "
       "lone particle is always summed exactly; 0 = exact. At 0.5 the median force error is 2.4e-4 to 3.8e-4 (uniform balls of 1e5 to 3000 "
       "particles; 3.4e-4 at 20,000), about 1e-3 at 0.7. From 1 on a cell may be used whole with its particles "
       "nearly as far from its centre as the group: grains in a line along a diagonal of the cells' boxes (a chain, say) "
       "then get errors of 0.29 of their force terms (1.6e-3 at 0.9)."},

      // --- aggregation analysis ---
      {"analysis.cluster_tolerance", K::real, pure, "1e-3", 0, inf, false, false, "",
       "Cluster graph (gravity scenes, physics.md section 8): i and j are linked when d < R_i + R_j + tol, "
       "tol = value * R_min."},
      {"analysis.aggregation_threshold", K::real, pure, "0.9", 0, 1, true, false, "",
       "`aggregation_time` is the first time the largest cluster holds at least this mass fraction."},
      {"analysis.every", K::integer, pure, "100", 1, 9.2e18, false, false, "",
       "Steps between the checks of the largest-cluster fraction that set `aggregation_time` (gravity scenes)."},
      {"analysis.stop_at_aggregation", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "`grains run` ends the run at the first check (every `analysis.every` steps) that finds the largest cluster at "
       "`aggregation_threshold` (gravity scenes): the run lasts until t_agg, or its length if that comes first. An FMU "
       "host decides its own stop (`aggregation_time` turns finite)."},
      {"analysis.zero_force", K::real, pure, "1e-5", 0, inf, false, false, "",
       "Contact-network outputs (adhesion scenes): an interaction whose static normal force is below "
       "value * max(F0, mean |F_N|) in magnitude counts as carrying no force (z0; and the rattlers where F0 = 0: with "
       "adhesion a rattler is a grain with no interaction at all, a bond at zero force still holding its grains)."},
      {"analysis.elastic_moduli", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "Elastic-moduli outputs (adhesion scenes in a periodic box, physics.md section 9): `B`, `G`, `C11`, `C12`, ..., "
       "`B_Voigt`, `G_Voigt`, `B_Reuss`, `Z2` and the `moduli_*` diagnostics from the stiffness matrix of the contact "
       "network, in `grains consolidate`'s stage rows. Computed only when read, but each reading is a sparse "
       "factorisation (measured 11-52 ms for 1444 disks, 0.32-2.1 s for 1000 spheres, as the host was loaded) that `grains run` would "
       "repeat at every observables record: off unless asked for (the consolidation scenes in `models/` ask)."},
      {"analysis.collision_log", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "Log every contact event (start, end, impact and rebound normal speeds; physics.md section 8) and report "
       "`collision_count`, `adhesive_collision_count`, `adhesive_collision_fraction`, `open_collision_count`. An event "
       "is adhesive when the pair, still touching, stops separating (docs/numerical-method.md: the collision event log). Needs contacts."},

      // --- pressure-controlled periodic cell (barostat) ---
      {"cell.enabled", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "Pressure-controlled periodic cell (physics.md section 9): the cell lengths obey M_c d2L/dt2 = (V/L)(sigma_aa - P) "
       "- eta_c dL/dt, integrated by CVODE; particles follow the cell affinely. Needs `box.periodic = true` and contacts."},
      {"cell.active", K::boolean, not_a_quantity, "true", 0, 0, false, false, "",
       "Whether the barostat moves the cell from the start; also the input variable `cell.active` (0 holds the cell "
       "fixed at rest, as while a type-2 sample aggregates)."},
      {"cell.pressure", K::real, pure, "0.01", 0, 1e6, false, false, "",
       "Target reduced pressure P* = a P / F0 (2D), a^2 P / F0 (3D); a = the size distribution's largest diameter "
       "(`particles.diameter_max` or `diameter`; for listed or file particles the largest given), F0 = `cell.force_unit`. "
       "Also the input variable `cell.pressure`, which a host or the runner may change between steps. A target whose "
       "force on a grain, P a^(D-1), reaches the largest elastic force of a clamped contact, K_N `contact.overlap_limit` "
       "R_min, cannot be held (the packing collapses into overlaps past the clamp): warned about, once, whether the "
       "scene, its ramp, a host or the programme sets it."},
      {"cell.pressure_final", K::real, pure, "", 0, 1e6, false, false, "",
       "P* at the end of a continuous ramp of the target pressure from `cell.pressure`, over `cell.ramp_duration` "
       "(geometric in time, a straight line in log P*, when both are positive; linear when one is 0), then held. "
       "Absent: no ramp. A host setting the input `cell.pressure` ends the ramp; the consolidation programme, "
       "which sets the pressure stage by stage, refuses it."},
      {"cell.ramp_duration", K::real, duration, "", 0, inf, true, false, "",
       "Simulated time over which the target pressure goes from `cell.pressure` to `cell.pressure_final` "
       "(required with it)."},
      {"cell.force_unit", K::real, force, "", 0, inf, false, false, "",
       "F0: the force unit of P* and of the equilibrium test; default `adhesion.force` when adhesion is on, and required "
       "without adhesion (in the scene's units: no other force of the scene sets it). 0 = cohesionless: "
       "`cell.pressure` (and `pressure_final`) is then P a^(D-2) / k_n (P / K_N in 2D), and must be > 0, and F1 = "
       "P a^(D-1)."},
      {"cell.mass", K::real, mass, "", 0, inf, true, false, "",
       "M_c: the cell's inertia; default m (L / a)^(D-2), m the mass of a grain of diameter a (in 2D: m). The cell then "
       "breathes about as fast as a contact and is damped by the contacts; a much heavier cell (say the total mass) "
       "oscillates for long after jamming."},
      {"cell.damping_ratio", K::real, pure, "0.0", 0, inf, false, false, "",
       "eta_c = damping_ratio * 2 sqrt(M_c K_cell), K_cell = k_n (L / a)^(D-2), about the cell's stiffness once the "
       "grains are jammed. Default 0: any cell damping large enough to matter for the jammed sample (say 0.1) also "
       "throttles the compression of a loose one far below the strain-rate cap; the contacts' damping settles the cell."},
      {"cell.contact_damping", K::real, pure, "0.0", 0, inf, false, false, "",
       "Optional extra drag on the cell's strain rate, eta_a = factor * c_n sum_contacts (r^a n^a)^2 / L_a^2 (global c_n, "
       "refreshed every 10 steps), as if every contact were strained affinely. The contacts' dashpots already see "
       "the affine flow's relative velocity in the pair loop and damp the cell through the stress, so the default 0 "
       "adds nothing; a positive factor over-damps tenuous cohesive networks (they buckle rather than strain "
       "affinely)."},
      {"cell.inertia_number", K::real, pure, "0.05", 0, inf, true, false, "",
       "I_a: the strain rate is capped at |dL/dt| / L <= I_a / T0, T0 = sqrt(a m / F0), m = mass of a grain of diameter "
       "a, F0 = `cell.force_unit` (physics.md section 9); a cohesionless cell (F0 = 0) uses the pressure's force "
       "P a^(D-1) for F0."},
      {"cell.rtol", K::real, pure, "1e-6", 1e-14, 1e-1, false, false, "", "CVODE relative tolerance on the cell lengths and rates."},
      {"cell.atol", K::real, pure, "1e-9", 0, inf, true, false, "",
       "CVODE absolute tolerance on the lengths in units of a (on the rates: a / T, T = sqrt(a m / F1) the output "
       "`inertial_time` at the start pressure: T0 up to P a^(D-1) = F0)."},
      {"cell.restart_cvode_every_step", K::boolean, not_a_quantity, "false", 0, 0, false, false, "",
       "Re-initialise CVODE at every particle step instead of keeping its history across steps (for the benchmark "
       "that measures what the kept history saves)."},
      {"cell.tolerance_force", K::real, pure, "1e-5", 0, inf, true, false, "",
       "Equilibrium: every net force < value * F1, F1 = max(F0, P a^(D-1))."},
      {"cell.tolerance_torque", K::real, pure, "1e-5", 0, inf, true, false, "", "Equilibrium: every net torque < value * F1 a."},
      {"cell.tolerance_stress", K::real, pure, "1e-5", 0, inf, true, false, "",
       "Equilibrium: every |sigma_aa - P| < value * F1 / a^(D-1)."},
      {"cell.tolerance_kinetic", K::real, pure, "5e-8", 0, inf, true, false, "",
       "Equilibrium: translational kinetic energy per grain (relative to the affine flow) < value * F1 a."},

      // --- consolidation programme (`grains consolidate`) ---
      {"programme.preparation", K::text, not_a_quantity, "\"none\"", 0, 0, false, false, "none|type1|type2",
       "Sample preparation before loading (physics.md section 9): `type1` equilibrates the initial gas (give it zero "
       "velocities) at `cell.pressure`; `type2` first holds the cell fixed until the grains form one bonded cluster "
       "(give them Maxwell velocities V0 / V* = 9.5), equilibrates at P* = 0, then at `cell.pressure`; `none` only "
       "equilibrates at `cell.pressure` (the cohesionless reference)."},
      {"programme.top_pressure", K::real, pure, "13.33", 0, 1e6, true, false, "",
       "P* of the last loading stage (at most cell.pressure's largest value, which each stage sets)."},
      {"programme.stages_per_decade", K::integer, pure, "8", 1, 1000, false, false, "",
       "Loading: P* is multiplied by 10^(1/value) per stage (8: the paper's factor 1.334)."},
      {"programme.unload_stages_per_decade", K::integer, pure, "2", 1, 1000, false, false, "",
       "Unloading: P* is divided by 10^(1/value) per stage, down to `cell.pressure`."},
      {"programme.load", K::boolean, not_a_quantity, "true", 0, 0, false, false, "", "Run the loading stages."},
      {"programme.unload", K::boolean, not_a_quantity, "true", 0, 0, false, false, "", "Run the unloading stages after loading."},
      {"programme.check_every", K::integer, pure, "100", 1, 9.2e18, false, false, "", "Steps between equilibrium checks."},
      {"programme.trace_every", K::integer, pure, "10000", 0, 9.2e18, false, false, "",
       "Steps between the records of `grains consolidate`'s trace: within every stage, at the first equilibrium check "
       "at or past each multiple of this many steps (counted from the programme's start), and at every stage's end (the "
       "state its stage record holds), P*, its target, Phi, z, the kinetic energy, the four equilibrium ratios, the "
       "bonded clusters and the stage's index go to grains/trace/<name> in the HDF5 output (the one full record per "
       "stage is in observables/<name>; the target is NaN in a type-2 aggregation's fixed cell); runner/plot.py draws "
       "it. 0: no trace."},
      {"programme.first_compression_time", K::real, duration, "0.0", 0, inf, false, false, "",
       "Simulated time over which the first stage under pressure (type 1 or type 2, at `cell.pressure`) raises its "
       "target linearly from 0, in steps of `check_every`, before it waits for equilibrium (its budget counts from the "
       "ramp's end). 0: a step to the full pressure, the paper's protocol. A slower first compression leaves a looser "
       "type-2 sample (docs/reproduction-consolidation.md: the pace of the first compression). Refused in a cohesionless cell (`cell.force_unit = 0`), "
       "which does not allow the ramp's start at P* = 0."},
      {"programme.stage_budget", K::integer, pure, "2000000", 1, 9.2e18, false, false, "",
       "Steps a stage may take to reach equilibrium; a stage that runs out is reported (`reached = 0`), and the programme goes on."},
      {"programme.aggregation_budget", K::integer, pure, "20000000", 1, 9.2e18, false, false, "",
       "Steps the type-2 aggregation may take to form one bonded cluster."},
      {"programme.quench_drag", K::real, pure, "1.0", 0, inf, false, false, "",
       "gamma T of the drag (`drag.rate`, T = sqrt(a m / F1) the output `inertial_time`) that quenches a settled "
       "stage: each stage starts on the paper's law (no drag); once it has settled (`settle_ratio`, `settle_checks`, "
       "`settle_compaction`) the drag is switched on, and when the four criteria hold it is switched off again; the "
       "stage is in equilibrium when they then hold at `confirm_checks` checks in a row without it. The paper's law damps relative "
       "normal motion only: its loose networks keep slow collective modes (ringing with periods of 5-40 T, decaying "
       "by about 2 % a period) far longer than a stage's budget. 0: no drag quench. The stage table's `quench_start` "
       "says when the quench began."},
      {"programme.background_drag", K::real, pure, "0.0", 0, inf, false, false, "",
       "gamma T of a weak drag on every grain (as `drag.rate`, T the output `inertial_time`) in every stage under "
       "pressure -- the compression to the start pressure, loading and unloading; not the aggregation or the "
       "relaxation at P* = 0 -- beneath the quench, which raises it to `quench_drag` and returns to it. Not in the "
       "paper's law, whose tangential and rolling motions are undamped: the inertia of a loose network collapsing "
       "under its first pressure then compacts it beyond the paper's states (docs/reproduction-consolidation.md: a weak drag). 0: none."},
      {"programme.quench_drag_min", K::real, pure, "0.125", 0, inf, false, false, "",
       "gamma T to which the quench's drag may step down: while a stage is quenched, the smallest force ratio "
       "(`equilibrium_force`) of each window of `quench_patience` checks is compared with the previous window's, and "
       "if it has not fallen by a fifth the drag halves, down to this value (refused above `quench_drag`; the default, above a "
       "smaller `quench_drag`, leaves the drag at that value). A network still creeping to a denser state creeps "
       "as fast as the drag lets it, its largest net force steady near gamma m v, while ringing modes decay under "
       "the drag; the stage table's `quench_drag` gives the value a stage ended with."},
      {"programme.quench_patience", K::integer, pure, "1000", 0, 9.2e18, false, false, "",
       "Checks per window of the drag's step-down (`quench_drag_min`); 0: the drag stays at `quench_drag`."},
      {"programme.quench_damping", K::real, pure, "0.0", 0, 1, false, false, "",
       "beta of the rolling dashpot (`rolling.damping_ratio`, consolidation law only) switched on and off with the "
       "quench, on top of the drag (the quench of earlier versions, default 0.003 then: it damps only relative spins "
       "and left the slow collective modes ringing). 0: not used."},
      {"programme.confirm_checks", K::integer, pure, "5", 1, 9.2e18, false, false, "",
       "Consecutive equilibrium checks (without the quench) at which the four criteria must hold for a stage to be in "
       "equilibrium: one check samples a single phase of whatever still rings."},
      {"programme.settle_ratio", K::real, pure, "100", 0, inf, true, false, "",
       "A stage has settled when its kinetic and stress equilibrium ratios (`equilibrium_kinetic`, "
       "`equilibrium_stress`) are below this for `settle_checks` checks in a row."},
      {"programme.settle_checks", K::integer, pure, "20", 1, 9.2e18, false, false, "",
       "Consecutive equilibrium checks a stage must stay settled before it is quenched."},
      {"programme.settle_compaction", K::real, pure, "1e-5", 0, inf, false, false, "",
       "A stage has settled only while its solid fraction also moves by less than this (relative) over those "
       "`settle_checks` checks: a loose cohesive network collapses slowly at its target pressure with the kinetic and "
       "stress ratios already small, and the quench would slow that collapse. 1: the ratios alone decide."},

      // --- time stepping ---
      {"time.dt", K::real, duration, "", 0, inf, true, false, "", "Time step; default t_c / steps_per_contact."},
      {"time.steps_per_contact", K::real, pure, "50", 1, inf, false, false, "", "n_c: steps per contact duration when dt is not given."},
      {"time.duration", K::real, duration, "", 0, inf, true, false, "", "Simulated time of a run (or give `steps` or `free_fall_times`)."},
      {"time.steps", K::integer, pure, "", 0, 1e15, false, false, "", "Number of steps of a run (or give `duration` or `free_fall_times`)."},
      {"time.free_fall_times", K::real, pure, "", 0, inf, true, false, "",
       "Length of a run in free-fall times t_ff = sqrt(R0^3 / (G M)) of the initial cloud (gravity scenes, physics.md "
       "section 8), instead of `duration` or `steps`."},

      // --- neighbour search ---
      {"neighbours.skin", K::real, length, "", 0, inf, true, false, "",
       "Verlet skin (length); default 0.2 * smallest diameter. Lists are rebuilt when a particle has moved skin/2."},
      {"neighbours.shell", K::real, length, "", 0, inf, false, false, "",
       "Thickness (length) of the shell of listed pairs the pair loop tests each step: the listed pairs whose gap "
       "is below the interaction range + shell, selected again from the list when a particle has moved shell/2. "
       "Default: adaptive, starting from skin / 10, each selection choosing the next thickness from the last one's "
       "life (a cost model: pairs tested per step against selections per step); a value fixes it; 0 tests every listed "
       "pair. Results do not depend on it (bit for bit); only the speed does."},

      // --- execution ---
      {"run.threads", K::integer, pure, "0", 0, 1024, false, false, "", "Worker threads; 0 = automatic: every core, at most one thread per 2000 particles. Results are deterministic for a given thread count, also where OpenMP starts fewer threads (`OMP_THREAD_LIMIT`, `OMP_DYNAMIC`, a host's own parallel region): each takes several threads' shares."},

      // --- output ---
      {"output.file", K::text, not_a_quantity, "", 0, 0, false, false, "", "HDF5 (H5MD) output path, relative to the working directory (not to the scene, as `particles.file` is); "
       "default `<scene.name>.h5` (`grains consolidate`: `<scene.name>-stages.h5`). The command's `--out` takes its place."},
      {"output.observables_every", K::integer, pure, "100", 1, 9.2e18, false, false, "", "Steps between scalar observable records."},
      {"output.snapshots_every", K::integer, pure, "0", 0, 9.2e18, false, false, "",
       "Steps between particle snapshots; 0 = first and last only."},
      {"output.xdmf", K::boolean, not_a_quantity, "true", 0, 0, false, false, "", "Write an XDMF file beside the HDF5 file (ParaView), and the per-frame views of the arrays it shows (/grains/xdmf, about 2.5 kB of metadata a frame)."},
      {"output.checkpoint_every", K::integer, pure, "0", 0, 9.2e18, false, false, "",
       "Steps between checkpoints of the complete state in the output file, from which `grains resume FILE.h5` "
       "continues a run or programme that was killed; 0 = only when stopped by Ctrl-C or SIGTERM (and, in "
       "`grains consolidate`, at the end of every stage but the last). A programme writes them at the first "
       "equilibrium check past every multiple of N (a stage's end past one counts as its checkpoint). Checkpoints change nothing: a run resumed from one "
       "continues bit for bit as the uninterrupted run (a pressure-controlled cell's CVODE history is replayed)."},
  };
  return schema;
}

// Keys read only with other keys' values (Scene::validate refuses them given without): each listed
// where the engine reads it (protocols/initial_state.cpp, core/simulation_setup.cpp).
const std::vector<UnreadKeyRule>& unread_key_rules() {
  static const std::vector<UnreadKeyRule> rules = [] {
    std::vector<UnreadKeyRule> r = {
        // Supersessions (a need with an empty value): read only while that key is not given.
        {"particles.diameter", {{"particles.size_distribution", "\"constant\""}}, ""},
        {"particles.density", {{"particles.mass", ""}}, ""},
        {"particles.solid_fraction", {{"box.lengths", ""}}, ""},
        {"time.steps_per_contact", {{"time.dt", ""}}, ""},
        // Listed particles' own diameters or masses, and a particle file's columns, replace the drawn or uniform
        // ones (a particles.mass beside a file was ignored without a word).
        {"particles.diameter", {{"particles.diameters", ""}}, ""},
        {"particles.diameter", {{"particles.file", ""}}, ""},
        {"particles.size_distribution", {{"particles.diameters", ""}}, ""},
        {"particles.size_distribution", {{"particles.file", ""}}, ""},
        {"particles.diameter_min", {{"particles.diameters", ""}}, ""},
        {"particles.diameter_min", {{"particles.file", ""}}, ""},
        {"particles.diameter_max", {{"particles.diameters", ""}}, ""},
        {"particles.diameter_max", {{"particles.file", ""}}, ""},
        {"particles.mass", {{"particles.masses", ""}}, ""},
        {"particles.mass", {{"particles.file", ""}}, ""},
        {"particles.density", {{"particles.masses", ""}}, ""},
        {"particles.density", {{"particles.file", ""}}, ""},
        {"gravity.opening_angle", {{"gravity.solver", "\"tree\""}}, ""},
        {"particles.diameter_min", {{"particles.size_distribution", "\"uniform\""}}, ""},
        {"particles.diameter_max", {{"particles.size_distribution", "\"uniform\""}}, ""},
        {"particles.kinetic_energy", {{"particles.velocity", "\"gaussian\""}}, ""},
        {"particles.positions", {{"particles.layout", "\"list\""}}, ""},
        {"particles.diameters", {{"particles.layout", "\"list\""}}, ""},
        {"particles.masses", {{"particles.layout", "\"list\""}}, ""},
        {"particles.file", {{"particles.layout", "\"file\""}}, ""},
        {"particles.velocities", {{"particles.velocity", "\"list\""}}, ""},
        // The moduli come from the adhesive contact network's stiffness and strain the periodic cell.
        {"analysis.elastic_moduli", {{"adhesion.enabled", "true"}, {"box.periodic", "true"}}, "true"},
        // The linear law's calibration; the adhesive law has its own stiffness and restitution.
        {"contact.restitution", {{"contact.enabled", "true"}, {"adhesion.enabled", "false"}}, ""},
        {"contact.duration", {{"contact.enabled", "true"}, {"adhesion.enabled", "false"}}, ""},
        {"contact.calibration", {{"contact.enabled", "true"}, {"adhesion.enabled", "false"}}, ""},
        {"contact.overlap_limit", {{"contact.enabled", "true"}}, ""},
        {"analysis.zero_force", {{"adhesion.enabled", "true"}}, ""},
        // The quench's rolling dashpot belongs to the consolidation law (protocols/consolidation_programme.cpp).
        {"programme.quench_damping", {{"adhesion.enabled", "true"}}, ""},
        // The aggregation analysis runs with self-gravity only.
        {"analysis.cluster_tolerance", {{"gravity.enabled", "true"}}, ""},
        {"analysis.aggregation_threshold", {{"gravity.enabled", "true"}}, ""},
        {"analysis.every", {{"gravity.enabled", "true"}}, ""},
    };
    // Each module's keys, read only with the module on. rolling.coefficient keeps the contact module's own
    // message (core/simulation_setup.cpp), which names the cohesionless alternative.
    const std::pair<std::string_view, std::string_view> modules[] = {
        {"adhesion.", "adhesion.enabled"}, {"gravity.", "gravity.enabled"}, {"friction.", "contact.enabled"},
        {"rolling.", "adhesion.enabled"}, {"cell.", "cell.enabled"}, {"programme.", "cell.enabled"}};
    for (const auto& e : scene_schema())
      for (const auto& [prefix, switch_key] : modules)
        if (e.path.starts_with(prefix) && e.path != switch_key && e.path != "rolling.coefficient")
          r.push_back({std::string(e.path), {{std::string(switch_key), "true"}}, ""});
    return r;
  }();
  return rules;
}

std::vector<std::string_view> choice_list(const SchemaEntry& e) {
  std::vector<std::string_view> list;
  if (e.choices.empty()) return list;
  for (std::size_t from = 0, bar; from <= e.choices.size(); from = bar + 1) {
    bar = std::min(e.choices.find('|', from), e.choices.size());
    list.push_back(e.choices.substr(from, bar - from));
  }
  return list;
}

const SchemaEntry* find_schema_entry(std::string_view path) {
  for (const auto& e : scene_schema())
    if (e.path == path) return &e;
  return nullptr;
}

std::string scene_key_unit(std::string_view path, int scene_dimension) {
  const SchemaEntry* e = find_schema_entry(path);
  if (!e) throw std::logic_error(fmt::format("scene_key_unit: {} is not a scene key", path));
  return e->dimension ? si_unit(*e->dimension, scene_dimension) : "";
}

namespace {
const char* kind_name(ValueKind k) {
  switch (k) {
    case K::real: return "number";
    case K::integer: return "integer";
    case K::boolean: return "boolean";
    case K::text: return "string";
    case K::real_array: return "array of numbers";
    default: return "array of number arrays";
  }
}
// The reference's unit column: both where disks and spheres differ, 1 for a pure number, nothing for text or a switch.
std::string unit_text(const SchemaEntry& e) {
  if (!e.dimension) return "";
  const std::string u3 = si_unit(*e.dimension, 3), u2 = si_unit(*e.dimension, 2);
  if (u3.empty()) return "1";
  return u3 == u2 ? u3 : fmt::format("{} (3D), {} (2D)", u3, u2);
}
std::string range_text(const SchemaEntry& e) {
  if (!e.choices.empty()) return fmt::format("one of {}", fmt::join(choice_list(e), ", "));
  if (e.kind == K::boolean || e.kind == K::text || e.kind == K::real_matrix) return "";
  bool lo = e.min > -1e307, hi = e.max < 1e307;
  // An infinite end is open: inf itself is never a value (in_range refuses non-finite ones).
  return fmt::format("{}{}, {}{}", e.min_open || !lo ? "(" : "[", lo ? fmt::format("{}", e.min) : "-inf",
                     hi ? fmt::format("{}", e.max) : "inf", e.max_open || !hi ? ")" : "]");
}
}  // namespace

std::string describe_allowed(const SchemaEntry& e) {
  if (e.file_name) return fmt::format("{}, {}", kind_name(e.kind), plain_file_name_rule);
  std::string r = range_text(e);
  if (r.empty()) return kind_name(e.kind);
  return e.choices.empty() ? fmt::format("{} in {}", kind_name(e.kind), r) : fmt::format("{}, {}", kind_name(e.kind), r);
}

std::string schema_reference_markdown() {
  std::string out =
      "# Scene reference\n\n"
      "Generated by `grains scene-reference` from `engine/io/scene_schema.cpp`; do not edit by hand.\n"
      "A scene is a TOML file; every key below is optional unless its text says otherwise, and an unknown key is an error.\n"
      "A key read only with other settings (\"Read only with\") is an error where given without them; its default is not.\n"
      "Any key can be overridden from the command line with `--set section.key=value`, the value written as in TOML; a\n"
      "string key also takes a bare word (`--set scene.name=run-2024`).\n"
      "The unit is the SI one (1: a pure number), which the FMUs declare for the keys they expose; a scene may be\n"
      "written in any consistent units instead, every key then in the scene's own (README, Units).\n";
  std::string section;
  for (const auto& e : scene_schema()) {
    auto dot = e.path.find('.');
    std::string s(e.path.substr(0, dot));
    if (s != section) {
      section = s;
      out += fmt::format("\n## [{}]\n\n| key | type / allowed | unit | default | meaning |\n|---|---|---|---|---|\n",
                         section);
    }
    std::string dflt = e.fallback.empty() ? "—" : fmt::format("`{}`", e.fallback);
    std::string doc(e.doc);
    std::vector<std::string> replacements;   // the keys that take this one's place, in one sentence
    for (const auto& rule : unread_key_rules())
      if (rule.path == e.path && rule.needs.size() == 1 && rule.needs[0].second.empty())
        replacements.push_back(fmt::format("`{}`", rule.needs[0].first));
    if (!replacements.empty()) {
      const std::string last = replacements.back();
      replacements.pop_back();
      doc += fmt::format(" Not read when {}{} is given, which takes its place (a warning says so).",
                         fmt::join(replacements, ", "), replacements.empty() ? last : " or " + last);
    }
    for (const auto& rule : unread_key_rules())
      if (rule.path == e.path) {
        if (rule.needs.size() == 1 && rule.needs[0].second.empty()) continue;   // a supersession, above
        std::vector<std::string> needs;
        for (const auto& [key, value] : rule.needs) needs.push_back(fmt::format("`{} = {}`", key, value));
        doc += fmt::format(" Read only with {}: given{} without, refused.", fmt::join(needs, " and "),
                           rule.when.empty() ? "" : fmt::format(" `{}`", rule.when));
      }
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", e.path.substr(dot + 1), describe_allowed(e), unit_text(e), dflt,
                       doc);
  }
  return out;
}

}  // namespace grains
