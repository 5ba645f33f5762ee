#pragma once
// Immersed-boundary kernels next to embedded walls (issue "Walls of any shape"). A node whose
// face stencils reach an embedded wall (fluid/embedded_geometry.hpp) keeps its kernel weights
// w_s but counts only the fluid: with a_s the open fraction of stencil face s (the solver's own
// face fraction, from the same corner values) and S = sum_s w_s a_s,
//   spreading:      f_s = F w_s / (S dx^3) on every open face (a_s > 0), nothing on closed ones;
//   interpolation:  V = sum_s (w_s a_s / S) uf_s.
// The flow weighs face s by its fluid volume a_s dx^3 (the projection is orthogonal in that
// inner product; fluid/energy.hpp's face power counts it), so
//   - the total is kept: sum_s a_s dx^3 f_s = F, and no closed face (no solid) receives any;
//   - the pair stays adjoint: sum_s a_s dx^3 f_s uf_s = F . V, and the coupling still neither
//     creates nor destroys energy;
//   - interpolation reads the fluid only and still reproduces a constant velocity.
// Away from the walls (every face of the stencil open) nothing changes, to the last bit.
// The divergence-free kernels lose their exact property where they are renormalised.
//
// The fractions are computed per node from the solid (not read from the tree), so that every
// rank a node is routed to gets the same numbers from the node's position alone.
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "fluid/embedded_geometry.hpp"
#include "ibm/kernels.hpp"
#include "ibm/stencil.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm {

class WallWeights {
 public:
  // For each node of x whose distance to the walls is at most `reach` (farther, every face of
  // its stencils is open), the open fractions of the faces of its three face stencils of
  // kernel `kind` on t's max level.
  void find(KernelKind kind, bool divergence_free, const fluid::EmbeddedGeometry<3>& walls, const tree::Tree<3>& t,
            Eigen::Ref<const Eigen::Matrix3Xd> x, double reach);
  void clear();

  // Component d of node i: nullptr when every face of its stencil is open (the plain kernel),
  // else the open fraction of each slot of its face stencil (BoxStencil's slot order).
  [[nodiscard]] const double* open(Eigen::Index i, int d) const {
    if (entry_.empty()) return nullptr;
    const std::int32_t e = entry_[static_cast<std::size_t>(i)];
    if (e < 0 || !renormalised_[static_cast<std::size_t>(3 * e + d)]) return nullptr;
    return open_.data() + static_cast<std::size_t>(3 * e + d) * stride_;
  }
  // 1 / S for component d of node i (open(i, d) not null).
  [[nodiscard]] double inverse_sum(Eigen::Index i, int d) const {
    return inverse_sum_[static_cast<std::size_t>(3 * entry_[static_cast<std::size_t>(i)] + d)];
  }
  // The nodes within reach of a wall (their stencils may still be wholly open).
  [[nodiscard]] std::int64_t near_nodes() const { return near_; }
  // The nodes found (0 when none was near a wall).
  [[nodiscard]] Eigen::Index nodes() const { return static_cast<Eigen::Index>(entry_.size()); }
  // The first node whose stencil of some component has no open face (the node is inside the
  // solid), or -1.
  [[nodiscard]] Eigen::Index buried() const { return buried_; }

 private:
  template <Kernel K>
  void find_with(const fluid::EmbeddedGeometry<3>& walls, const tree::Tree<3>& t, Eigen::Ref<const Eigen::Matrix3Xd> x,
                 double reach);

  int stride_ = 0;                          // slots per component (the widest stencil's)
  std::vector<std::int32_t> entry_;         // per node: -1 (clear of the walls) or its entry
  std::vector<double> open_;                // 3 stride_ per entry
  std::vector<double> inverse_sum_;         // 3 per entry
  std::vector<std::uint8_t> renormalised_;  // 3 per entry: some face of the stencil is not open
  std::int64_t near_ = 0;
  Eigen::Index buried_ = -1;
};

// The spreading factor of slot s: 1 / S on an open face, 0 on a closed one.
[[nodiscard]] inline double spread_factor(double open, double inverse_sum) { return open > 0.0 ? inverse_sum : 0.0; }
// The interpolation factor of slot s: a_s / S.
[[nodiscard]] inline double interpolation_factor(double open, double inverse_sum) { return open * inverse_sum; }

}  // namespace capsflow::ibm
