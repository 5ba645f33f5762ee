#pragma once
// Spreading (seed paper eq. 4): point forces F(X) at the membrane nodes become a cell-centred
// force density (force per unit volume) on the max-level cells around each node,
//   f_c = sum_X F(X) w(X, c) / dx^3,   w(X, c) = phi(sx) phi(sy) phi(sz),  s = (x_c - X)/dx,
// with the weights of stencil.hpp (normalised: sum_c w(X, c) = 1), so that
// sum_c f_c dx^3 = sum_X F(X) to round-off. Every stencil cell must be an active leaf of
// the tree's max level, else StencilError.
//
// Race-free and deterministic in parallel, with one barrier: first (parallel over nodes)
// each node's stencil cells and weights go to a workspace, and the output is zeroed; then
// each thread owns a contiguous range of the max level's cells and scans all nodes, adding
// the contributions that fall in its range. Every cell thus receives its contributions in
// node order whatever the number of threads: the result is bitwise independent of it. A
// node whose stencil misses a thread's range costs that thread two comparisons.
//
// The solver takes forces on faces (fluid/faces.hpp). Two ways there:
//  - spread_faces (the coupling's default): component d straight onto the max-level faces
//    normal to d, f_d(face) = sum_X F_d(X) w(X, face) / dx^3 with the staggered stencils of
//    stencil.hpp; then sum_faces f_d dx^3 = sum_X F_d, and it is the adjoint of
//    interpolate_faces with the same kernel (sum_X V.F = sum_faces uf f dx^3), so the
//    coupling neither creates nor destroys energy. add_face_force copies it into the
//    solver's field and restricts to coarse faces.
//  - spread to cells, then cell_to_face_force puts on each fine face the mean of the two
//    cells' values and restricts to coarse faces, which keeps sum_faces f dx^3 =
//    sum_cells f dx^3 away from walls (a wall carries the normal force itself; the solver
//    drops it there). Its adjoint reads the face average of a cell field, not the cell
//    velocity that interpolate() reads: the cell pair is adjoint only up to that average.
#include <array>
#include <vector>

#include <Eigen/Core>

#include "fluid/faces.hpp"
#include "ibm/kernels.hpp"
#include "ibm/node_boxes.hpp"
#include "ibm/stencil.hpp"
#include "ibm/wall_weights.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm {

using tree::Index;

// A vector field on cells: three arrays over all of the tree's cell slots.
using CellVector = std::array<std::vector<double>, 3>;

// assign: f is resized to the tree and overwritten (zero away from the stencils);
// add: the spread force is added to f, which must already span the tree.
enum class SpreadMode : unsigned char { assign, add };

// Reused between calls to avoid allocation.
struct SpreadWorkspace {
  std::vector<Index> cells;            // kSupport^3 per node
  std::vector<double> weights;         // 3 kSupport per node: x, y, z axis weights
  std::vector<Index> lowest, highest;  // per node: the range of its stencil's cell indices
};

// x: node positions, forces: point forces (3 x nodes each). own: on N ranks, the positions
// of the cells this rank owns: only those cells receive forces (and must exist), the others'
// owners spread the same node into theirs (stencil.hpp, OwnedPositions).
template <Kernel K>
void spread(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces, CellVector& f,
            SpreadWorkspace& ws, SpreadMode mode = SpreadMode::assign, const OwnedPositions& own = {});

inline void spread(KernelKind kind, const tree::Tree<3>& t, const Eigen::Matrix3Xd& x,
                   const Eigen::Matrix3Xd& forces, CellVector& f, SpreadWorkspace& ws,
                   SpreadMode mode = SpreadMode::assign, const OwnedPositions& own = {}) {
  with_kernel(kind, [&]<Kernel K>(K) { spread<K>(t, x, forces, f, ws, mode, own); });
}

// f: one array per component over the tree's cell slots, slot c the lower face of cell c
// normal to d (a fluid::FaceField).
// boxes: the nodes' stencil boxes found this step (NodeBoxes, with the same own), or nullptr.
// walls: the nodes' open fractions next to embedded walls (WallWeights, of this kernel), or
// nullptr (no embedded walls).
template <Kernel K>
void spread_faces(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces,
                  fluid::FaceField<3>& f, SpreadWorkspace& ws, SpreadMode mode = SpreadMode::assign,
                  const OwnedPositions& own = {}, const NodeBoxes* boxes = nullptr,
                  const WallWeights* walls = nullptr);

// divergence_free: with DivergenceFree<K> (kernels.hpp), the adjoint of the divergence-free
// interpolation.
inline void spread_faces(KernelKind kind, bool divergence_free, const tree::Tree<3>& t, const Eigen::Matrix3Xd& x,
                         const Eigen::Matrix3Xd& forces, fluid::FaceField<3>& f, SpreadWorkspace& ws,
                         SpreadMode mode = SpreadMode::assign, const OwnedPositions& own = {},
                         const NodeBoxes* boxes = nullptr, const WallWeights* walls = nullptr) {
  with_face_kernel(kind, divergence_free,
                   [&]<Kernel K>(K) { spread_faces<K>(t, x, forces, f, ws, mode, own, boxes, walls); });
}

// faces = f (or faces + f with SpreadMode::add) on every fine face; coarse faces: the mean of
// their fine faces. f: a face force from spread_faces (zero away from its stencils).
template <int D>
void add_face_force(const tree::Tree<D>& t, const fluid::FaceField<D>& f, fluid::FaceField<D>& faces,
                    SpreadMode mode = SpreadMode::assign) {
  const double keep = mode == SpreadMode::add ? 1.0 : 0.0;
  fluid::for_each_face<D>(t, [&](int d, Index, Index hi, double, const tree::Level<D>&) {
    faces[d][hi] = keep * faces[d][hi] + f[d][hi];
  });
  fluid::restrict_faces<D>(t, faces);
}

// faces[d] on every fine face: (f_d(lower cell) + f_d(upper cell)) / 2 (added to the face's
// value with SpreadMode::add); coarse faces: the mean of their fine faces. f must be defined
// (zero away from forces) on every cell slot.
template <int D>
void cell_to_face_force(const tree::Tree<D>& t, const std::array<std::vector<double>, D>& f,
                        fluid::FaceField<D>& faces, SpreadMode mode = SpreadMode::assign) {
  CAPSFLOW_ASSERT(fluid::spans_cells<D>(f, t) && fluid::spans_cells<D>(faces, t),
                  "cell_to_face_force: a field does not have the tree's num_cells slots");
  const double keep = mode == SpreadMode::add ? 1.0 : 0.0;
  fluid::for_each_face<D>(t, [&](int d, Index lo, Index hi, double, const tree::Level<D>&) {
    faces[d][hi] = keep * faces[d][hi] + 0.5 * (f[d][lo] + f[d][hi]);
  });
  fluid::restrict_faces<D>(t, faces);
}

}  // namespace capsflow::ibm
