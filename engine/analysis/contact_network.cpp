#include "analysis/contact_network.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace grains {

ContactNetwork analyse_contact_network(std::size_t particle_count, const std::vector<NetworkInteraction>& interactions,
                                       const ContactNetworkOptions& options) {
  ContactNetwork net;
  const int bins = std::max(1, options.histogram_bins);
  net.histogram.assign(bins + 1, 0.0);
  if (particle_count == 0) return net;
  std::vector<char> held(particle_count, 0);   // by a force, or with adhesion by any interaction: no rattler
  long plus = 0, minus = 0, zero = 0;
  for (const auto& c : interactions) {
    (c.gap < 0 ? net.contacts : net.distant_bonds) += 1;
    const double f = c.normal_force;
    if (std::abs(f) <= options.zero_force) {
      ++zero;
      if (options.bonds_hold) held[c.i] = held[c.j] = 1;
    } else {
      (f > 0 ? plus : minus) += 1;
      held[c.i] = held[c.j] = 1;
    }
    const double bin = std::floor((f / options.force_scale - options.histogram_lower) / options.histogram_width);
    net.histogram[std::size_t(std::clamp(bin, 0.0, double(bins)))] += 1;
  }
  const double N = double(particle_count);
  net.z = 2.0 * double(interactions.size()) / N;
  net.z_plus = 2.0 * double(plus) / N, net.z_minus = 2.0 * double(minus) / N, net.z_zero = 2.0 * double(zero) / N;
  const long rattlers = long(std::count(held.begin(), held.end(), 0));
  net.rattler_fraction = double(rattlers) / N;
  // Every grain a rattler: no backbone, whose coordination is then undefined (not 0: z may be above 0).
  net.z_star = rattlers < long(particle_count) ? net.z / (1 - net.rattler_fraction)
                                               : std::numeric_limits<double>::quiet_NaN();
  if (!interactions.empty())
    for (auto& h : net.histogram) h /= double(interactions.size());
  return net;
}

std::vector<std::uint64_t> contact_keys(const std::vector<NetworkInteraction>& interactions) {
  std::vector<std::uint64_t> keys;
  for (const auto& c : interactions)
    if (c.gap < 0) keys.push_back((std::uint64_t(std::min(c.i, c.j)) << 32) | std::max(c.i, c.j));
  std::sort(keys.begin(), keys.end());
  return keys;
}

ContactChanges compare_contacts(const std::vector<std::uint64_t>& before, const std::vector<std::uint64_t>& now) {
  ContactChanges ch;
  std::size_t a = 0, b = 0;
  while (a < before.size() || b < now.size()) {   // merge of two sorted lists
    if (b == now.size() || (a < before.size() && before[a] < now[b])) ++ch.lost, ++a;
    else if (a == before.size() || now[b] < before[a]) ++ch.gained, ++b;
    else ++ch.kept, ++a, ++b;
  }
  return ch;
}

}  // namespace grains
