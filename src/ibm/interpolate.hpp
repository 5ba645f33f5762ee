#pragma once
// Interpolation (seed paper eq. 6): the velocity of a membrane node is the kernel-weighted
// sum of the cell-centred velocities of the max-level cells around it,
//   v(X) = sum_c u_c w(X, c),   w(X, c) = phi(sx) phi(sy) phi(sz),  s = (x_c - X)/dx,
// with the normalised weights of stencil.hpp (the same stencil spreading uses). Every
// stencil cell must be an active leaf of the tree's max level, else StencilError: a
// coarser leaf's value would be a silently wrong weight.
//
// On faces (the default of the coupling, capsule_coupling.hpp): component d of v is the
// kernel-weighted sum of the MAC velocities uf_d on the max-level faces normal to d around
// the node (the staggered stencils of stencil.hpp),
//   v_d(X) = sum_f uf_d(f) w(X, f),   s = (x_f - X)/dx with x_f the face centre,
// as IBAMR and Bao et al. (2017) interpolate on a staggered grid. The projection makes uf,
// not the cell-centred u, discretely divergence-free (to its tolerance), and the cell
// velocity's non-solenoidal part made closed membranes gain volume steadily in shear.
// This is the adjoint of spread_faces with the same kernel: sum_X V.F = sum_f uf f dx^3.
// With a kernel K the interpolant of a discretely divergence-free uf is not divergence-free
// as a function of X (cosine: max |div V| / max |grad V| = 0.23 on a smooth curl field,
// tests/ibm/faces_test.cpp); with DivergenceFree<K> (kernels.hpp, the coupling's default)
// it is, to round-off (1e-9).
//
// Face stencils have a width per axis (ibm/stencil.hpp, BoxStencil): K's W along all three,
// or for DivergenceFree<K> W + 1 along the component's axis and W along the others.
//
// Parallel over nodes: each node gathers its own sum, so there is nothing to race on and
// the result does not depend on the number of threads.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "fluid/faces.hpp"
#include "ibm/kernels.hpp"
#include "ibm/node_boxes.hpp"
#include "ibm/stencil.hpp"
#include "ibm/wall_weights.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm {

// u: the three velocity components over the tree's cells (valid on the max-level leaves);
// x: node positions; v is resized to 3 x nodes.
template <Kernel K>
void interpolate(const tree::Tree<3>& t, const std::array<std::span<const double>, 3>& u,
                 const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& v);

inline void interpolate(KernelKind kind, const tree::Tree<3>& t, const std::array<std::span<const double>, 3>& u,
                        const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& v) {
  with_kernel(kind, [&]<Kernel K>(K) { interpolate<K>(t, u, x, v); });
}

// uf: the face velocities (fluid/faces.hpp; valid on the max-level faces of the stencils).
// boxes: the nodes' stencil boxes found this step (NodeBoxes), or nullptr. walls: the nodes'
// open fractions next to embedded walls (WallWeights, of this kernel), or nullptr.
template <Kernel K>
void interpolate_faces(const tree::Tree<3>& t, const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x,
                       Eigen::Matrix3Xd& v, const NodeBoxes* boxes = nullptr, const WallWeights* walls = nullptr);

// divergence_free: with DivergenceFree<K> (kernels.hpp): V is then exactly divergence-free
// (as a function of X) wherever uf is discretely.
inline void interpolate_faces(KernelKind kind, bool divergence_free, const tree::Tree<3>& t,
                              const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& v,
                              const NodeBoxes* boxes = nullptr, const WallWeights* walls = nullptr) {
  with_face_kernel(kind, divergence_free, [&]<Kernel K>(K) { interpolate_faces<K>(t, uf, x, v, boxes, walls); });
}

// On N ranks (stencil.hpp, OwnedPositions): what this rank knows of each node's face
// velocity from the cells it owns. Per node i and component d (entry 3 i + d): nothing (no
// stencil cell here), the whole sum (every cell here: box_sum's order, as one rank), or the
// slots and values of the cells here, which the node's owner gathers from every rank and
// sums with complete_face_velocity (the same order again: the result is one rank's to the
// last bit; an all-reduce of partial sums would depend on the rank count).
struct PartialVelocities {
  static constexpr std::uint8_t kNothing = 0, kSum = 1, kSlots = 2;
  std::vector<std::uint8_t> kind;
  std::vector<double> sum;
  std::vector<std::uint32_t> offset, count;  // into slots and values
  std::vector<std::uint16_t> slots;
  std::vector<double> values;
};

// Throws StencilError for a stencil cell this rank owns that is not an active leaf of the
// max level, or one beyond a wall. Next to embedded walls (walls) the values sent are already
// multiplied by their slots' interpolation factors, so the owner's box_sum is one rank's.
template <Kernel K>
void interpolate_faces_owned(const tree::Tree<3>& t, const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x,
                             const OwnedPositions& own, PartialVelocities& out, const NodeBoxes* boxes = nullptr,
                             const WallWeights* walls = nullptr);

inline void interpolate_faces_owned(KernelKind kind, bool divergence_free, const tree::Tree<3>& t,
                                    const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x,
                                    const OwnedPositions& own, PartialVelocities& out,
                                    const NodeBoxes* boxes = nullptr, const WallWeights* walls = nullptr) {
  with_face_kernel(kind, divergence_free,
                   [&]<Kernel K>(K) { interpolate_faces_owned<K>(t, uf, x, own, out, boxes, walls); });
}

// Component d of the velocity at x from the values of every slot of its face stencil, in
// slot order. Throws std::logic_error for a count that is not the stencil's.
template <Kernel K>
[[nodiscard]] double complete_face_velocity(const tree::TreeOptions<3>& options, double h, const double* x, int d,
                                            std::span<const double> values);

[[nodiscard]] inline double complete_face_velocity(KernelKind kind, bool divergence_free,
                                                   const tree::TreeOptions<3>& options, double h, const double* x,
                                                   int d, std::span<const double> values) {
  return with_face_kernel(kind, divergence_free,
                          [&]<Kernel K>(K) { return complete_face_velocity<K>(options, h, x, d, values); });
}

}  // namespace capsflow::ibm
