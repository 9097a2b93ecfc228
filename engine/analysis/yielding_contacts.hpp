// Contacts ready to yield: the consolidation paper (section II D 3) observes that in its equilibrated states
// |F_T| < mu F_N^e and |Gamma_R| < mu_R F_N^e hold as strict inequalities in every contact, so that the response
// to a small load increment is elastic. These fractions say how far a state is from that: the share of
// contacts whose tangential force, or rolling moment, sits at its bound.
#pragma once
#include <limits>
#include <vector>

#include "analysis/elastic_spring.hpp"

namespace grains {

struct YieldingContacts {
  // Fractions of the contacts with that spring at its bound (NaN where no contact has that spring).
  double sliding = std::numeric_limits<double>::quiet_NaN();
  double rolling = std::numeric_limits<double>::quiet_NaN();
};

// A spring is at its bound when its force reaches (1 - tolerance) of it: a contact that slid and stopped keeps
// the bound to rounding, so any small tolerance tells it from a contact inside the cone.
template <int D>
YieldingContacts yielding_contacts(const std::vector<ElasticSpring<D>>& springs, double tolerance = 1e-6) {
  long frictional = 0, sliding = 0, rolling_springs = 0, rolling = 0;
  for (const auto& s : springs) {
    if (s.tangential > 0) {
      ++frictional;
      if (s.tangential_force >= (1 - tolerance) * s.tangential_bound) ++sliding;
    }
    if (s.rolling > 0) {
      ++rolling_springs;
      if (s.rolling_moment >= (1 - tolerance) * s.rolling_bound) ++rolling;
    }
  }
  YieldingContacts y;
  if (frictional > 0) y.sliding = double(sliding) / double(frictional);
  if (rolling_springs > 0) y.rolling = double(rolling) / double(rolling_springs);
  return y;
}

}  // namespace grains
