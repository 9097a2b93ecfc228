// Contact-network statistics of a packing (consolidation paper, physics.md section 9): coordination
// and its split by force sign, rattlers, distant attractive bonds, the normal-force distribution,
// and which contacts were kept, lost or gained since a reference state.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace grains {

// One interacting pair: a contact (gap h < 0, overlap -h) or a distant attractive bond (0 <= h < D0).
struct NetworkInteraction {
  std::uint32_t i, j;
  double gap;            // h = d - R_i - R_j
  double normal_force;   // static normal force, positive = compressive, negative = tensile
};

struct ContactNetworkOptions {
  double zero_force = 0;          // |F_N| <= zero_force counts as carrying no force (z0)
  double force_scale = 1;         // histogram of F_N / force_scale (F0, or the mean |F_N| when F0 = 0)
  double histogram_lower = -1;    // first bin edge, in units of force_scale
  double histogram_width = 0.5;   // bin width, in units of force_scale
  int histogram_bins = 20;        // plus one last bin for everything above the top edge
  // Adhesion (F0 > 0): a bond at zero force still holds its grains (it resists parting up to F0), so a rattler is a
  // grain with no interaction at all, as the consolidation paper defines them in cohesive samples ("isolated, free
  // grains with no interactions", absent after aggregation). Without: a grain none of whose interactions carries
  // a force, as in its cohesionless packings ("particles that transmit no force").
  bool bonds_hold = false;
};

struct ContactNetwork {
  long contacts = 0;         // pairs with h < 0
  long distant_bonds = 0;    // pairs attracting across a gap 0 <= h < D0, none with F0 = 0 (counted in z and, being tensile, in z-)
  double z = 0;              // 2 (contacts + distant bonds) / N
  double z_plus = 0, z_minus = 0, z_zero = 0;   // the part of z carried by compressive / tensile / zero forces
  double rattler_fraction = 0;                  // x0: rattlers per grain (ContactNetworkOptions::bonds_hold)
  double z_star = 0;                            // z / (1 - x0), the backbone's coordination (NaN if all rattle)
  // Fraction of interactions per bin of F_N / force_scale: bins below histogram_lower are folded into
  // the first bin, the last entry holds everything at or above the top edge. Sums to 1 (0 if empty).
  std::vector<double> histogram;
};

ContactNetwork analyse_contact_network(std::size_t particle_count, const std::vector<NetworkInteraction>& interactions,
                                       const ContactNetworkOptions& options);

// A contact is identified by its particle pair; keys are i * 2^32 + j with i < j, sorted.
std::vector<std::uint64_t> contact_keys(const std::vector<NetworkInteraction>& interactions);

struct ContactChanges { long kept = 0, lost = 0, gained = 0; };
ContactChanges compare_contacts(const std::vector<std::uint64_t>& before, const std::vector<std::uint64_t>& now);

}  // namespace grains
