#pragma once
// Coefficients of the elliptic operator div(alpha grad a) + lambda a, as small types the
// operator is templated on, so the common constant case reads no coefficient array.
//
// alpha lives on faces: for an active cell c, face k = 2d + side (side 0: low, 1: high).
// A leaf's face value is the coefficient at the centre of that face; a parent's is the
// average of its children's values on the same side (so coarse levels see the mean
// conductance of the fine faces they cover).
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "tree/tree.hpp"

namespace capsflow::fluid {

using tree::Index;

struct ConstantFaces {
  static constexpr bool kConstant = true;
  double value = 1.0;
  double at(Index /*cell*/, int /*face*/) const { return value; }
};

template <int D>
struct FaceArray {
  static constexpr bool kConstant = false;
  const double* data = nullptr;  // 2D values per cell slot
  double at(Index c, int face) const { return data[static_cast<std::size_t>(c) * (2 * D) + face]; }
};

struct ZeroCells {
  static constexpr bool kConstant = true;
  double uniform_value() const { return 0.0; }
  double at(Index /*cell*/) const { return 0.0; }
};

struct ConstantCells {
  static constexpr bool kConstant = true;
  double value = 0.0;
  double uniform_value() const { return value; }
  double at(Index /*cell*/) const { return value; }
};

// What a cell's stencil is, per cell slot (EmbeddedGeometry::uniform and the flags made
// from it): the arrays' (near a wall or a property jump), the constant one, none (a cell
// without fluid: every face closed, no wall, only its own cell term), or the constant one
// with face k closed (kStencilClosedFace + k: a full cell whose wall lies on that face, the
// layer along a wall on grid faces; its cell term is the constant one too).
inline constexpr std::uint8_t kStencilArrays = 0;
inline constexpr std::uint8_t kStencilUniform = 1;
inline constexpr std::uint8_t kStencilEmpty = 2;
inline constexpr std::uint8_t kStencilClosedFace = 8;
constexpr bool closed_face_stencil(std::uint8_t flag) { return flag >= kStencilClosedFace; }
// The flags whose stencil takes the constant coefficients (uniform or closed-face).
constexpr bool constant_stencil(std::uint8_t flag) { return flag == kStencilUniform || closed_face_stencil(flag); }

// Embedded walls (multigrid/embedded_coefficients.hpp): the fluid's own coefficient `value`
// on the uniform cells (every face open, no wall: EmbeddedGeometry::uniform), the array
// elsewhere. The operator takes the uniform cells' stencil as constant (no array read), so
// the cells away from the walls cost what the brick's cells cost, and a cell with one closed
// face the same without that face (its wall's flux apart); a cell without fluid costs its
// cell term only. The arrays hold every cell's values, whatever its flag.
template <int D>
struct EmbeddedFaces {
  static constexpr bool kConstant = false;
  double value = 1.0;
  const double* data = nullptr;        // 2D values per cell slot
  const std::uint8_t* full = nullptr;  // per cell slot: kStencil*
  // The halo groups of cells without fluid that no prolongation reads (their faces are
  // closed: every stencil weighs them by 0), filled by injection in the solves; or nullptr.
  const tree::InjectedHalos* injected = nullptr;
  bool uniform(Index c) const { return full[c] == kStencilUniform; }
  bool empty(Index c) const { return full[c] == kStencilEmpty; }
  // The closed face of a kStencilClosedFace cell, else a negative number.
  int closed_face(Index c) const { return int{full[c]} - kStencilClosedFace; }
  double at(Index c, int face) const {
    return full[c] == kStencilUniform ? value : data[static_cast<std::size_t>(c) * (2 * D) + face];
  }
};

// lambda with EmbeddedFaces' flags: `value` on the uniform cells and the closed-face ones
// (whose data must equal it: full cells of the fluid's own density), the array elsewhere.
struct EmbeddedCells {
  static constexpr bool kConstant = false;
  double value = 0.0;
  const double* data = nullptr;
  const std::uint8_t* full = nullptr;
  double uniform_value() const { return value; }
  double at(Index c) const { return full[c] == kStencilUniform ? value : data[c]; }
};

// lambda = 0 on the cells with fluid and a pin on those without (embedded walls, see
// multigrid/embedded_coefficients.hpp): the operator is as singular as with ZeroCells on the
// fluid, which the pins do not reach.
struct PinnedCells {
  static constexpr bool kConstant = false;
  const double* data = nullptr;
  double uniform_value() const { return 0.0; }
  double at(Index c) const { return data[c]; }
};

struct CellArray {
  static constexpr bool kConstant = false;
  const double* data = nullptr;
  double at(Index c) const { return data[c]; }
};

// Fills `out` (2D values per cell slot) from alpha(face centre, direction) on the leaves
// and by averaging onto parents.
template <int D>
void face_coefficients(const tree::Tree<D>& t,
                       const std::function<double(const tree::Point<D>&, int)>& alpha,
                       std::vector<double>& out);

// How a face coefficient comes from the values of the two cells it separates.
enum class FaceMean {
  harmonic,            // 2ab / (a + b): a conductance in series (viscosity across a jump)
  inverse_arithmetic,  // 2 / (a + b): 1/rho on a face from cell densities
};

double face_mean(FaceMean mean, double a, double b);

// The same from cell values (read on the leaves only): a leaf's face takes the mean of the
// leaf and its same-level neighbour, where a halo neighbour (the coarse side of a jump)
// stands for its coarse leaf and a boundary cell (the domain boundary) for the leaf itself (zero
// normal gradient of the property); then parents and the leaf-facing-parent fix-up as
// above.
template <int D>
void face_coefficients(const tree::Tree<D>& t, std::span<const double> cells, FaceMean mean,
                       std::vector<double>& out);

}  // namespace capsflow::fluid
