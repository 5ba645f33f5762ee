// tree::box_owners against brute force: every cell of random boxes (across periodic sides,
// beyond walls) with its owner from the split keys, on random partitions of 2D and 3D bricks.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <vector>

#include "tree/box_owners.hpp"
#include "tree/curve_stencil.hpp"

namespace capsflow::tree {
namespace {

template <int D>
std::vector<int> brute_force(const Partition& p, const TreeOptions<D>& o, int level, const Coords<D>& lo,
                             const Coords<D>& hi) {
  std::set<int> owners;
  std::array<std::int64_t, D> n{};
  std::int64_t count = 1;
  for (int d = 0; d < D; ++d) {
    n[d] = hi[d] - lo[d] + 1;
    count *= n[d];
  }
  for (std::int64_t i = 0; i < count; ++i) {
    Coords<D> c{};
    bool inside = true;
    for (int d = 0, rest = static_cast<int>(i); d < D; ++d) {
      std::int64_t v = lo[d] + rest % n[d];
      rest /= static_cast<int>(n[d]);
      const std::int64_t extent = std::int64_t{o.roots[d]} << level;
      if (v < 0 || v >= extent) {
        if (!o.periodic[d]) inside = false;
        v = ((v % extent) + extent) % extent;
      }
      c[d] = static_cast<std::int32_t>(v);
    }
    if (inside) owners.insert(p.owner(curve_position<D>(level, morton_encode<D>(c), o.max_level)));
  }
  return {owners.begin(), owners.end()};
}

template <int D>
void check_random_boxes(const TreeOptions<D>& o, int level) {
  std::mt19937_64 rng(7 + D);
  const Key end = span_of<D>(0, o.max_level) * static_cast<Key>([&] {
                    int r = 1;
                    for (int d = 0; d < D; ++d) r *= o.roots[d];
                    return r;
                  }());
  for (int trial = 0; trial < 300; ++trial) {
    const int ranks = 1 + static_cast<int>(rng() % 9);
    std::vector<Key> split{0};
    for (int r = 1; r < ranks; ++r) split.push_back(rng() % end);
    std::sort(split.begin(), split.end());
    if (ranks > 2 && trial % 7 == 0) split[2] = split[1];  // an empty rank
    split.push_back(~Key{0});
    const Partition p = Partition::from_splits(split);
    Coords<D> lo{}, hi{};
    for (int d = 0; d < D; ++d) {
      const std::int64_t extent = std::int64_t{o.roots[d]} << level;
      lo[d] = static_cast<std::int32_t>(static_cast<std::int64_t>(rng() % (extent + 6)) - 3);
      hi[d] = lo[d] + static_cast<std::int32_t>(rng() % 9);
    }
    std::vector<int> got;
    box_owners<D>(p, o, level, lo, hi, got);
    ASSERT_EQ(got, brute_force<D>(p, o, level, lo, hi)) << "trial " << trial;
  }
}

TEST(BoxOwners, MatchBruteForce2D) {
  check_random_boxes<2>({.roots = {3, 2}, .periodic = {true, false}, .max_level = 5}, 5);
  check_random_boxes<2>({.roots = {3, 2}, .periodic = {false, true}, .max_level = 3}, 3);
}

TEST(BoxOwners, MatchBruteForce3D) {
  check_random_boxes<3>({.roots = {4, 1, 1}, .periodic = {false, true, false}, .max_level = 4}, 4);
  check_random_boxes<3>({.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = 4}, 4);
}

}  // namespace
}  // namespace capsflow::tree
