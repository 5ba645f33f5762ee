// The distributed tree, multigrid and flow solver on 1-4 ranks against the serial run that
// every rank repeats on its own copy of the forest: the union of the partitions is the
// serial forest, every ghost holds its owner's value after an exchange, and the multigrid
// residual histories and the flow's values match the serial ones to 1e-12 relative.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "../tree/tree_invariants.hpp"
#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/multigrid/multigrid.hpp"
#include "fluid/navier_stokes.hpp"
#include "forest_fixtures.hpp"
#include "parallel/reduce.hpp"
#include "tree/distributed_forest.hpp"

namespace capsflow::tree {
namespace {

const double kPi = std::acos(-1.0);

template <int D>
double smooth(const Point<D>& x) {
  double s = 0.0;
  for (int d = 0; d < D; ++d) s += std::sin(2.1 * x[d] + 0.3 * d);
  return s;
}

// The serial leaf (by level and coordinates) of every owned leaf, and whether the ranks'
// owned leaves add up to the serial forest.
template <int D>
void expect_partition_of(const Tree<D>& serial, const Tree<D>& local) {
  for (const Index c : local.owned_leaves()) {
    const Index s = serial.find(local.level_of(c), local.coords(c));
    ASSERT_NE(s, kNone);
    EXPECT_TRUE(s < serial.level(local.level_of(c)).active_end() && serial.level(local.level_of(c)).is_leaf(s));
  }
  EXPECT_EQ(local.global_leaves(), serial.num_leaves());
}

template <int D>
void check_ghosts(const TreeOptions<D>& o) {
  const parallel::Comm comm = parallel::Comm::world();
  const Tree<D> serial = testing::uneven_tree(o);
  Tree<D> t = testing::uneven_tree(o);
  const auto forest = distribute(comm, t);
  testing::check_invariants(t);
  expect_partition_of(serial, t);
  // Owned active cells hold a value of their place and level, the others NaN; after one
  // exchange every cell a stencil of an owned cell reads must hold that value.
  auto value = [&](Index c) { return smooth<D>(t.center(c)) + t.level_of(c); };
  std::vector<double> v(static_cast<std::size_t>(t.num_cells()), std::numeric_limits<double>::quiet_NaN());
  for (int l = 0; l <= t.depth(); ++l)
    for (Index c = t.level(l).active_begin(); c < t.level(l).active_end(); ++c)
      if (t.owns(c)) v[static_cast<std::size_t>(c)] = value(c);
  t.update_ghosts(v);
  std::int64_t received = 0, wrong = 0, missing = 0;
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      if (!t.owns(c) && !std::isnan(v[static_cast<std::size_t>(c)])) {
        ++received;
        if (v[static_cast<std::size_t>(c)] != value(c)) ++wrong;
      }
      if (!t.owns(c)) continue;
      // Same-level neighbours (active ones) of an owned cell, and its parent's block.
      for (int s = 0; s < kStencil<D>; ++s) {
        const Index n = lv.neighbor(c, s);
        if (n < lv.active_end() && std::isnan(v[static_cast<std::size_t>(n)])) ++missing;
      }
      if (l > 0) {
        const Level<D>& up = t.level(l - 1);
        const Index parent = t.find(l - 1, [&] {
          auto x = t.coords(c);
          for (auto& xi : x) xi >>= 1;
          return x;
        }());
        for (int s = 0; s < kStencil<D>; ++s) {
          const Index n = up.neighbor(parent, s);
          if (n < up.active_end() && std::isnan(v[static_cast<std::size_t>(n)])) ++missing;
        }
      }
    }
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(missing, 0) << "rank " << comm.rank();
  EXPECT_EQ(received, forest->traffic().ghost_cells);  // each ghost once, at its level
  if (comm.size() > 1) {
    EXPECT_GT(forest->traffic().ghost_cells, 0);
  }
  // One colour's exchange (after a red-black half-sweep): every ghost of that colour gets
  // its owner's new value, the other colour's ghosts keep theirs, and the two colours'
  // exchanges together bring every ghost once.
  auto colour_of = [&](Index c) {
    const int l = t.level_of(c);
    return std::popcount(t.level(l).keys[static_cast<std::size_t>(c - t.level(l).base)] & (kChildren<D> - 1)) & 1;
  };
  for (int colour = 0; colour < 2; ++colour) {
    std::vector<double> w = v;
    for (int l = 0; l <= t.depth(); ++l)
      for (Index c = t.level(l).active_begin(); c < t.level(l).active_end(); ++c)
        if (t.owns(c) && colour_of(c) == colour) w[static_cast<std::size_t>(c)] = -value(c);
    for (int l = 0; l <= t.depth(); ++l) t.update_ghosts(l, w, colour);
    std::int64_t stale = 0, touched = 0;
    for (int l = 0; l <= t.depth(); ++l)
      for (Index c = t.level(l).active_begin(); c < t.level(l).active_end(); ++c) {
        if (t.owns(c) || std::isnan(v[static_cast<std::size_t>(c)])) continue;
        const double expected = colour_of(c) == colour ? -value(c) : value(c);
        if (w[static_cast<std::size_t>(c)] != expected) ++stale;
        if (colour_of(c) == colour) ++touched;
      }
    EXPECT_EQ(stale, 0) << "colour " << colour << ", rank " << comm.rank();
    if (comm.size() > 1 && t.depth() > 2) {
      EXPECT_GT(touched, 0);
    }
  }
  // Several fields at once, every level in one message (exchange_all) or level by level
  // (exchange_level): each field's ghosts get that field's owner values, exactly as the
  // one-field exchange above gave them, and no field's values land in another's.
  constexpr int kFields = 3;
  for (const bool by_level : {false, true}) {
    std::vector<std::vector<double>> w(kFields, std::vector<double>(v.size(), std::numeric_limits<double>::quiet_NaN()));
    for (int k = 0; k < kFields; ++k)
      for (int l = 0; l <= t.depth(); ++l)
        for (Index c = t.level(l).active_begin(); c < t.level(l).active_end(); ++c)
          if (t.owns(c)) w[k][static_cast<std::size_t>(c)] = (k + 1) * value(c) + k;
    std::vector<std::span<double>> fields(w.begin(), w.end());
    if (by_level) {
      for (int l = 0; l <= t.global_depth(); ++l) t.update_ghosts(l, fields);
    } else {
      t.update_ghosts(fields);
    }
    std::int64_t mismatched = 0;
    for (int k = 0; k < kFields; ++k)
      for (std::size_t i = 0; i < v.size(); ++i) {
        const double expected = std::isnan(v[i]) ? v[i] : (k + 1) * v[i] + k;
        if (std::isnan(expected) != std::isnan(w[k][i]) || (!std::isnan(expected) && w[k][i] != expected)) ++mismatched;
      }
    EXPECT_EQ(mismatched, 0) << (by_level ? "level by level" : "all levels") << ", rank " << comm.rank();
  }
  // Gathered on rank 0, the owned values are the serial forest's leaves again.
  const FieldId f = t.add_field({.name = "v"});
  for (const Index c : t.owned_leaves()) t.values(f)[static_cast<std::size_t>(c)] = value(c);
  const auto whole = forest->gather_on_root(t);
  if (comm.is_root()) {
    ASSERT_TRUE(whole.has_value());
    ASSERT_EQ(whole->num_leaves(), serial.num_leaves());
    for (const Index c : whole->leaves())
      EXPECT_EQ(whole->values(f)[static_cast<std::size_t>(c)], smooth<D>(whole->center(c)) + whole->level_of(c));
  }
}

TEST(DistributedForest, GhostsHoldOwnersValues2D) { check_ghosts<2>({.roots = {2, 1}, .max_level = 6}); }
TEST(DistributedForest, GhostsHoldOwnersValuesPeriodic2D) {
  check_ghosts<2>({.roots = {1, 1}, .periodic = {true, true}, .max_level = 6});
}
TEST(DistributedForest, GhostsHoldOwnersValues3D) { check_ghosts<3>({.roots = {1, 1, 2}, .max_level = 5}); }

// Refine/coarsen flags from a hash of each leaf's key, level and the round: every rank
// and the serial tree flag the same leaves.
template <int D>
std::vector<std::int8_t> random_flags(const Tree<D>& tr, int round) {
  std::vector<std::int8_t> flags(static_cast<std::size_t>(tr.num_cells()), 0);
  for (const Index c : tr.leaves()) {
    const int l = tr.level_of(c);
    const Key key = tr.level(l).keys[static_cast<std::size_t>(c - tr.level(l).base)];
    const std::uint64_t h = (key * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(l * 131 + round * 7919)) >> 40;
    flags[static_cast<std::size_t>(c)] = static_cast<std::int8_t>(h % 7 == 0 ? 1 : (h % 7 < 4 ? -1 : 0));
  }
  return flags;
}

// Random refine/coarsen sequences (flags from a hash of the cell and the round, so every
// rank and the serial tree flag the same leaves): after each, the ranks' leaves gathered are
// the serial forest's, cell for cell and value for value, and each local tree is balanced.
template <int D>
void check_random_adaptation(const TreeOptions<D>& o) {
  const parallel::Comm comm = parallel::Comm::world();
  Tree<D> serial = testing::uneven_tree(o);
  Tree<D> t = testing::uneven_tree(o);
  const FieldId fs = serial.add_field({.name = "v"});
  const FieldId f = t.add_field({.name = "v"});
  for (const Index c : serial.leaves()) serial.values(fs)[static_cast<std::size_t>(c)] = smooth<D>(serial.center(c));
  for (const Index c : t.leaves()) t.values(f)[static_cast<std::size_t>(c)] = smooth<D>(t.center(c));
  const auto forest = distribute(comm, t);
  for (int round = 0; round < 6; ++round) {
    (void)serial.apply_flags(random_flags(serial, round));
    (void)t.apply_flags(random_flags(t, round));
    testing::check_invariants(t);
    EXPECT_EQ(t.global_leaves(), serial.num_leaves()) << "round " << round;
    const auto whole = forest->gather_on_root(t);
    if (!comm.is_root()) continue;
    ASSERT_EQ(whole->num_leaves(), serial.num_leaves()) << "round " << round;
    std::int64_t differ = 0;
    for (const Index c : serial.leaves()) {
      const Index w = whole->find(serial.level_of(c), serial.coords(c));
      if (w == kNone || !whole->level(serial.level_of(c)).is_leaf(w) ||
          whole->values(f)[static_cast<std::size_t>(w)] != serial.values(fs)[static_cast<std::size_t>(c)])
        ++differ;
    }
    EXPECT_EQ(differ, 0) << "round " << round;
  }
}

TEST(DistributedForest, RandomAdaptationsMatchSerial2D) { check_random_adaptation<2>({.roots = {2, 1}, .max_level = 7}); }
TEST(DistributedForest, RandomAdaptationsMatchSerialPeriodic2D) {
  check_random_adaptation<2>({.roots = {1, 1}, .periodic = {true, false}, .max_level = 7});
}
TEST(DistributedForest, RandomAdaptationsMatchSerial3D) { check_random_adaptation<3>({.roots = {1, 2, 1}, .max_level = 5}); }

// Weighted partitions: a leaf's weight is 10 where a hash of its key and of the round
// picks it (a membrane band's cells, say) and 1 elsewhere. After the first partition, each
// random adaptation and each rebalance under new weights, every rank's owned weight is
// within the heaviest leaf of W / P (partition.hpp), the gathered forest is the serial one
// value for value, and every local tree is balanced.
template <int D>
void check_weighted_partition(const TreeOptions<D>& o) {
  const parallel::Comm comm = parallel::Comm::world();
  Tree<D> serial = testing::uneven_tree(o);
  Tree<D> t = testing::uneven_tree(o);
  const FieldId fs = serial.add_field({.name = "v"});
  const FieldId f = t.add_field({.name = "v"});
  for (const Index c : serial.leaves()) serial.values(fs)[static_cast<std::size_t>(c)] = smooth<D>(serial.center(c));
  for (const Index c : t.leaves()) t.values(f)[static_cast<std::size_t>(c)] = smooth<D>(t.center(c));
  constexpr std::int64_t kHeavy = 10;
  auto weight_for = [](int round) {
    return [round](int level, Key key) -> std::int64_t {
      const std::uint64_t h = (key * 0xD6E8FEB86659FD93ull + static_cast<std::uint64_t>(level * 977 + round * 31)) >> 41;
      return h % 4 == 0 ? kHeavy : 1;
    };
  };
  auto expect_balanced_and_serial = [&](const DistributedForest<D>& forest, const char* when, int round) {
    testing::check_invariants(t);
    const std::int64_t mine = forest.owned_weight();
    const std::int64_t total = parallel::global_sum(comm, mine);
    const double share = static_cast<double>(total) / comm.size();
    EXPECT_LE(std::abs(static_cast<double>(mine) - share), static_cast<double>(kHeavy)) << when << " round " << round;
    const auto whole = forest.gather_on_root(t);
    if (!comm.is_root()) return;
    ASSERT_EQ(whole->num_leaves(), serial.num_leaves()) << when << " round " << round;
    std::int64_t differ = 0;
    for (const Index c : serial.leaves()) {
      const Index w = whole->find(serial.level_of(c), serial.coords(c));
      if (w == kNone || whole->values(f)[static_cast<std::size_t>(w)] != serial.values(fs)[static_cast<std::size_t>(c)]) ++differ;
    }
    EXPECT_EQ(differ, 0) << when << " round " << round;
  };
  const auto forest = distribute(comm, t, weight_for(0));
  expect_balanced_and_serial(*forest, "distribute", 0);
  // Heavy leaves are a quarter of all: an even weight split is not an even count split.
  if (comm.size() > 1) {
    const std::int64_t leaves = static_cast<std::int64_t>(t.owned_leaves().size());
    const std::int64_t fewest = -parallel::global_max(comm, -leaves), most = parallel::global_max(comm, leaves);
    EXPECT_GT(most, fewest + 1) << "weights did not change the split";
  }
  for (int round = 1; round <= 4; ++round) {
    (void)serial.apply_flags(random_flags(serial, round));
    (void)t.apply_flags(random_flags(t, round));
    expect_balanced_and_serial(*forest, "adapt", round);
    forest->set_leaf_weight(weight_for(round));
    forest->rebalance(t);
    expect_balanced_and_serial(*forest, "rebalance", round);
  }
}

TEST(DistributedForest, WeightedPartitionAndRebalance2D) {
  check_weighted_partition<2>({.roots = {2, 1}, .max_level = 7});
}
TEST(DistributedForest, WeightedPartitionAndRebalance3D) {
  check_weighted_partition<3>({.roots = {1, 2, 1}, .max_level = 5});
}

// --- multigrid

template <int D>
struct Problem {
  BoundaryConditions<D> bc;
  std::function<double(const Point<D>&)> rhs;
};

template <int D>
fluid::MultigridStats solve_on(Tree<D>& t, const Problem<D>& p, std::vector<double>& a, bool krylov) {
  a.assign(static_cast<std::size_t>(t.num_cells()), 0.0);
  std::vector<double> b(static_cast<std::size_t>(t.num_cells()), 0.0);
  for (const Index c : t.leaves()) b[static_cast<std::size_t>(c)] = p.rhs(t.center(c));
  fluid::EllipticOperator<D> op(t, fluid::ConstantFaces{1.0}, fluid::ZeroCells{}, p.bc);
  fluid::MultigridWorkspace ws;
  return fluid::solve(op, a, b, ws, {.tolerance = 1e-10, .max_cycles = 40, .krylov = krylov});
}

template <int D>
void check_multigrid(const TreeOptions<D>& o, const Problem<D>& p, bool krylov) {
  const parallel::Comm comm = parallel::Comm::world();
  Tree<D> serial = testing::uneven_tree(o);
  std::vector<double> a_serial, a;
  const auto s = solve_on(serial, p, a_serial, krylov);
  Tree<D> t = testing::uneven_tree(o);
  const auto forest = distribute(comm, t);
  const auto d = solve_on(t, p, a, krylov);
  ASSERT_EQ(d.residuals.size(), s.residuals.size()) << "cycles";
  for (std::size_t i = 0; i < s.residuals.size(); ++i)
    EXPECT_NEAR(d.residuals[i], s.residuals[i], 1e-12 * s.residuals[i]) << "cycle " << i;
  EXPECT_TRUE(d.converged);
  double scale = 0.0, worst = 0.0;
  for (const Index c : serial.leaves()) scale = std::max(scale, std::abs(a_serial[static_cast<std::size_t>(c)]));
  for (const Index c : t.owned_leaves()) {
    const Index sc = serial.find(t.level_of(c), t.coords(c));
    worst = std::max(worst, std::abs(a[static_cast<std::size_t>(c)] - a_serial[static_cast<std::size_t>(sc)]));
  }
  EXPECT_LE(parallel::global_max(comm, worst), 1e-12 * scale);
}

template <int D>
Problem<D> dirichlet() {
  Problem<D> p;
  p.bc = BoundaryConditions<D>::all(BcKind::dirichlet);
  for (auto& side : p.bc.side) side.function = [](const Point<D>& x) { return x[0] - 0.5 * x[D - 1]; };
  p.rhs = [](const Point<D>& x) { return -std::sin(kPi * x[0]) * std::cos(2 * kPi * x[1]) * (1 + x[D - 1]); };
  return p;
}

template <int D>
Problem<D> neumann() {  // singular: the mean is removed
  Problem<D> p;
  p.bc = BoundaryConditions<D>::all(BcKind::neumann);
  p.rhs = [](const Point<D>& x) { return std::cos(kPi * x[0]) * std::cos(kPi * x[1]); };
  return p;
}

// Second order on N ranks: a manufactured solution on nested uniform trees (levels 5-7),
// the error against the exact solution at the owned leaves, the maximum over ranks.
TEST(DistributedMultigrid, ManufacturedSolutionSecondOrder2D) {
  const parallel::Comm comm = parallel::Comm::world();
  auto exact = [](const Point<2>& x) { return std::sin(kPi * x[0]) * std::sin(2 * kPi * x[1]) + x[0] - 2 * x[1]; };
  Problem<2> p;
  p.bc = BoundaryConditions<2>::all(BcKind::dirichlet);
  for (auto& side : p.bc.side) side.function = exact;
  p.rhs = [](const Point<2>& x) { return -5 * kPi * kPi * std::sin(kPi * x[0]) * std::sin(2 * kPi * x[1]); };
  std::vector<double> errors;
  for (int level = 5; level <= 7; ++level) {
    Tree<2> t({.roots = {1, 1}, .max_level = level});
    t.refine_to([level](const Box<2>&) { return level; });
    const auto forest = distribute(comm, t);
    std::vector<double> a;
    EXPECT_TRUE(solve_on(t, p, a, false).converged);
    double worst = 0.0;
    for (const Index c : t.owned_leaves()) worst = std::max(worst, std::abs(a[static_cast<std::size_t>(c)] - exact(t.center(c))));
    errors.push_back(parallel::global_max(comm, worst));
  }
  for (std::size_t i = 1; i < errors.size(); ++i) EXPECT_GE(std::log2(errors[i - 1] / errors[i]), 1.8) << errors[i];
}

TEST(DistributedMultigrid, DirichletMatchesSerial2D) {
  check_multigrid<2>({.roots = {2, 1}, .max_level = 7}, dirichlet<2>(), false);
}
TEST(DistributedMultigrid, NeumannMatchesSerial2D) {
  check_multigrid<2>({.roots = {1, 1}, .max_level = 7}, neumann<2>(), false);
}
TEST(DistributedMultigrid, KrylovMatchesSerial2D) {
  check_multigrid<2>({.roots = {1, 1}, .max_level = 7}, dirichlet<2>(), true);
}
TEST(DistributedMultigrid, DirichletMatchesSerial3D) {
  check_multigrid<3>({.roots = {1, 1, 1}, .max_level = 5}, dirichlet<3>(), false);
}
TEST(DistributedMultigrid, NeumannMatchesSerial3D) {
  check_multigrid<3>({.roots = {1, 1, 2}, .max_level = 5}, neumann<3>(), false);
}


// --- flow

namespace flow {

using fluid::FlowOptions;
using fluid::NavierStokes;
using fluid::SideKind;

// A row of what a run reports per step.
struct Row {
  double t, dt, max_u, divergence;
  int cycles;
};

template <int D>
void expect_same_rows(const std::vector<Row>& serial, const std::vector<Row>& distributed) {
  ASSERT_EQ(serial.size(), distributed.size());
  for (std::size_t i = 0; i < serial.size(); ++i) {
    EXPECT_EQ(distributed[i].cycles, serial[i].cycles) << "step " << i;
    EXPECT_NEAR(distributed[i].t, serial[i].t, 1e-12 * serial[i].t) << "step " << i;
    EXPECT_NEAR(distributed[i].dt, serial[i].dt, 1e-12 * serial[i].dt) << "step " << i;
    EXPECT_NEAR(distributed[i].max_u, serial[i].max_u, 1e-12 * serial[i].max_u) << "step " << i;
    EXPECT_NEAR(distributed[i].divergence, serial[i].divergence, 1e-12 * serial[i].max_u / 1e-3 + 1e-300)
        << "step " << i;
  }
}

// Runs `steps` steps on t (distributed or not) and returns the rows; `adapt_every` > 0 adapts
// (velocity wavelets) before every such step.
template <int D>
std::vector<Row> run(Tree<D>& t, const FlowOptions<D>& o, int steps, std::vector<std::vector<double>>* final_u = nullptr,
                     int adapt_every = 0, int min_level = 0, const geometry::SolidPtr& solid = nullptr,
                     const typename NavierStokes<D>::Properties& properties = {}) {
  NavierStokes<D> ns(t, o);
  if (solid) ns.set_solid(solid);
  if (properties) ns.set_properties(properties);
  std::vector<Row> rows;
  for (int s = 0; s < steps; ++s) {
    if (adapt_every > 0 && s % adapt_every == 0) {
      (void)ns.adapt(0.01, {.min_level = min_level});
      rows.push_back({double(t.global_leaves()), 0.0, ns.max_velocity_component(), 0.0, -1});
    }
    const fluid::StepStats st = ns.step();
    rows.push_back({st.t, st.dt, ns.max_velocity_component(), ns.max_divergence(), st.cycles()});
  }
  if (final_u)
    for (int d = 0; d < D; ++d) final_u->emplace_back(ns.u(d).begin(), ns.u(d).end());
  return rows;
}

template <int D>
void check_flow(const TreeOptions<D>& to, const std::function<int(const Box<D>&)>& levels, const FlowOptions<D>& o,
                int steps, int adapt_every = 0, int min_level = 0, const geometry::SolidPtr& solid = nullptr,
                const typename NavierStokes<D>::Properties& properties = {}) {
  const parallel::Comm comm = parallel::Comm::world();
  Tree<D> serial(to);
  serial.refine_to(levels);
  std::vector<std::vector<double>> u_serial, u;
  const auto rows_serial = run(serial, o, steps, &u_serial, adapt_every, min_level, solid, properties);
  Tree<D> fresh(to);
  fresh.refine_to(levels);
  const auto forest = distribute(comm, fresh);
  const auto rows = run(fresh, o, steps, &u, adapt_every, min_level, solid, properties);
  expect_same_rows<D>(rows_serial, rows);
  double worst = 0.0, scale = 0.0;
  for (const Index c : fresh.owned_leaves()) {
    const Index sc = serial.find(fresh.level_of(c), fresh.coords(c));
    for (int d = 0; d < D; ++d) {
      worst = std::max(worst, std::abs(u[d][static_cast<std::size_t>(c)] - u_serial[d][static_cast<std::size_t>(sc)]));
      scale = std::max(scale, std::abs(u_serial[d][static_cast<std::size_t>(sc)]));
    }
  }
  EXPECT_LE(parallel::global_max(comm, worst), 1e-12 * parallel::global_max(comm, scale));
  if (comm.is_root())
    std::printf("%d ranks: %zu steps, max|u| %.6g, %.0f values sent, %.3f s waiting\n", comm.size(), rows.size(),
                rows.back().max_u, double(forest->values_sent()), forest->seconds_waiting());
}

template <int D>
std::array<fluid::SideFlow<D>, 2 * D> lid() {
  std::array<fluid::SideFlow<D>, 2 * D> s{};
  s[2 * (D - 1) + 1] = {.kind = SideKind::moving_wall, .velocity = {1.0}};
  return s;
}

TEST(DistributedFlow, CavityNavierStokesMatchesSerial2D) {
  check_flow<2>({.roots = {1, 1}, .max_level = 5}, [](const Box<2>&) { return 5; },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<2>()}, 20);
}

TEST(DistributedFlow, CavityGradedNavierStokesMatchesSerial2D) {
  // Finer towards the lid: resolution jumps cross the partition boundaries.
  check_flow<2>({.roots = {1, 1}, .max_level = 6}, [](const Box<2>& b) { return b.hi[1] > 0.8 ? 6 : (b.hi[1] > 0.5 ? 5 : 4); },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<2>()}, 15);
}

// Density and viscosity varying across the cavity, the lightest fluid in the lid's corner
// (a density ratio of 100) and the most viscous at the bottom: each rank's part has its own
// least density, and the viscous solves' tolerance,
// scaled by it, must be the same on every rank (else they stop at different cycles).
TEST(DistributedFlow, CavityWithVaryingPropertiesMatchesSerial2D) {
  const NavierStokes<2>::Properties layers = [](const Tree<2>& t, std::span<double> rho, std::span<double> mu) {
    for (Index c = 0; c < t.num_cells(); ++c) {
      const double x = t.center(c)[0], y = t.center(c)[1];
      rho[static_cast<std::size_t>(c)] = 1.0 + 99.0 * std::min(1.0, 4.0 * ((1.0 - x) * (1.0 - x) + (1.0 - y) * (1.0 - y)));
      mu[static_cast<std::size_t>(c)] = 1.0 + 4.0 * (1.0 - y);
    }
  };
  check_flow<2>({.roots = {1, 1}, .max_level = 5}, [](const Box<2>&) { return 5; },
                {.Re = 10, .stokes = true, .dt = 0.01, .boundaries = lid<2>(), .viscous = {.tolerance = 1e-7}}, 8, 0, 0, nullptr, layers);
}

TEST(DistributedFlow, CavityStokesMatchesSerial3D) {
  check_flow<3>({.roots = {1, 1, 1}, .max_level = 4}, [](const Box<3>&) { return 4; },
                {.Re = 10, .stokes = true, .dt = 0.01, .boundaries = lid<3>()}, 5);
}

// Embedded walls: a cylinder (the section of a ball) in the lid-driven cavity, on a graded
// tree, adapted every 4 steps (the geometry and its operators rebuilt on every rank).
TEST(DistributedFlow, CavityAroundACylinderStokesMatchesSerial2D) {
  check_flow<2>({.roots = {1, 1}, .max_level = 7}, [](const Box<2>& b) { return b.hi[1] > 0.8 ? 6 : 5; },
                {.Re = 10, .stokes = true, .dt = 0.01, .boundaries = lid<2>()}, 12, 4, 4,
                geometry::sphere({0.47, 0.52, 0.0}, 0.21));
}

// The same cylinder turning (a moving embedded wall: its velocity is the no-slip value of
// the wall flux at every cut cell, on whichever rank holds it).
TEST(DistributedFlow, CavityAroundATurningCylinderStokesMatchesSerial2D) {
  const Eigen::Vector3d centre(0.47, 0.52, 0.0);
  check_flow<2>({.roots = {1, 1}, .max_level = 7}, [](const Box<2>& b) { return b.hi[1] > 0.8 ? 6 : 5; },
                {.Re = 10, .stokes = true, .dt = 0.01, .boundaries = lid<2>()}, 12, 4, 4,
                geometry::moving_wall(geometry::sphere(centre, 0.21), {.angular_velocity = {0.0, 0.0, -3.0}, .centre = centre}));
}

// Navier-Stokes past the cylinder (advection of the open parts' fluxes), adapted every 4 steps.
TEST(DistributedFlow, CavityAroundACylinderNavierStokesMatchesSerial2D) {
  check_flow<2>({.roots = {1, 1}, .max_level = 7}, [](const Box<2>& b) { return b.hi[1] > 0.8 ? 6 : 5; },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<2>()}, 12, 4, 4,
                geometry::sphere({0.47, 0.52, 0.0}, 0.21));
}

// The cavity's varying density and viscosity (above) around the cylinder, Navier-Stokes,
// adapted every 4 steps: the projection's faces 1/rho times the fractions and the viscous
// cell term rho / dt per cell (parents: their children's mean) on every rank.
TEST(DistributedFlow, CavityAroundACylinderWithVaryingPropertiesMatchesSerial2D) {
  const NavierStokes<2>::Properties layers = [](const Tree<2>& t, std::span<double> rho, std::span<double> mu) {
    for (Index c = 0; c < t.num_cells(); ++c) {
      const double x = t.center(c)[0], y = t.center(c)[1];
      rho[static_cast<std::size_t>(c)] = 1.0 + 9.0 * std::min(1.0, 4.0 * ((1.0 - x) * (1.0 - x) + (1.0 - y) * (1.0 - y)));
      mu[static_cast<std::size_t>(c)] = 0.01 * (1.0 + 4.0 * (1.0 - y));
    }
  };
  check_flow<2>({.roots = {1, 1}, .max_level = 7}, [](const Box<2>& b) { return b.hi[1] > 0.8 ? 6 : 5; },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<2>()}, 12, 4, 4,
                geometry::sphere({0.47, 0.52, 0.0}, 0.21), layers);
}

TEST(DistributedFlow, CavityAroundABallStokesMatchesSerial3D) {
  check_flow<3>({.roots = {1, 1, 1}, .max_level = 4}, [](const Box<3>&) { return 4; },
                {.Re = 10, .stokes = true, .dt = 0.01, .boundaries = lid<3>()}, 5, 0, 0, geometry::sphere({0.48, 0.51, 0.46}, 0.23));
}

TEST(DistributedFlow, CavityNavierStokesMatchesSerial3D) {
  check_flow<3>({.roots = {1, 1, 1}, .max_level = 4}, [](const Box<3>& b) { return b.hi[2] > 0.7 ? 4 : 3; },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<3>()}, 5);
}

TEST(DistributedFlow, AdaptiveCavityMatchesSerial2D) {
  // Adapted (velocity wavelets, refinement and coarsening, repartition) every 4 steps.
  check_flow<2>({.roots = {1, 1}, .max_level = 7}, [](const Box<2>& b) { return b.hi[1] > 0.9 ? 6 : 4; },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<2>()}, 16, 4, 3);
}

TEST(DistributedFlow, AdaptiveCavityMatchesSerial3D) {
  check_flow<3>({.roots = {1, 1, 1}, .max_level = 5}, [](const Box<3>& b) { return b.hi[2] > 0.8 ? 4 : 3; },
                {.Re = 100, .dt = 0.02, .cfl = 0.8, .boundaries = lid<3>()}, 6, 3, 2);
}

TEST(DistributedFlow, SquareDuctMatchesSerial3D) {
  std::array<fluid::SideFlow<3>, 6> sides{};
  sides[0] = {.kind = SideKind::inflow, .profile = fluid::InflowProfile::square_duct, .mean_velocity = 1.0};
  sides[1] = {.kind = SideKind::outflow};
  check_flow<3>({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4.0, -1.0, -1.0}, .max_level = 3},
                [](const Box<3>& b) { return std::abs(b.lo[1]) > 0.7 || std::abs(b.hi[2]) > 0.7 ? 3 : 2; },
                {.Re = 10, .dt = 0.05, .cfl = 0.5, .boundaries = sides}, 5);
}

}  // namespace flow

}  // namespace
}  // namespace capsflow::tree
