// The scene text of a small self-gravitating cloud: `count` unit spheres (diameter 1, mass 1) at random
// positions, at rest, in an open box, with the linear contact law and direct-sum gravity (G = 1,
// softening 0.1: the defaults, written out because the tests' expectations use them).
#pragma once
#include <string>

#include <fmt/format.h>

struct CloudScene {
  int count;
  unsigned seed;
  double restitution, duration;
  int threads;
  double edge = 0;       // > 0: a cubic box of this edge; otherwise sized by a solid fraction of 0.05
  bool gravity = true;   // false: the same cloud without self-gravity
};

// `extra`: further TOML tables appended to the scene (e.g. [time], [analysis]).
inline std::string cloud_scene(const CloudScene& c, const std::string& extra = "") {
  return fmt::format(R"(
[particles]
layout = "random"
count = {}
diameter = 1.0
mass = 1.0
{}
seed = {}
[box]
periodic = false
{}
[contact]
restitution = {}
duration = {}
{}
[run]
threads = {}
{}
)", c.count, c.edge > 0 ? "" : "solid_fraction = 0.05", c.seed,
                     c.edge > 0 ? fmt::format("lengths = [{0}, {0}, {0}]", c.edge) : "", c.restitution, c.duration,
                     c.gravity ? "[gravity]\nenabled = true\nG = 1.0\nsoftening = 0.1" : "", c.threads, extra);
}
