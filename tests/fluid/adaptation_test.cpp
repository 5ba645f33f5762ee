// The adapt stage (fluid/adaptation.hpp) and the one definition of walls (fluid/walls.hpp):
// walls are the no-slip sides; forced levels follow them, not the inflow or the outflow;
// adaptations follow the run's step number, so a restarted run adapts when the
// uninterrupted one does.
#include <gtest/gtest.h>

#include <cmath>
#include <span>
#include <vector>

#include "fluid/adaptation.hpp"
#include "fluid/walls.hpp"

namespace capsflow::fluid {
namespace {

TEST(Walls, OnlyNoSlipSidesAreWalls) {
  EXPECT_TRUE(is_wall(SideKind::wall));
  EXPECT_TRUE(is_wall(SideKind::moving_wall));
  EXPECT_FALSE(is_wall(SideKind::inflow));
  EXPECT_FALSE(is_wall(SideKind::outflow));
  EXPECT_FALSE(is_wall(SideKind::periodic));
  EXPECT_FALSE(is_wall(SideKind::prescribed));
}

// A 2D channel [0, 2] x [0, 1]: inflow at x_lo, outflow at x_hi, walls at y_lo and y_hi.
struct Channel {
  static FlowOptions<2> flow() {
    FlowOptions<2> o{.Re = 1.0, .stokes = true, .dt = 0.01};
    for (auto& s : o.boundaries) s.kind = SideKind::wall;
    o.boundaries[0].kind = SideKind::inflow;
    o.boundaries[1].kind = SideKind::outflow;
    return o;
  }
  tree::Tree<2> tree{tree::TreeOptions<2>{.roots = {2, 1}, .root_size = 1.0, .max_level = 6}};
  NavierStokes<2> ns{tree, flow()};
};

// Embedded walls are walls: the leaves they cut reach wall_level, those far from them not.
TEST(Adaptation, InitialRefinementForcesEmbeddedWalls) {
  Channel c;
  c.ns.set_solid(geometry::sphere({0.93, 0.47, 0.0}, 0.2));
  Adaptation<2> a(c.ns, {.min_level = 2, .wall_level = 6});
  (void)a.refine_initial();
  int cut = 0;
  for (const tree::Index i : c.tree.leaves()) {
    const tree::Point<2> x = c.tree.center(i);
    const double r = std::hypot(x[0] - 0.93, x[1] - 0.47);
    const int l = c.tree.level_of(i);
    if (c.ns.embedded()->wall_area(i) > 0.0) {
      EXPECT_EQ(l, 6) << "a leaf on the embedded wall";
      ++cut;
    }
    if (std::abs(r - 0.2) > 0.25 && x[1] > 0.2 && x[1] < 0.8) {
      EXPECT_LE(l, 3) << "far from every wall";
    }
  }
  EXPECT_GT(cut, 0);
}

// The brick's walls buried in a solid are no walls of the flow: a narrower channel made of
// an embedded box (the fluid 0.25 < y < 0.75) refines along its own walls only, not in the
// solid along the brick's sides (which refined 1.8x the cells of the seed channel).
TEST(Adaptation, BrickWallsBuriedInASolidAreNotRefined) {
  Channel c;
  c.ns.set_solid(geometry::complement(geometry::box({-1.0, 0.25, -1.0}, {3.0, 0.75, 1.0})));
  Adaptation<2> a(c.ns, {.min_level = 2, .wall_level = 6});
  (void)a.refine_initial();
  int on_embedded = 0, on_buried = 0;
  for (const tree::Index i : c.tree.leaves()) {
    const tree::Box<2> b = c.tree.box(i);
    const int l = c.tree.level_of(i);
    if (c.ns.embedded()->wall_area(i) > 0.0) {
      EXPECT_EQ(l, 6) << "a leaf on the embedded wall";
      ++on_embedded;
    }
    if (b.lo[1] <= 1e-12 || b.hi[1] >= 1.0 - 1e-12) {
      EXPECT_LE(l, 3) << "a leaf on the brick's wall, deep in the solid";
      ++on_buried;
    }
  }
  EXPECT_GT(on_embedded, 0);
  EXPECT_GT(on_buried, 0);
}

// The solid side of an embedded wall is not refined to the wall level: its cells there would
// hold no fluid (every corner solid), so it stays one level coarser, as the 2:1 balance next
// to the wall's fluid cells allows (the seed channel as an embedded box: a third of the
// wall level's cells were such solid cells).
TEST(Adaptation, TheSolidSideOfAnEmbeddedWallStaysCoarser) {
  Channel c;
  c.ns.set_solid(geometry::complement(geometry::box({-1.0, 0.25, -1.0}, {3.0, 0.75, 1.0})));
  Adaptation<2> a(c.ns, {.min_level = 2, .wall_level = 6});
  (void)a.refine_initial();
  const std::span<const double> volume = c.ns.embedded()->volume();
  int fluid_at_wall = 0, solid_at_wall = 0;
  for (const tree::Index i : c.tree.leaves()) {
    const tree::Box<2> b = c.tree.box(i);
    const bool touches = std::abs(b.lo[1] - 0.75) < 1e-12 || std::abs(b.hi[1] - 0.25) < 1e-12 ||
                         std::abs(b.hi[1] - 0.75) < 1e-12 || std::abs(b.lo[1] - 0.25) < 1e-12;
    if (!touches || b.lo[0] < 0.1 || b.hi[0] > 1.9) continue;
    const int l = c.tree.level_of(i);
    if (volume[static_cast<std::size_t>(i)] > 0.0) {
      EXPECT_EQ(l, 6) << "a fluid leaf on the wall";
      ++fluid_at_wall;
    } else {
      EXPECT_EQ(l, 5) << "a solid leaf on the wall: as coarse as the balance allows";
      ++solid_at_wall;
    }
  }
  EXPECT_GT(fluid_at_wall, 0);
  EXPECT_GT(solid_at_wall, 0);
  // The rule's own boxes: a solid box of level 5 on the wall needs no more; a fluid one
  // the wall level; a coarse box is never judged by a lattice of its own.
  EXPECT_EQ(a.required_level({{1.0, 0.75}, {1.0 + 1.0 / 32, 0.75 + 1.0 / 32}}), 0);
  EXPECT_EQ(a.required_level({{1.0, 0.75 - 1.0 / 32}, {1.0 + 1.0 / 32, 0.75}}), 6);
  EXPECT_EQ(a.required_level({{1.0, 0.75}, {1.0 + 1.0 / 8, 0.75 + 1.0 / 8}}), 6);
}

TEST(Adaptation, InitialRefinementForcesWallsNotInflowOrOutflow) {
  Channel c;
  Adaptation<2> a(c.ns, {.min_level = 2, .wall_level = 5});
  (void)a.refine_initial();
  const double eps = 1e-12;
  int on_walls = 0, on_ends = 0;
  for (const tree::Index i : c.tree.leaves()) {
    const tree::Box<2> b = c.tree.box(i);
    const int l = c.tree.level_of(i);
    EXPECT_GE(l, 2);
    if (b.lo[1] <= eps || b.hi[1] >= 1.0 - eps) {
      EXPECT_GE(l, 5) << "a leaf on a wall";
      ++on_walls;
    } else if ((b.lo[0] <= eps || b.hi[0] >= 2.0 - eps) && b.lo[1] >= 0.25 && b.hi[1] <= 0.75) {
      EXPECT_LE(l, 3) << "a leaf on the inflow or the outflow, away from the walls";
      ++on_ends;
    }
  }
  EXPECT_GT(on_walls, 0);
  EXPECT_GT(on_ends, 0);
  EXPECT_EQ(a.required_level({{0.0, 0.5}, {1.0 / 64, 0.5 + 1.0 / 64}}), 0);  // inflow
  EXPECT_EQ(a.required_level({{1.0, 0.0}, {1.0 + 1.0 / 64, 1.0 / 64}}), 5);  // wall y_lo
}

// Interval 3: the stage adapts after steps 3, 6, 9, ... of the run, whichever step it
// was built at (a restart from step 4 builds it there).
TEST(Adaptation, AdaptsAfterEveryIntervalOfTheRunsSteps) {
  Channel c;
  Adaptation<2> a(c.ns, {.interval = 3, .min_level = 2});
  (void)a.refine_initial();
  std::vector<int> adapted;
  for (int step = 1; step <= 9; ++step)
    if (a.after_step(step)) adapted.push_back(step);
  EXPECT_EQ(adapted, (std::vector<int>{3, 6, 9}));
  Adaptation<2> restarted(c.ns, {.interval = 3, .min_level = 2});
  adapted.clear();
  for (int step = 5; step <= 9; ++step)
    if (restarted.after_step(step)) adapted.push_back(step);
  EXPECT_EQ(adapted, (std::vector<int>{6, 9}));
}

// An interval in time: the stage adapts after the steps that cross a multiple of it, so
// dt = 0.01 and dt = 0.005 adapt at the same instants (0.03, 0.06, 0.09), and a step that
// crosses one without landing on it adapts too (dt = 0.02: after 0.04, 0.06 and 0.10).
TEST(Adaptation, AnIntervalInTimeAdaptsAtTheSameInstantsForEveryDt) {
  for (const double dt : {0.01, 0.005, 0.02}) {
    tree::Tree<2> tree{tree::TreeOptions<2>{.roots = {2, 1}, .root_size = 1.0, .max_level = 6}};
    FlowOptions<2> o = Channel::flow();
    o.dt = dt;
    NavierStokes<2> ns(tree, o);
    Adaptation<2> a(ns, {.interval_time = 0.03, .min_level = 2});
    (void)a.refine_initial();
    EXPECT_FALSE(a.after_step(0)) << "no step yet";
    std::vector<double> adapted;
    for (int step = 1; ns.time() < 0.1 - 1e-9; ++step) {
      (void)ns.step();
      if (a.after_step(step)) adapted.push_back(ns.time());
    }
    const std::vector<double> expected =
        dt == 0.02 ? std::vector<double>{0.04, 0.06, 0.10} : std::vector<double>{0.03, 0.06, 0.09};
    ASSERT_EQ(adapted.size(), expected.size()) << dt;
    for (std::size_t i = 0; i < adapted.size(); ++i) EXPECT_NEAR(adapted[i], expected[i], 1e-12) << dt;
  }
}

TEST(Adaptation, OffMeansUniformAtTheMaxLevel) {
  Channel c;
  Adaptation<2> a(c.ns, {.enabled = false, .min_level = 2, .wall_level = 5});
  (void)a.refine_initial();
  EXPECT_EQ(c.tree.num_leaves(), 2 * 64 * 64);
  EXPECT_FALSE(a.after_step(1));
}

TEST(Adaptation, BadOptionsAreRefused) {
  Channel c;
  EXPECT_THROW(Adaptation<2>(c.ns, {.interval = 0}), std::invalid_argument);
  EXPECT_THROW(Adaptation<2>(c.ns, {.wall_level = 7}), std::invalid_argument);
  EXPECT_THROW(Adaptation<2>(c.ns, {.min_level = -1}), std::invalid_argument);
  EXPECT_THROW(Adaptation<2>(c.ns, {.interval = 2, .interval_time = 0.1}), std::invalid_argument);
  EXPECT_THROW(Adaptation<2>(c.ns, {.interval_time = 0.1, .max_interval_time = 0.05}), std::invalid_argument);
  EXPECT_THROW(Adaptation<2>(c.ns, {.interval_time = -0.1}), std::invalid_argument);
  EXPECT_THROW(Adaptation<2>(c.ns, {.max_interval_time = 0.1}), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::fluid
