#pragma once
// The membrane model: elastic energy E = integral of W dS0 over the reference surface and
// nodal forces F = -dE/dX (the point forces the immersed boundary method spreads, the seed
// paper's "integrated load"; element kernels and their equations in force_kernel.hpp).
//
// Quadrature: one point for P1 (exact, the strain is constant on a flat element); for P2 the
// seed's Hammer 3-point rule by default, or a collapsed Gauss rule of a requested degree.
// Everything that depends only on the reference configuration (shape function derivatives
// at the quadrature points, inverse reference metric, weight times reference area element,
// node-to-element map) is computed once here, so an evaluation is one pass over the elements
// with no allocation.
// Parallel assembly by gather, race-free without atomics: OpenMP over elements, each element
// writing its nodal forces to its own slots of a buffer; then OpenMP over nodes, each node
// summing its slots in element order. Two barriers per evaluation (element colouring needs
// one per colour, about ten, and each costs a scheduler time slice when cores are shared),
// and the result is bitwise independent of the thread count.
#include "membrane/force_kernel.hpp"
#include "membrane/laws.hpp"
#include "membrane/mesh.hpp"
#include "membrane/quadrature.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstdint>
#include <variant>
#include <vector>

namespace capsflow::membrane {

// Which tangent stiffness MembraneModel::stiffness assembles (stiffness_kernel.hpp): the
// exact Hessian, or its positive semi-definite variant (each quadrature point's Hessian in
// the tangents projected on its non-negative eigenvalues).
enum class StiffnessPart : unsigned char { exact, positive };

struct ModelOptions {
  // 0: element default (P1: 1 point; P2: Hammer 3 points). Otherwise the smallest collapsed
  // Gauss rule exact for this polynomial degree.
  int quadrature_degree = 0;
};

class MembraneModel {
 public:
  // Validates the reference mesh (validate_mesh) and the law parameters; throws
  // std::invalid_argument / ElementError naming the offending value.
  MembraneModel(Mesh reference, const LawParameters& law, const ModelOptions& options = {});

  [[nodiscard]] const Mesh& mesh() const noexcept { return mesh_; }
  [[nodiscard]] const AnyLaw& law() const noexcept { return law_; }
  [[nodiscard]] const QuadratureRule& quadrature() const noexcept { return rule_; }

  // E(x). Throws ElementError if an element of x is collapsed or (P2) folded.
  [[nodiscard]] double energy(const Eigen::Matrix3Xd& x) const;

  // forces = -dE/dx (resized to 3 x nodes if needed); returns E(x). Throws like energy().
  // Non-const: it uses the model's element force buffer (one evaluation at a time per model).
  double compute_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& forces);

  // The tangent stiffness K = d2E/dx2 = -dF/dx at x (stiffness_kernel.hpp), or its positive
  // variant: 3n x 3n, row and column 3 node + component (the order of x.data()), symmetric,
  // with the mesh's pattern (nodes that share an element; built at the first call). The
  // reference stays valid until the next call. Throws like energy(). Non-const: the model
  // holds the matrix and its element buffer. Assembled like the forces, by gather: the same
  // bits on any thread count.
  const Eigen::SparseMatrix<double>& stiffness(const Eigen::Matrix3Xd& x, StiffnessPart part = StiffnessPart::exact);

  // Principal stretches and Cauchy tensions at each element's centroid (xi = eta = 1/3),
  // in element order, for output.
  [[nodiscard]] std::vector<PrincipalTensions> element_tensions(const Eigen::Matrix3Xd& x) const;

 private:
  template <int Nn>
  void precompute();
  // E(x); with forces != nullptr also F, through buffer (element_forces_, see compute_forces).
  template <int Nn, class Law>
  double assemble(const Law& law, const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd* forces,
                  Eigen::Vector3d* buffer) const;
  template <int Nn>
  void build_stiffness_pattern();
  template <int Nn, class Law>
  void assemble_stiffness(const Law& law, const Eigen::Matrix3Xd& x, bool positive);
  template <int Nn>
  [[noreturn]] void throw_bad_element(const Eigen::Matrix3Xd& x, std::int64_t slot) const;
  void check_configuration(const Eigen::Matrix3Xd& x) const;

  Mesh mesh_;
  AnyLaw law_;
  QuadratureRule rule_;
  // Shape derivatives per quadrature point (the alternative matches the element order).
  std::variant<std::vector<ShapeDerivatives<3>>, std::vector<ShapeDerivatives<6>>> shape_derivatives_;
  std::vector<ReferencePoint> reference_points_;  // [element][q]
  // Assembly by gather: element force buffer [element][local node], and for each node its
  // buffer entries (CSR, in element order).
  std::vector<Eigen::Vector3d> element_forces_;
  std::vector<std::size_t> node_offsets_;
  std::vector<std::int64_t> node_entries_;
  // The stiffness: the matrix, its element buffer [element][(3 Nn)^2, column-major], and for
  // each stored value its buffer entries (CSR, in element order).
  Eigen::SparseMatrix<double> stiffness_;
  std::vector<double> element_stiffness_;
  std::vector<std::int64_t> value_offsets_, value_entries_;
};

}  // namespace capsflow::membrane
