// Each rank's local forest on 1-4 ranks: a valid balanced forest (the serial invariant
// checks) holding every owned and ghost leaf as a leaf, few placeholders, and an integral over owned leaves that matches the serial one to the bit.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../tree/tree_invariants.hpp"
#include "forest_fixtures.hpp"
#include "parallel/reduce.hpp"
#include "tree/local_forest.hpp"

namespace capsflow::tree {
namespace {

template <int D>
double integrand(const Point<D>& x) {
  double s = 0.0;
  for (int d = 0; d < D; ++d) s += std::sin(1.3 * x[d] + d);
  return s;
}

template <int D>
void check_local_forest(const TreeOptions<D>& o, int width) {
  const parallel::Comm comm = parallel::Comm::world();
  const auto serial = testing::uneven_tree(o);
  const auto all = testing::curve_leaves(serial);
  std::vector<Key> positions;
  std::vector<std::int64_t> weights;
  const auto n = all.size(), p = static_cast<std::size_t>(comm.size()), r = static_cast<std::size_t>(comm.rank());
  for (std::size_t i = n * r / p; i < n * (r + 1) / p; ++i) {
    positions.push_back(all[i].position);
    weights.push_back(all[i].weight);
  }
  const Partition partition = Partition::by_weight(comm, positions, weights);
  std::vector<CurveCell> owned;
  for (const auto& l : all)
    if (partition.owner(l.position) == comm.rank()) owned.push_back({l.position, l.level});
  const GhostLayer<D> ghosts(comm, partition, o, owned, width);

  const LocalForest<D> local = build_local_forest<D>(o, owned, ghosts.ghosts());
  testing::check_invariants(local.tree);
  EXPECT_EQ(local.owned + local.ghosts + local.remote, local.tree.num_leaves());
  // Placeholders cover what is neither owned nor ghost, as coarse as the balance allows: a
  // surface around the real leaves, never more cells than those (seen here: 0-30% of them).
  EXPECT_LE(local.remote, local.owned + local.ghosts) << "rank " << comm.rank();

  // The integral of a smooth function by the midpoint rule over owned leaves, summed over the
  // ranks, is the serial one to the last bit (exact sums).
  parallel::ExactSum mine, everything;
  for (const Index c : local.tree.leaves())
    if (local.role[static_cast<std::size_t>(c)] == LeafRole::owned)
      mine.add(integrand<D>(local.tree.center(c)) * std::pow(local.tree.cell_size(local.tree.level_of(c)), D));
  for (const Index c : serial.leaves())
    everything.add(integrand<D>(serial.center(c)) * std::pow(serial.cell_size(serial.level_of(c)), D));
  EXPECT_EQ(parallel::global_sum(comm, mine), everything.value());
  EXPECT_EQ(parallel::global_sum(comm, std::int64_t{local.owned}), serial.num_leaves());
}

TEST(LocalForest, Channel2D) { check_local_forest<2>({.roots = {2, 1}, .max_level = 6}, 2); }

TEST(LocalForest, PeriodicBox3D) {
  check_local_forest<3>({.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = 4}, 2);
}

TEST(LocalForest, SeedChannel3D) {
  check_local_forest<3>({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 5}, 2);
}

}  // namespace
}  // namespace capsflow::tree
