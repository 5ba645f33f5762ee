#pragma once
// The ranks that own the cells of a box on one level: where an immersed membrane's node must
// send its force (the owners of its stencil's cells, which add it into their own cells) and
// whose cells its band of refinement covers. The answer follows from the partition's split
// keys alone (partition.hpp): no rank holds a table of cells.
//
// The box is cut into the largest aligned blocks of the brick's grid that it contains (a
// block of level k is one cell of that level: a contiguous range of the curve), each block's
// range giving its owners by two binary searches over the split keys. Across a periodic side
// the box wraps; beyond a wall it is clipped.
#include <vector>

#include "tree/morton.hpp"
#include "tree/partition.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::tree {

// Appends to `ranks`, ascending and each once, the ranks that own a curve position inside
// the cells of `level` whose integer coordinates lie in [lo, hi] (inclusive; beyond the brick
// wrapped or clipped as above): at the max level, the owners of those cells. Ranks that own
// no position are never named.
template <int D>
void box_owners(const Partition& partition, const TreeOptions<D>& options, int level, const Coords<D>& lo,
                const Coords<D>& hi, std::vector<int>& ranks);

}  // namespace capsflow::tree
