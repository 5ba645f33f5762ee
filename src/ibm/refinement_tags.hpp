#pragma once
// Membrane-driven refinement: which cells must be at the max level so that every node's
// spreading and interpolation stencil exists there (stencil.hpp), with cells to spare for
// the motion of the membrane until the next adaptation.
//
// Tagged cells: on the finest level L, every cell within `band` cells (per axis, in cell
// indices) of the cell containing a node. A stencil of support W around a node in cell i
// is the cells i - W/2 ... i + W/2 at most, so band = W/2 + m covers it with m cells of
// margin: a node may move m cells before its stencil leaves the tagged set (the motion per
// step is |v| dt, well below one cell at the stable dt). Coarser levels tag the ancestors
// of tagged cells, so a leaf of any level asks for level L exactly when its box contains a
// tagged cell.
//
// Built once per adaptation in O(nodes + V), V the number of level-L cells in the nodes'
// bounding box widened by the band (one byte each; ~0.3 MB for the seed capsule at
// dx = 1/32): node cells are marked, dilated by the band with three separable 1D passes,
// then OR-reduced level by level. A query (the tree's required_level, once per leaf) is an
// O(1) lookup. Periodic directions: node coordinates may be unwrapped; queries test the
// periodic images.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "ibm/kernels.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm {

// Half the widest kernel support plus the margin, in cells of the max level
// (divergence_free: of the kernels' DivergenceFree forms, one cell wider on each side).
[[nodiscard]] inline int band_cells(KernelKind spread, KernelKind interpolate, int margin,
                                    bool divergence_free = false) {
  const int w = std::max(support_of(spread, divergence_free), support_of(interpolate, divergence_free));
  return w / 2 + margin;
}

class MembraneTags {
 public:
  MembraneTags() = default;
  // Tags the cells of `level` around the nodes x (3 x nodes). Throws std::invalid_argument
  // for a negative band or a level outside [0, domain.max_level].
  void build(const tree::TreeOptions<3>& domain, int level, int band, const Eigen::Matrix3Xd& x);

  // The tag level for a leaf whose box is b: level() if b contains a tagged cell, else 0.
  // Usable as AdaptOptions<3>::required_level (through required_level() or std::cref).
  [[nodiscard]] int operator()(const tree::Box<3>& b) const;
  // Whether the cell of level l at integer coordinates ijk is tagged or an ancestor of one.
  [[nodiscard]] bool tagged(int l, const tree::Coords<3>& ijk) const;
  // A callable referring to this object (which must outlive it).
  [[nodiscard]] std::function<int(const tree::Box<3>&)> required_level() const {
    return [this](const tree::Box<3>& b) { return (*this)(b); };
  }

  [[nodiscard]] int level() const { return level_; }
  [[nodiscard]] int band() const { return band_; }
  [[nodiscard]] std::int64_t tagged_cells() const;  // on the finest level

 private:
  // A dense byte grid over a box of one level's integer coordinates.
  struct Grid {
    tree::Coords<3> lo{};
    std::array<std::int64_t, 3> n{};
    std::vector<std::uint8_t> on;
    [[nodiscard]] bool get(const tree::Coords<3>& ijk) const;
  };
  tree::TreeOptions<3> domain_{};
  int level_ = 0, band_ = 0;
  std::vector<Grid> grids_;  // one per level 0..level_, empty without nodes
};

}  // namespace capsflow::ibm
