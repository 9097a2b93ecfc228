// The H5MD frame that views a simulation's particle and box snapshot (runner output and the FMU's
// snapshot plugin write the same frames). Header-only, so it needs no HDF5.
#pragma once
#include "core/simulation.hpp"
#include "io/h5md_writer.hpp"

namespace grains {

// `p` and `b` must outlive the frame: it points into them.
inline H5mdFrame frame_view(long step, double time, const ParticleView& p, const BoxView& b) {
  H5mdFrame f{};
  f.step = step;
  f.time = time;
  f.dimension = p.dimension;
  f.count = p.count;
  f.position = p.position.data();
  f.velocity = p.velocity.data();
  f.radius = p.radius.data();
  f.mass = p.mass.data();
  f.angular_velocity = p.angular_velocity.data();
  f.angular_components = p.dimension == 3 ? 3 : 1;
  f.orientation = p.orientation.empty() ? nullptr : p.orientation.data();   // empty: not tracked
  f.orientation_components = p.dimension == 3 ? 4 : 1;
  f.image = p.image.empty() ? nullptr : p.image.data();   // empty: no periodic axis
  f.box_lower = b.lower.data();
  f.box_length = b.length.data();
  return f;
}

}  // namespace grains
