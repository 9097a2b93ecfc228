// Initial particles and box from a scene: layout, sizes, masses, velocities.
#pragma once
#include "core/box.hpp"
#include "core/particles.hpp"
#include "io/scene.hpp"

namespace grains {

template <int D>
struct InitialState {
  Particles<D> particles;
  Box<D> box;
};

template <int D>
InitialState<D> make_initial_state(const Scene& scene);

}  // namespace grains
