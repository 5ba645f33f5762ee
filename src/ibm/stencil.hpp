#pragma once
// The stencil of a membrane node: the W x W x W cells of one tree level (the max level: the
// finest uniform patch around the node) whose centres lie within W/2 cells of the node, and
// the kernel's 1D weights along each axis.
//
// Along an axis with origin o and cell size h, let u = (X - o)/h - 1/2 (the node in units
// of cells, measured from the centre of cell 0), i0 = floor(u), r = u - i0 in [0, 1). The
// stencil is the cells i0 - W/2 + 1 ... i0 + W/2, at offsets s_k = (k - W/2 + 1) - r from the
// node (in cells, k = 0..W-1): every cell with phi(s) != 0 is in it. The weights are
// divided by their sum, so that sum_k w_k = 1 to the last bit the division allows whatever
// the kernel's analytic normalisation: spreading then conserves the total force exactly.
//
// Face (staggered) stencils: the MAC velocity and face force of component d live on the
// lower faces of the cells along d (fluid/faces.hpp: slot c is the lower face of cell c), at
// o + i h along d and at cell centres along the other axes. The stencil of component d is
// then the same construction with u = (X - o)/h along axis d (the faces at integer i), so
// that its slots are again cell indices: at most one cell beyond the centred stencil on the
// upper side, within the band's margin.
//
// Locating the cells: find_patch does one tree search per anchor cell of level L - k
// (k >= 2 and 2^k >= W - 1, so a stencil spans at most 2 anchors per axis: at most 8
// searches), descends from the anchors to the stencil's parents on level L - 1 (at most
// (W/2 + 1)^3), and takes each parent's 8 contiguous children: no search per cell. Every
// cell must be an active leaf of the level (never a halo cell, never a coarser leaf, never
// outside a wall): otherwise the caller throws StencilError, since any fallback weight
// would be wrong.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "common/assert.hpp"
#include "ibm/kernels.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm {

using tree::Index;

template <int W>
struct AxisStencil {
  std::int32_t first = 0;     // integer coordinate (on the level's grid) of cell k = 0
  std::array<double, W> w{};  // normalised weights
};

// The first cell of a W-wide axis stencil whose node lies in cell floor(u) (u measured from
// sample 0, in cells); and of the W + 1 faces of a divergence-free face axis whose nearest
// face is i0 = floor(u + 1/2). One definition for the stencils and NodeBoxes' boxes.
[[nodiscard]] inline std::int32_t axis_first(double floor_u, int W) {
  return static_cast<std::int32_t>(floor_u) - (W / 2 - 1);
}
[[nodiscard]] inline std::int32_t smoothed_face_first(double i0, int W) { return static_cast<std::int32_t>(i0) - W / 2; }

// offset: where sample 0 lies in cell 0, in cells (1/2: cell centres, 0: lower faces).
template <Kernel K>
[[nodiscard]] inline AxisStencil<K::kSupport> axis_stencil(double x, double origin, double h, double offset = 0.5) {
  constexpr int W = K::kSupport;
  const double u = (x - origin) / h - offset;
  // A NaN or huge coordinate would make the cast below undefined (UBSan does not check
  // float casts): the coupling stops a run before a node moves to such a place.
  CAPSFLOW_ASSERT(std::abs(u) < 1e9, "ibm: a membrane node's coordinate is not finite or far outside the tree");
  const double i0 = std::floor(u);
  const double r = u - i0;
  AxisStencil<W> a;
  a.first = axis_first(i0, W);
  if constexpr (requires(double* w) { K::stencil_weights(r, w); }) {
    K::stencil_weights(r, a.w.data());
  } else {
    for (int k = 0; k < W; ++k) a.w[k] = K::weight((k - W / 2 + 1) - r);
  }
  double sum = 0.0;
  for (int k = 0; k < W; ++k) sum += a.w[k];
  CAPSFLOW_ASSERT(sum > 0.0 && std::isfinite(sum), "ibm: the kernel's weights around a node do not sum to a positive value");
  const double inv = 1.0 / sum;
  for (int k = 0; k < W; ++k) a.w[k] *= inv;
  return a;
}

// The three axis stencils of point x on level `level` of the tree: on cell centres, or, for
// face_axis = d in {0, 1, 2}, on the lower faces along d (the stencil of component d).
template <Kernel K>
[[nodiscard]] inline std::array<AxisStencil<K::kSupport>, 3> node_stencil(const tree::TreeOptions<3>& o, double h,
                                                                         const double* x, int face_axis = -1) {
  auto offset = [face_axis](int d) { return d == face_axis ? 0.0 : 0.5; };
  return {axis_stencil<K>(x[0], o.origin[0], h, offset(0)), axis_stencil<K>(x[1], o.origin[1], h, offset(1)),
          axis_stencil<K>(x[2], o.origin[2], h, offset(2))};
}

// A stencil with a width per axis (at most kMaxBoxWidth): the face stencils. Slot
// i + n0 j + n0 n1 k holds cell first + (i, j, k) with weight w[0][i] w[1][j] w[2][k].
inline constexpr int kMaxBoxWidth = 8;
struct BoxStencil {
  std::array<int, 3> n{};
  tree::Coords<3> first{};
  std::array<std::array<double, kMaxBoxWidth>, 3> w{};
  [[nodiscard]] int size() const { return n[0] * n[1] * n[2]; }
};

template <int W>
void set_axis(BoxStencil& b, int d, const AxisStencil<W>& a) {
  b.n[d] = W;
  b.first[d] = a.first;
  std::copy(a.w.begin(), a.w.end(), b.w[d].begin());
}

// The stencil of component face_axis on the faces normal to it: K's node_stencil, or, for
// DivergenceFree<K> (kernels.hpp), K on the cell centres along the other two axes and the
// smoothed kernel psi on the faces along face_axis, over the K::kSupport + 1 faces nearest
// the node (psi's support is that wide: i0 = the nearest face, faces i0 - W/2 ... i0 + W/2).
// These cells lie within the cube of width K::kSupport + 2 that the band provides.
template <Kernel K>
[[nodiscard]] inline BoxStencil face_stencil(const tree::TreeOptions<3>& o, double h, const double* x, int face_axis) {
  CAPSFLOW_ASSERT(face_axis >= 0 && face_axis < 3, "ibm: a face stencil needs the component's axis");
  BoxStencil b;
  if constexpr (kIsDivergenceFree<K>) {
    using Base = typename K::Base;
    constexpr int W = Base::kSupport;
    for (int d = 0; d < 3; ++d)
      if (d != face_axis) set_axis(b, d, axis_stencil<Base>(x[d], o.origin[d], h, 0.5));
    const double u = (x[face_axis] - o.origin[face_axis]) / h;
    CAPSFLOW_ASSERT(std::abs(u) < 1e9, "ibm: a membrane node's coordinate is not finite or far outside the tree");
    const double i0 = std::floor(u + 0.5);
    b.n[face_axis] = W + 1;
    b.first[face_axis] = smoothed_face_first(i0, W);
    double* w = b.w[face_axis].data();
    if constexpr (requires(double* v) { Base::smoothed_stencil_weights(0.0, v); }) {
      Base::smoothed_stencil_weights(u + 0.5 - i0, w);
    } else {
      for (int k = 0; k <= W; ++k) w[k] = K::weight((i0 - W / 2 + k) - u);
    }
    double sum = 0.0;
    for (int k = 0; k <= W; ++k) sum += w[k];
    CAPSFLOW_ASSERT(sum > 0.0 && std::isfinite(sum), "ibm: the kernel's weights around a node do not sum to a positive value");
    for (int k = 0; k <= W; ++k) w[k] /= sum;
  } else {
    const auto st = node_stencil<K>(o, h, x, face_axis);
    for (int d = 0; d < 3; ++d) set_axis(b, d, st[d]);
  }
  return b;
}

// The cells of face_stencil<K>(o, h, x, face_axis) without its weights: first and n.
template <Kernel K>
[[nodiscard]] inline BoxStencil face_stencil_bounds(const tree::TreeOptions<3>& o, double h, const double* x,
                                                    int face_axis) {
  BoxStencil b;
  constexpr bool kSmoothed = kIsDivergenceFree<K>;
  constexpr int W = [] {
    if constexpr (kSmoothed) return K::Base::kSupport;
    else return K::kSupport;
  }();
  for (int d = 0; d < 3; ++d) {
    const double u = (x[d] - o.origin[d]) / h - (d == face_axis ? 0.0 : 0.5);
    CAPSFLOW_ASSERT(std::abs(u) < 1e9, "ibm: a membrane node's coordinate is not finite or far outside the tree");
    if (kSmoothed && d == face_axis) {
      b.n[d] = W + 1;
      b.first[d] = smoothed_face_first(std::floor(u + 0.5), W);
    } else {
      b.n[d] = W;
      b.first[d] = axis_first(std::floor(u), W);
    }
  }
  return b;
}

// Fills cells[slot] for each slot of a box of n[0] x n[1] x n[2] cells of `level` from
// `first` (widths at most kMaxBoxWidth); returns -1 if all are active leaves, else the
// first missing slot.
int find_box(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
             Index* cells);

// Fills cells[i + W j + W^2 k] with the active leaf of `level` at first + (i, j, k)
// (coordinates wrap across periodic sides). Returns -1 if all exist, else the first slot
// whose cell is missing (then cells is partly filled). Checked builds assert that a
// complete patch is the stencil (patch_is_the_stencil).
template <int W>
int find_patch(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, Index* cells) {
  return find_box(t, level, first, {W, W, W}, cells);
}

// The curve positions (tree/partition.hpp) of the cells this rank owns, [begin, end): on N
// ranks spreading adds into, and interpolation reads, only the stencil cells whose position
// lies here (the other cells' owners get the node too). One rank: every position.
struct OwnedPositions {
  tree::Key begin = 0, end = ~tree::Key{0};
  [[nodiscard]] bool all() const { return begin == 0 && end == ~tree::Key{0}; }
  [[nodiscard]] bool contains(tree::Key p) const { return p >= begin && p < end; }
};

// As find_box for the cells of the box this rank owns: cells[slot] is the active leaf of
// `level` there, or kNone where another rank owns the cell. Returns -1, or the first slot
// whose cell this rank owns but is not an active leaf of the level, or that lies beyond a
// wall. With own.all() the same as find_box.
int find_owned_box(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
                   const OwnedPositions& own, Index* cells);

// sum over the slots of w[0][i] w[1][j] w[2][k] values[slot], in the one order every
// interpolation uses (rows along x first): a node's velocity comes out the same to the last
// bit whether one rank reads every value or the values were gathered from their owners.
[[nodiscard]] inline double box_sum(const BoxStencil& st, const double* values) {
  double sum = 0.0;
  for (int kz = 0, s = 0; kz < st.n[2]; ++kz)
    for (int jy = 0; jy < st.n[1]; ++jy) {
      const double wyz = st.w[2][kz] * st.w[1][jy];
      double row = 0.0;
      for (int ix = 0; ix < st.n[0]; ++ix, ++s) row += values[s] * st.w[0][ix];
      sum += wyz * row;
    }
  return sum;
}

// Whether cells[] holds, for each stencil slot, an active leaf of `level` whose key
// decodes to first + (i, j, k) (wrapped): the anchors and descents of find_patch are
// shortcuts, the keys are the truth they must agree with.
bool box_is_the_stencil(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
                        const Index* cells);
template <int W>
bool patch_is_the_stencil(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const Index* cells) {
  return box_is_the_stencil(t, level, first, {W, W, W}, cells);
}

// Thrown when a stencil cell is missing; names the node, its position, the cell and why.
// The fields let a caller say it in its own words (the coupled step names the likely cause).
class StencilError : public std::runtime_error {
 public:
  enum class Missing : unsigned char {
    outside_domain,  // the cell lies across a non-periodic side: the node is within the kernel's reach of it
    not_refined,     // the tree is coarser there than the stencil's level
  };
  struct Where {
    std::int64_t node = 0;
    std::array<double, 3> x{};  // the node's position
    int level = 0;              // the stencil's level (the max level)
    int found_level = -1;       // not_refined: the level of the leaf there (-1: unknown)
    int side = -1;              // outside_domain: the side crossed (2d or 2d + 1)
  };
  StencilError(const std::string& message, Missing missing, Where where)
      : std::runtime_error(message), missing_(missing), where_(where) {}
  [[nodiscard]] std::int64_t node() const noexcept { return where_.node; }
  [[nodiscard]] Missing missing() const noexcept { return missing_; }
  [[nodiscard]] const Where& where() const noexcept { return where_; }

 private:
  Missing missing_;
  Where where_;
};

// Builds the StencilError for node `node` at x whose cell `ijk` of `level` is missing:
// outside a wall (the membrane is within the kernel's reach of the wall), or not refined
// to the level (the membrane-driven refinement did not run or its band is too narrow).
[[noreturn]] void throw_missing_cell(const tree::Tree<3>& t, int level, const tree::Coords<3>& ijk,
                                     std::int64_t node, const double* x, std::string_view operation,
                                     std::string_view kernel);

// Finds the box of node `node` and throws StencilError naming its first missing cell (of the
// cells this rank owns).
void require_box(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
                 Index* cells, std::int64_t node, const double* x, std::string_view operation,
                 std::string_view kernel, const OwnedPositions& own = {});
template <int W>
void require_patch(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, Index* cells,
                   std::int64_t node, const double* x, std::string_view operation, std::string_view kernel) {
  require_box(t, level, first, {W, W, W}, cells, node, x, operation, kernel);
}

}  // namespace capsflow::ibm
