#include "protocols/initial_state.hpp"
#include "core/morton.hpp"
#include "io/file_kind.hpp"
#include "io/printable.hpp"
#include "protocols/initial_overlaps.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <cstdint>

#include <unistd.h>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace grains {
namespace {

// The memory a run may use: the machine's, or its container's limit (cgroup v2) when that is smaller.
double usable_memory_bytes() {
  double bytes = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
  std::ifstream limit("/sys/fs/cgroup/memory.max");
  double cap = 0;
  if (limit >> cap && cap > 0) bytes = bytes > 0 ? std::min(bytes, cap) : cap;   // "max" (no limit) does not parse
  return bytes;
}

template <int D> double ball_volume(double r) {
  return D == 3 ? 4.0 / 3.0 * std::numbers::pi * r * r * r : std::numbers::pi * r * r;
}

// Total volume (3D) or area (2D) of the particles.
template <int D> double solid_volume(const Particles<D>& P) {
  double v = 0;
  for (double r : P.radius) v += ball_volume<D>(r);
  return v;
}

// `row`: the row of a list of vectors; none for a key that is one vector (box.lengths).
constexpr std::size_t single = std::size_t(-1);
template <int D>
Vec<D> to_vec(const Scene& s, std::string_view key, const std::vector<double>& v, std::size_t row) {
  if (v.size() != std::size_t(D))
    s.fail(key, row == single ? fmt::format("{} values; a {}D scene needs {}", v.size(), D, D)
                              : fmt::format("row {} has {} components; a {}D scene needs {}", row, v.size(), D, D));
  Vec<D> out;
  for (int a = 0; a < D; ++a) out[a] = v[a];
  return out;
}

// The placed particles by cell: an open-addressed table of the occupied cells' keys (non-negative), each with
// the last particle placed there, and a chain through the earlier ones. std::unordered_multimap takes 75-110 s
// for 1e6 spheres at solid fraction 0.3; which particles a cell holds is all a
// candidate's test reads, so the placements are the same.
class PlacedByCell {
 public:
  explicit PlacedByCell(std::size_t particles) : next_(particles, none) {
    std::size_t size = 64;
    while (size < 2 * particles) size *= 2;
    cells_.assign(size, Cell{}), mask_ = size - 1;
  }
  void add(long long key, std::size_t i) {
    Cell& c = cells_[slot(key)];
    c.key = key, next_[i] = c.last, c.last = i;
  }
  template <class Visit> bool all_of(long long key, Visit&& ok) const {   // ok(j) for the cell's particles
    for (std::size_t j = cells_[slot(key)].last; j != none; j = next_[j])
      if (!ok(j)) return false;
    return true;
  }

 private:
  static constexpr std::size_t none = std::size_t(-1);
  std::size_t slot(long long key) const {   // the key's slot, or the empty one where it would go
    std::uint64_t h = std::uint64_t(key) * 0x9E3779B97F4A7C15ull;
    std::size_t s = std::size_t(h ^ (h >> 29)) & mask_;
    while (cells_[s].key != key && cells_[s].key != -1) s = (s + 1) & mask_;
    return s;
  }
  struct Cell {   // a key and its particle side by side: one cache line read for both
    long long key = -1;
    std::size_t last = none;
  };
  std::vector<Cell> cells_;
  std::vector<std::size_t> next_;
  std::size_t mask_ = 0;
};

// Non-overlapping random insertion in the given order; returns the first particle it could not place (or
// P.size()). Candidates are checked against a hashed cell grid whose cells are at least one largest diameter
// wide and tile each periodic axis exactly (so neighbours across the boundary are found by wrapping cell indices).
template <int D>
std::size_t insert_in_order(Particles<D>& P, const Box<D>& box, const std::vector<std::size_t>& order,
                            long attempts_per_particle, std::mt19937_64& rng, const PreparationProgress& progress,
                            std::string_view task) {
  const double dmax = 2 * *std::max_element(P.radius.begin(), P.radius.end());
  std::array<long long, D> n;
  Vec<D> cell;
  for (int a = 0; a < D; ++a) {
    // At most 1e6 cells an axis (wider cells find the same pairs), so that the keys below cannot overflow: a tiny
    // grain's L / d in a large box (1e-30 in 10) overflowed the integer it was converted to (found by fuzzing).
    n[a] = (long long)std::clamp(std::floor(box.length[a] / dmax), 1.0, 1e6);
    cell[a] = box.length[a] / double(n[a]);
  }
  PlacedByCell grid(P.size());
  auto key = [&](std::array<long long, D> c) {
    long long k = 0;
    for (int a = 0; a < D; ++a) {
      if (box.periodic[a]) c[a] = ((c[a] % n[a]) + n[a]) % n[a];
      k = k * 2000003 + c[a] + 1000000;
    }
    return k;
  };
  auto coords = [&](const Vec<D>& x) {
    std::array<long long, D> c;
    for (int a = 0; a < D; ++a) c[a] = (long long)std::floor((x[a] - box.lower[a]) / cell[a]);
    return c;
  };
  std::uniform_real_distribution<double> u(0, 1);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t i = order[k];
    if (progress && k % 256 == 0) progress(task, k, order.size());
    bool placed = false;
    for (long t = 0; t < attempts_per_particle && !placed; ++t) {
      Vec<D> x;
      for (int a = 0; a < D; ++a) x[a] = box.lower[a] + u(rng) * box.length[a];
      const auto home = coords(x);
      bool ok = true;
      std::array<int, D> o;
      o.fill(-1);
      for (bool more = true; more && ok;) {
        auto c = home;
        for (int a = 0; a < D; ++a) c[a] += o[a];
        ok = grid.all_of(key(c), [&](std::size_t j) {
          return box.minimum_image(P.position[j] - x).norm() >= P.radius[i] + P.radius[j];
        });
        int a = 0;
        while (a < D && ++o[a] == 2) o[a++] = -1;
        more = a < D;
      }
      if (ok) {
        P.position[i] = x;
        grid.add(key(home), i);
        placed = true;
      }
    }
    if (!placed) return i;
  }
  return P.size();
}

// Random insertion in the particles' order. Where that jams (polydisperse spheres near 0.3: a large grain
// finds no hole late in the filling), it starts again placing the largest first, which fills further; layouts
// that the first pass completes are kept as they were.
template <int D>
void place_randomly(const Scene& s, Particles<D>& P, const Box<D>& box, std::mt19937_64& rng,
                    const PreparationProgress& progress) {
  const long attempts_per_particle = 20000;
  std::vector<std::size_t> order(P.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  if (insert_in_order(P, box, order, attempts_per_particle, rng, progress, "random insertion") == P.size()) return;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return P.radius[a] > P.radius[b]; });
  const std::size_t failed =
      insert_in_order(P, box, order, attempts_per_particle, rng, progress, "random insertion, largest first");
  if (failed == P.size()) return;
  const std::size_t rank = std::find(order.begin(), order.end(), failed) - order.begin();
  double reached = 0;   // the solid fraction of the particles placed before the one that found no hole
  for (std::size_t k = 0; k < rank; ++k) reached += ball_volume<D>(P.radius[order[k]]);
  reached /= box.volume();
  // Each particle gets a fixed number of attempts, so the fraction random insertion reaches falls as the count
  // grows (the last holes are rarer the more there are to fill): equal spheres at 0.36 are placed for 10^4 but
  // not for 10^5, and 0.34 not for 10^6 (after 8.5 minutes).
  s.fail(s.has("box.lengths") ? "box.lengths" : "particles.solid_fraction",
         fmt::format("random insertion could not place the particles at solid fraction {:.4g}, neither in their order "
                     "nor largest first: it jammed at {:.4g} ({} of {} placed, then {} attempts at the next); the "
                     "fraction it reaches falls as the particles grow in number (equal {} jam near {} for a thousand, "
                     "lower for more{}); lower the solid fraction below {:.4g} "
                     "({}) or use particles.layout = \"lattice\"",
                     solid_volume(P) / box.volume(), reached, rank, P.size(), attempts_per_particle,
                     D == 3 ? "spheres" : "disks", D == 3 ? "0.38" : "0.55",
                     D == 3 ? ": 0.36 places 10^4 spheres but not 10^5" : "", reached,
                     s.has("box.lengths") ? "wider box.lengths" : "particles.solid_fraction"));
}

// Renumbers randomly placed particles along a Z-order (Morton) curve of the box, so that particles
// close in space are close in memory. A random insertion numbers them in random places; the pair
// loop then gathers from all over memory, and with two threads both cores write nearly every cache
// line each step. Grains move only a few diameters while a type-2 sample aggregates, so the order
// lasts through a consolidation cycle. Sizes, masses and images move with the positions (the particles are
// exchangeable: only their labels change).
template <int D>
void number_along_z_curve(Particles<D>& P, const Box<D>& box) {
  constexpr int bits = morton::key_bits<D>;
  const double cells = std::ldexp(1.0, bits), top = cells - 1;
  const std::size_t N = P.size();
  std::vector<unsigned long long> keys(N);
  std::vector<int> order(N);
  for (std::size_t i = 0; i < N; ++i) {
    std::array<unsigned long long, D> q;
    for (int a = 0; a < D; ++a)
      q[a] = static_cast<unsigned long long>(std::clamp((P.position[i][a] - box.lower[a]) / box.length[a] * cells, 0.0, top));
    keys[i] = morton::key<D>(q), order[i] = int(i);
  }
  morton::radix_sort(keys, order);
  const auto position = P.position;
  const auto radius = P.radius, mass = P.mass;
  const auto image = P.image;   // all zero this early; carried so the order never parts a particle from its image
  for (std::size_t i = 0; i < N; ++i) {
    P.position[i] = position[order[i]];
    P.image[i] = image[order[i]];
    P.set_mass_and_radius(i, mass[order[i]], radius[order[i]]);
  }
}

}  // namespace

template <int D>
InitialState<D> make_initial_state(const Scene& s, const PreparationProgress& progress) {
  InitialState<D> st;
  auto& P = st.particles;
  auto& box = st.box;
  const std::string layout = s.text("particles.layout");
  std::mt19937_64 rng(std::uint64_t(s.integer("particles.seed")));

  // --- count and explicit rows ---
  constexpr std::size_t spin_columns = D == 3 ? 3 : 1;   // a file's spin columns, after its velocity columns
  std::vector<std::vector<double>> rows;   // layout = file
  std::vector<int> row_lines;              // each row's line in the file, for messages
  std::filesystem::path file_path;
  std::size_t N = 0;
  if (layout == "list") {
    N = s.matrix("particles.positions").size();
    if (N == 0) s.fail("particles.positions", "layout \"list\" needs at least one position");
  } else if (layout == "file") {
    auto& path = file_path;
    path = *particle_file(s);
    // An ifstream opens a folder and reads nothing from it, and reads a device (/dev/zero: one line without end)
    // until memory runs out. A pipe is read as a file. No size limit: a particle table may be large.
    std::error_code ec;
    if (const auto kind = not_a_regular_file(path.string()); kind && !std::filesystem::is_fifo(path, ec))
      s.fail("particles.file", fmt::format("'{}' is {}: name a file of particle rows (a regular file or a pipe)",
                                           path.string(), *kind));
    std::ifstream in(path);
    if (!in)
      s.fail("particles.file", fmt::format("cannot read '{}' ({})", printable(path.string()),
                                           std::filesystem::exists(path, ec) ? "it exists, but could not be opened for reading" : "no such file"));
    std::string line;
    int first_row_line = 0;
    for (int lineno = 1; std::getline(in, line); ++lineno) {
      // A byte-order mark that some editors write before the first line: it is no part of the first number.
      if (lineno == 1 && line.starts_with("\xef\xbb\xbf")) line.erase(0, 3);
      if (auto h = line.find('#'); h != std::string::npos) line.resize(h);
      std::istringstream ls(line);
      std::vector<double> r;
      for (std::string word; ls >> word;) {   // every word a number: a stray one is an error, not the row's end
        char* end = nullptr;
        const double v = std::strtod(word.c_str(), &end);
        // strtod reads C's hexadecimal numbers too ("0x10" = 16), which a table of decimal numbers does not hold, and
        // stops at a NUL inside the word ("3\0" "77" read as 3: a crash's zero-filled block would pass)
        if (end != word.c_str() + word.size() || word.empty() || word.find_first_of("xX") != std::string::npos)
          s.fail("particles.file", fmt::format("{}:{}: column {}: '{}' is not a decimal number", printable(path.string()),
                                               lineno, r.size() + 1, printable_excerpt(word)));
        // strtod reads "nan", "inf" and overflowing literals such as 1e999 too
        if (!std::isfinite(v))
          s.fail("particles.file", fmt::format("{}:{}: column {}: '{}' is {}, expected a finite number",
                                               printable(path.string()), lineno, r.size() + 1, printable_excerpt(word), v));
        r.push_back(v);
      }
      if (r.empty()) continue;
      if (r.size() != std::size_t(D + 2) && r.size() != std::size_t(2 * D + 2) && r.size() != std::size_t(2 * D + 2 + spin_columns))
        s.fail("particles.file", fmt::format("{}:{}: {} columns; expected {} (x.. diameter mass), {} (with velocity) or {} "
                                             "(with velocity and spin {})", path.string(), lineno, r.size(), D + 2, 2 * D + 2,
                                             2 * D + 2 + spin_columns, D == 3 ? "wx wy wz" : "w"));
      // The first row decides whether the file gives velocities: every row must follow it.
      if (!rows.empty() && r.size() != rows[0].size())
        s.fail("particles.file", fmt::format("{}:{}: {} columns, but the first particle row (line {}) has {}: every row "
                                             "needs the same columns ({} without velocity, {} with, {} with spin too)",
                                             path.string(), lineno, r.size(), first_row_line, rows[0].size(), D + 2,
                                             2 * D + 2, 2 * D + 2 + spin_columns));
      if (rows.empty()) first_row_line = lineno;
      rows.push_back(r);
      row_lines.push_back(lineno);
    }
    N = rows.size();
    if (N == 0) s.fail("particles.file", fmt::format("'{}' holds no particle rows", path.string()));
  }
  // Listed and file particles are counted, not drawn: a count given beside them must agree (it was ignored).
  if ((layout == "list" || layout == "file") && s.has("particles.count") && s.integer("particles.count") != std::int64_t(N))
    s.fail("particles.count", fmt::format("value {}, but {} {} particles: give {} or leave the count out",
                                          s.integer("particles.count"),
                                          layout == "list" ? "particles.positions lists" : "particles.file holds", N, N));
  if (layout != "list" && layout != "file") {
    N = std::size_t(s.integer("particles.count"));
    // Refuse what cannot fit before allocating (Linux would hand out the memory and kill the run later). The
    // least a run keeps per particle, its peak resident memory measured: in 3D 750 bytes (the aggregation FMU;
    // `grains run` of the gas 800-950 from 8k to 512k spheres), in 2D 320 (the consolidation FMU; a lean
    // `grains run` 530). A lower figure lets 3D counts through that are killed when they touch the memory.
    const double per_particle = D == 3 ? 750.0 : 300.0;
    const double need = per_particle * double(N), have = usable_memory_bytes();
    if (have > 0 && need > have)
      s.fail("particles.count", fmt::format("value {} needs at least {:.3g} GB of memory (about {:g} bytes a particle in "
                                            "{}D); this machine (or its container) has {:.3g} GB",
                                            N, need / 1e9, per_particle, D, have / 1e9));
  }
  P.resize(N);

  // --- sizes and masses ---
  const std::string dist = s.text("particles.size_distribution");
  std::vector<double> diam(N, s.real("particles.diameter"));
  if (layout == "file") {
    for (std::size_t i = 0; i < N; ++i) diam[i] = rows[i][D];
  } else if (layout == "list" && s.has("particles.diameters")) {
    diam = s.reals("particles.diameters");
    if (diam.size() != N) s.fail("particles.diameters", fmt::format("{} values for {} positions", diam.size(), N));
  } else if (dist == "uniform") {
    const double lo = s.real("particles.diameter_min"), hi = s.real("particles.diameter_max");
    if (hi < lo) s.fail("particles.diameter_max", fmt::format("{} is below diameter_min = {}", hi, lo));
    std::uniform_real_distribution<double> u(lo, hi);
    for (auto& d : diam) d = u(rng);
  }
  std::vector<double> mass(N);
  const double density = s.real("particles.density");
  for (std::size_t i = 0; i < N; ++i) mass[i] = density * ball_volume<D>(0.5 * diam[i]);
  if (layout == "file") {
    for (std::size_t i = 0; i < N; ++i) mass[i] = rows[i][D + 1];
  } else if (layout == "list" && s.has("particles.masses")) {
    mass = s.reals("particles.masses");
    if (mass.size() != N) s.fail("particles.masses", fmt::format("{} values for {} positions", mass.size(), N));
  } else if (s.has("particles.mass")) {
    std::fill(mass.begin(), mass.end(), s.real("particles.mass"));
  }
  // The keys that set the masses and the sizes, for the messages below
  const char* mass_key = layout == "file"                                   ? "particles.file"
                         : layout == "list" && s.has("particles.masses")    ? "particles.masses"
                         : s.has("particles.mass")                          ? "particles.mass"
                                                                            : "particles.density";
  const char* diameter_key = layout == "file"                                 ? "particles.file"
                             : layout == "list" && s.has("particles.diameters") ? "particles.diameters"
                             : dist == "uniform"                                ? "particles.diameter_max"
                                                                                : "particles.diameter";
  for (std::size_t i = 0; i < N; ++i) {
    // Sizes first (a huge diameter makes an infinite mass). Products of two masses or sizes (reduced masses,
    // stiffnesses, G m m) must neither overflow nor vanish: so not just positive and finite, but in range.
    if (!(diam[i] >= 1e-100 && diam[i] <= 1e100))
      s.fail(diameter_key, fmt::format("gives particle {} the diameter {:.3g}; diameters must lie within [1e-100, 1e100]: "
                                       "choose other units", i, diam[i]));
    if (!(mass[i] >= 1e-150 && mass[i] <= 1e150))
      s.fail(mass_key, fmt::format("gives particle {} the mass {:.3g}; masses must lie within [1e-150, 1e150], where "
                                   "products of two of them stay finite and nonzero: choose other units", i, mass[i]));
    P.set_mass_and_radius(i, mass[i], 0.5 * diam[i]);
  }

  // --- box ---
  const double solids = solid_volume(P);
  for (int a = 0; a < D; ++a) box.periodic[a] = s.boolean("box.periodic");
  if (s.has("box.lengths")) {
    auto L = s.reals("box.lengths");
    box.length = to_vec<D>(s, "box.lengths", L, single);
  } else if (s.has("particles.solid_fraction")) {
    const double fraction = s.real("particles.solid_fraction");
    box.length.setConstant(std::pow(solids / fraction, 1.0 / D));
    // A fraction far below any packing's (1e-309) overflows the volume: the run went non-finite at its first step.
    if (!std::isfinite(box.length[0]))
      s.fail("particles.solid_fraction", fmt::format("value {:.6g} makes the box's volume (solid volume {:.6g} / fraction) "
                                                     "overflow a double: allowed a fraction at least {:.3g} here",
                                                     fraction, solids, solids / 1e308));
  } else if (layout == "lattice" || layout == "random" || box.any_periodic()) {
    s.fail("box.lengths", "give box.lengths or particles.solid_fraction to size the box");
  } else {
    box.length.setConstant(1.0);   // open system with explicit positions: nominal box only
  }
  if (s.has("box.lower")) box.lower = to_vec<D>(s, "box.lower", s.reals("box.lower"), single);

  // --- positions ---
  if (layout == "lattice") {
    const long n = std::lround(std::pow(double(N), 1.0 / D));
    long total = 1;
    for (int a = 0; a < D; ++a) total *= n;
    if (total != long(N))
      s.fail("particles.count", fmt::format("{} is not a perfect {}: a lattice layout needs n^{} particles (e.g. {})",
                                            N, D == 3 ? "cube" : "square", D, total));
    for (std::size_t i = 0; i < N; ++i) {
      std::size_t r = i;
      for (int a = 0; a < D; ++a, r /= n) P.position[i][a] = box.lower[a] + (double(r % n) + 0.5) * box.length[a] / n;
    }
    const double spacing = box.length.minCoeff() / n;
    const double dmax = 2 * *std::max_element(P.radius.begin(), P.radius.end());
    if (spacing < dmax) {
      if (s.has("box.lengths"))   // the box is the scene's own, not sized from the solid fraction
        s.fail("box.lengths", fmt::format("the lattice spacing {:.4g} (the shortest length over {} per side) is below the "
                                          "largest diameter {:.4g}: particles would overlap; lengthen the box or use "
                                          "smaller or fewer particles", spacing, n, dmax));
      s.fail("particles.solid_fraction", fmt::format("the lattice spacing {:.4g} is below the largest diameter {:.4g}: "
                                                     "particles would overlap; lower the solid fraction", spacing, dmax));
    }
  } else if (layout == "random") {
    place_randomly<D>(s, P, box, rng, progress);
    number_along_z_curve<D>(P, box);
  } else if (layout == "list") {
    auto pos = s.matrix("particles.positions");
    for (std::size_t i = 0; i < N; ++i) P.position[i] = to_vec<D>(s, "particles.positions", pos[i], i);
  } else {
    for (std::size_t i = 0; i < N; ++i)
      for (int a = 0; a < D; ++a) P.position[i][a] = rows[i][a];
  }
  // Given positions (the other layouts place particles apart): a coincident pair has no contact direction (its
  // force is NaN), one overlapping beyond the contact's limit flies apart with its clamped spring's energy.
  if ((layout == "list" || layout == "file") && s.boolean("contact.enabled")) {
    const double limit = s.real("contact.overlap_limit");
    const InitialOverlaps o = find_initial_overlaps<D>(P, box, limit);
    const char* key = layout == "list" ? "particles.positions" : "particles.file";
    auto particle = [&](std::size_t i) {
      return layout == "list" ? fmt::format("particle {} (row {})", i, i)
                              : fmt::format("particle {} ({}:{})", i, file_path.string(), row_lines[i]);
    };
    if (o.coincident)
      s.fail(key, fmt::format("{} and {} are at the same position ({}): a contact between them has no direction; "
                              "move one of them", particle(o.same_i), particle(o.same_j),
                              fmt::join(P.position[o.same_i], ", ")));
    if (o.deep > 0)
      st.warnings.push_back(fmt::format(
          "{}: {} pair(s) of particles overlap at the start beyond the contact's limit contact.overlap_limit * "
          "min(R_i, R_j) = {} min(R_i, R_j); the deepest, {} and {}, by {:.6g} ({:.4g} min(R_i, R_j)): such pairs fly "
          "apart with the energy of the clamped spring", key, o.deep, limit, particle(o.i), particle(o.j), o.overlap,
          o.ratio));
  }

  // --- velocities ---
  const std::string vel = s.text("particles.velocity");
  // A file's velocity columns are the velocities unless drawn or listed ones take their place (they did silently).
  if (layout == "file" && rows[0].size() >= std::size_t(2 * D + 2) && vel != "zero")
    st.warnings.push_back(fmt::format("the velocity columns of particles.file '{}' are not used: particles.velocity = \"{}\" "
                                      "takes their place", file_path.string(), vel));
  if (vel == "gaussian") {
    std::normal_distribution<double> g(0, 1);
    Vec<D> mean = Vec<D>::Zero();
    double msum = 0;
    for (std::size_t i = 0; i < N; ++i) {
      for (int a = 0; a < D; ++a) P.velocity[i][a] = g(rng);
      mean += P.mass[i] * P.velocity[i];
      msum += P.mass[i];
    }
    mean /= msum;
    double ke = 0;
    for (std::size_t i = 0; i < N; ++i) {
      if (N > 1) P.velocity[i] -= mean;
      ke += 0.5 * P.mass[i] * P.velocity[i].squaredNorm();
    }
    const double target = s.real("particles.kinetic_energy") * double(N);
    const double scale = ke > 0 ? std::sqrt(target / ke) : 1.0;
    // The speeds squared must stay finite (the energies and the time-step checks square them).
    if (!std::isfinite(target) || !std::isfinite(scale * scale * ke))
      s.fail("particles.kinetic_energy", fmt::format("value {} per particle gives {} particles speeds whose energy "
                                                     "overflows a double: allowed a value whose total is finite",
                                                     s.real("particles.kinetic_energy"), N));
    for (auto& v : P.velocity) v *= scale;
  } else if (vel == "list") {
    auto v = s.matrix("particles.velocities");
    if (v.size() != N) s.fail("particles.velocities", fmt::format("{} velocities for {} particles", v.size(), N));
    for (std::size_t i = 0; i < N; ++i) P.velocity[i] = to_vec<D>(s, "particles.velocities", v[i], i);
  } else if (layout == "file" && rows[0].size() >= std::size_t(2 * D + 2)) {
    for (std::size_t i = 0; i < N; ++i)
      for (int a = 0; a < D; ++a) P.velocity[i][a] = rows[i][D + 2 + a];
  }
  // Given speeds must keep the kinetic energy finite, as the Gaussian's above (the energies and the time-step
  // checks square them): name the row at which the sum overflows.
  double kinetic = 0;
  for (std::size_t i = 0; i < N && vel != "gaussian"; ++i) {   // the Gaussian's were checked as they were scaled
    kinetic += 0.5 * P.mass[i] * P.velocity[i].squaredNorm();
    if (std::isfinite(kinetic)) continue;
    const std::string what = fmt::format("the velocity ({}) of particle {} (mass {:.3g}) makes the kinetic energy summed "
                                         "up to it overflow a double: allowed speeds whose total energy is finite",
                                         fmt::join(P.velocity[i], ", "), i, P.mass[i]);
    if (vel == "list") s.fail("particles.velocities", fmt::format("row {}: {}", i, what));
    s.fail("particles.file", fmt::format("{}:{}: {}", file_path.string(), row_lines[i], what));
  }
  // A file's spin columns (a spinning body of more grains than a scene's text may list)
  const bool file_spins = layout == "file" && rows[0].size() == std::size_t(2 * D + 2 + spin_columns);
  if (file_spins && s.has("particles.angular_velocities"))
    s.fail("particles.angular_velocities", fmt::format("particles.file '{}' gives spins too (its last {} columns): give them "
                                                       "in one place", file_path.string(), spin_columns));
  if (file_spins)
    for (std::size_t i = 0; i < N; ++i)
      for (std::size_t a = 0; a < spin_columns; ++a) P.angular_velocity[i][a] = rows[i][2 * D + 2 + a];
  if (s.has("particles.angular_velocities")) {
    auto w = s.matrix("particles.angular_velocities");
    if (w.size() != N) s.fail("particles.angular_velocities", fmt::format("{} rows for {} particles", w.size(), N));
    for (std::size_t i = 0; i < N; ++i) {
      if (w[i].size() != spin_columns)
        s.fail("particles.angular_velocities", fmt::format("row {} has {} components; a {}D scene needs {} ({})", i, w[i].size(), D, spin_columns,
                                                         D == 2 ? "[w], the spin about the axis normal to the plane" : "[wx, wy, wz]"));
      for (std::size_t a = 0; a < spin_columns; ++a) P.angular_velocity[i][a] = w[i][a];
    }
  }
  double rotational = 0;
  for (std::size_t i = 0; i < N; ++i) {
    rotational += 0.5 * P.inertia[i] * P.angular_velocity[i].squaredNorm();
    if (std::isfinite(rotational)) continue;
    const std::string what = fmt::format("the spin of particle {} makes the rotational energy summed up to it overflow a "
                                         "double: allowed spins whose total energy is finite", i);
    if (file_spins) s.fail("particles.file", fmt::format("{}:{}: {}", file_path.string(), row_lines[i], what));
    s.fail("particles.angular_velocities", fmt::format("row {}: {}", i, what));
  }
  return st;
}

std::optional<std::filesystem::path> particle_file(const Scene& s) {
  if (s.text("particles.layout") != "file") return std::nullopt;
  auto path = std::filesystem::path(s.text("particles.file"));
  return path.is_relative() ? s.directory() / path : path;
}

template <int D>
UnitGrain unit_grain(const Scene& s, const Particles<D>& P) {
  const std::size_t big = std::max_element(P.radius.begin(), P.radius.end()) - P.radius.begin();
  const UnitGrain largest{2 * P.radius[big], P.mass[big]};
  const std::string layout = s.text("particles.layout");
  if (layout == "file" || (layout == "list" && s.has("particles.diameters"))) return largest;
  const double a = s.text("particles.size_distribution") == "uniform" ? s.real("particles.diameter_max")
                                                                       : s.real("particles.diameter");
  if ((layout == "list" && s.has("particles.masses")) || s.has("particles.mass")) return {a, largest.mass};
  return {a, s.real("particles.density") * ball_volume<D>(0.5 * a)};
}

template InitialState<2> make_initial_state<2>(const Scene&, const PreparationProgress&);
template InitialState<3> make_initial_state<3>(const Scene&, const PreparationProgress&);
template UnitGrain unit_grain<2>(const Scene&, const Particles<2>&);
template UnitGrain unit_grain<3>(const Scene&, const Particles<3>&);

}  // namespace grains
