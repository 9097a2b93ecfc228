// The quench's drag steps down while it holds a creep back (protocols/drag_schedule.hpp).
#include <catch2/catch.hpp>

#include <cmath>

#include "protocols/drag_schedule.hpp"

using namespace grains;

TEST_CASE("drag schedule: halves while the force ratio stalls, keeps while it falls", "[quench]") {
  // A window must take a fifth off the smallest force ratio, else the drag halves.
  SECTION("a steady force ratio (a creep the drag holds) halves the drag every other window, to the floor") {
    DragSchedule d(1.0, 0.125, 10);
    std::vector<long> changes;
    for (long check = 1; check <= 200; ++check)
      if (d.observe(20.0)) changes.push_back(check);
    // The first window records, the second compares (stalled: halve), then again after a recording window.
    CHECK(changes == std::vector<long>{20, 40, 60});
    CHECK(d.value() == 0.125);
  }
  SECTION("a force ratio falling by a third a window (modes ringing down) keeps the drag") {
    DragSchedule d(1.0, 0.125, 10);
    for (long check = 0; check < 200; ++check) CHECK_FALSE(d.observe(1000.0 * std::pow(0.67, check / 10.0)));
    CHECK(d.value() == 1.0);
  }
  SECTION("falling, but by less than a fifth a window, steps down") {
    DragSchedule d(2.0, 0.5, 10);
    long changes = 0;
    for (long check = 0; check < 30; ++check) changes += d.observe(100.0 * std::pow(0.85, check / 10.0));
    CHECK(changes == 1);
    CHECK(d.value() == 1.0);
  }
  SECTION("the smallest ratio of a window counts: one low sample of a ringing mode is progress") {
    DragSchedule d(1.0, 0.125, 10);
    for (long check = 0; check < 10; ++check) d.observe(50.0);
    for (long check = 0; check < 10; ++check) CHECK_FALSE(d.observe(check == 4 ? 35.0 : 60.0));
    CHECK(d.value() == 1.0);
  }
  SECTION("a restart (the quench switched off and on) starts new windows at the drag reached") {
    DragSchedule d(1.0, 0.125, 10);
    for (long check = 0; check < 20; ++check) d.observe(20.0);
    REQUIRE(d.value() == 0.5);
    d.restart();
    for (long check = 0; check < 19; ++check) CHECK_FALSE(d.observe(20.0));
    CHECK(d.observe(20.0));
    CHECK(d.value() == 0.25);
  }
  SECTION("patience 0: never changes; a floor above the start: never changes") {
    DragSchedule never(1.0, 0.125, 0), high_floor(0.5, 2.0, 10);
    for (long check = 0; check < 100; ++check) CHECK_FALSE((never.observe(20.0) || high_floor.observe(20.0)));
    CHECK(never.value() == 1.0);
    CHECK(high_floor.value() == 0.5);
  }
}
