// MembraneModel: precomputation, parallel assembly by gather, bad-element reports.
// The discrete equations are stated in force_kernel.hpp.
#include "membrane/forces.hpp"

#include "membrane/errors.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace capsflow::membrane {

namespace {

QuadratureRule force_rule(Order order, const ModelOptions& options) {
  if (options.quadrature_degree < 0) {
    throw std::invalid_argument("MembraneModel: quadrature degree " +
                                std::to_string(options.quadrature_degree) + " must be >= 0");
  }
  if (options.quadrature_degree > 0) return gauss_rule_for_degree(options.quadrature_degree);
  switch (order) {
    case Order::p1: return centroid_rule();
    case Order::p2: return hammer3_rule();
  }
  throw std::logic_error("MembraneModel: unknown element order");
}

}  // namespace

MembraneModel::MembraneModel(Mesh reference, const LawParameters& law, const ModelOptions& options)
    : mesh_(std::move(reference)), law_(make_law(law)), rule_(force_rule(mesh_.order, options)) {
  validate_mesh(mesh_);
  with_element_nodes(mesh_.order, [&](auto nn) { precompute<nn()>(); });
}

template <int Nn>
void MembraneModel::precompute() {
  const int nq = static_cast<int>(rule_.points.size());
  std::vector<ShapeDerivatives<Nn>> derivatives;
  for (const auto& p : rule_.points) {
    const auto s = shape_functions<Nn>(p.xi, p.eta);
    derivatives.push_back({s.d_xi, s.d_eta});
  }
  shape_derivatives_ = std::move(derivatives);
  const ShapeDerivatives<Nn>* d = std::get<std::vector<ShapeDerivatives<Nn>>>(shape_derivatives_).data();

  const auto n_elements = static_cast<std::size_t>(mesh_.element_count());
  reference_points_.resize(n_elements * static_cast<std::size_t>(nq));
  element_forces_.assign(n_elements * Nn, Eigen::Vector3d::Zero());
  // Node -> (element, local node) entries of the element force buffer, in element order.
  node_offsets_.assign(static_cast<std::size_t>(mesh_.node_count()) + 1, 0);
  for (const auto v : mesh_.elements) ++node_offsets_[static_cast<std::size_t>(v) + 1];
  for (std::size_t i = 1; i < node_offsets_.size(); ++i) node_offsets_[i] += node_offsets_[i - 1];
  node_entries_.resize(mesh_.elements.size());
  {
    auto fill = node_offsets_;
    for (std::size_t k = 0; k < mesh_.elements.size(); ++k)
      node_entries_[fill[static_cast<std::size_t>(mesh_.elements[k])]++] = static_cast<std::int64_t>(k);
  }
  for (std::size_t slot = 0; slot < n_elements; ++slot) {
    const auto nodes = mesh_.element(static_cast<std::int64_t>(slot));
    const auto x = gather<Nn>(mesh_.nodes, nodes.data());
    for (int q = 0; q < nq; ++q) {
      const auto [g1, g2] = tangents<Nn>(x, d[q][0].data(), d[q][1].data());
      const double g11 = g1.squaredNorm(), g12 = g1.dot(g2), g22 = g2.squaredNorm();
      const double det = g11 * g22 - g12 * g12;
      if (!(det > 0.0)) {  // validate_mesh samples 7 points; the rule may use others
        std::ostringstream msg;
        msg << "membrane mesh: element " << static_cast<std::int64_t>(slot)
            << " is degenerate: reference det G = " << det << " at quadrature point " << q;
        throw ElementError(msg.str(), static_cast<std::int64_t>(slot));
      }
      reference_points_[slot * static_cast<std::size_t>(nq) + static_cast<std::size_t>(q)] = {
          g22 / det, -g12 / det, g11 / det, 1.0 / det,
          rule_.points[static_cast<std::size_t>(q)].weight * std::sqrt(det)};
    }
  }
}

void MembraneModel::check_configuration(const Eigen::Matrix3Xd& x) const {
  if (x.cols() != mesh_.node_count()) {
    throw std::invalid_argument("MembraneModel: configuration has " + std::to_string(x.cols()) +
                                " nodes, the mesh " + std::to_string(mesh_.node_count()));
  }
}

template <int Nn>
void MembraneModel::throw_bad_element(const Eigen::Matrix3Xd& x, std::int64_t slot) const {
  const ShapeDerivatives<Nn>* d = std::get<std::vector<ShapeDerivatives<Nn>>>(shape_derivatives_).data();
  const int nq = static_cast<int>(rule_.points.size());
  const auto xe = gather<Nn>(x, mesh_.elements.data() + slot * Nn);
  const Eigen::Vector3d chord = chord_normal<Nn>(xe);
  const std::int64_t e = slot;
  std::ostringstream msg;
  msg << "membrane forces: element " << e << " ";
  for (int q = 0; q < nq; ++q) {
    const auto k = point_kinematics<Nn>(xe, d[q], reference_points_[static_cast<std::size_t>(slot * nq + q)]);
    if (!(k.det > min_det_c) || !std::isfinite(k.det)) {
      msg << "is degenerate in the current configuration: det C = J^2 = " << k.det
          << " at quadrature point " << q;
      throw ElementError(msg.str(), e);
    }
    const double orientation = k.g.g1.cross(k.g.g2).dot(chord);
    if (!(orientation > 0.0)) {
      msg << "is inverted (folded) in the current configuration: g1 x g2 . n_chord = "
          << orientation << " at quadrature point " << q;
      throw ElementError(msg.str(), e);
    }
  }
  msg << "is invalid in the current configuration";
  throw ElementError(msg.str(), e);
}

// stiffness.cpp reports bad elements too.
template void MembraneModel::throw_bad_element<3>(const Eigen::Matrix3Xd&, std::int64_t) const;
template void MembraneModel::throw_bad_element<6>(const Eigen::Matrix3Xd&, std::int64_t) const;

template <int Nn, class Law>
double MembraneModel::assemble(const Law& law, const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd* forces,
                               Eigen::Vector3d* buffer) const {
  const ShapeDerivatives<Nn>* d = std::get<std::vector<ShapeDerivatives<Nn>>>(shape_derivatives_).data();
  const int nq = static_cast<int>(rule_.points.size());
  const std::int32_t* conn = mesh_.elements.data();
  const ReferencePoint* ref = reference_points_.data();
  const std::int64_t n_elements = mesh_.element_count();
  const std::int64_t n_nodes = mesh_.node_count();
  // Element energies summed afterwards in element order: the energy is then the same to the
  // last bit for any thread count (an OpenMP reduction's order follows the threads).
  std::vector<double> energies(static_cast<std::size_t>(n_elements));
  std::int64_t bad_slot = -1;
#pragma omp parallel
  {
    std::array<Eigen::Vector3d, Nn> f;
    // Phase 1: element kernels, each element writing only its own buffer entries.
#pragma omp for schedule(static)
    for (std::int64_t slot = 0; slot < n_elements; ++slot) {
      const std::int32_t* nodes = conn + slot * Nn;
      const auto xe = gather<Nn>(x, nodes);
      ElementStatus status;
      if (forces != nullptr) {
        energies[static_cast<std::size_t>(slot)] = element_forces<Nn>(law, xe, d, ref + slot * nq, nq, f, status);
        // Each element owns its buffer slots: no two threads write the same entry.
        for (int i = 0; i < Nn; ++i) buffer[slot * Nn + i] = f[i];
      } else {
        energies[static_cast<std::size_t>(slot)] = element_energy<Nn>(law, xe, d, ref + slot * nq, nq, status);
      }
      if (!status.ok) {
#pragma omp critical(capsflow_membrane_bad_element)
        if (bad_slot < 0 || slot < bad_slot) bad_slot = slot;
      }
    }
    // Phase 2: each node sums its entries in element order (after the barrier above).
    if (forces != nullptr) {
#pragma omp for schedule(static)
      for (std::int64_t node = 0; node < n_nodes; ++node) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::size_t k = node_offsets_[static_cast<std::size_t>(node)]; k < node_offsets_[static_cast<std::size_t>(node) + 1]; ++k)
          sum += buffer[node_entries_[k]];
        forces->col(node) = sum;
      }
    }
  }
  if (bad_slot >= 0) throw_bad_element<Nn>(x, bad_slot);
  double energy = 0.0;
  for (const double e : energies) energy += e;
  return energy;
}

double MembraneModel::energy(const Eigen::Matrix3Xd& x) const {
  check_configuration(x);
  return std::visit(
      [&](const auto& law) {
        return with_element_nodes(mesh_.order, [&](auto nn) { return assemble<nn()>(law, x, nullptr, nullptr); });
      },
      law_);
}

double MembraneModel::compute_forces(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& forces) {
  check_configuration(x);
  if (forces.cols() != x.cols()) forces.resize(3, x.cols());
  return std::visit(
      [&](const auto& law) {
        Eigen::Vector3d* buffer = element_forces_.data();
        return with_element_nodes(mesh_.order, [&](auto nn) { return assemble<nn()>(law, x, &forces, buffer); });
      },
      law_);
}

std::vector<PrincipalTensions> MembraneModel::element_tensions(const Eigen::Matrix3Xd& x) const {
  check_configuration(x);
  const std::int64_t n_elements = mesh_.element_count();
  std::vector<PrincipalTensions> out(static_cast<std::size_t>(n_elements));
  const auto at_centroid = [&]<int Nn>(std::int64_t e) {
    const auto s = shape_functions<Nn>(1.0 / 3.0, 1.0 / 3.0);
    const auto ref = gather<Nn>(mesh_.nodes, mesh_.element(e).data());
    const auto cur = gather<Nn>(x, mesh_.element(e).data());
    const auto [G1, G2] = tangents<Nn>(ref, s.d_xi.data(), s.d_eta.data());
    const auto [g1, g2] = tangents<Nn>(cur, s.d_xi.data(), s.d_eta.data());
    const double G11 = G1.squaredNorm(), G12 = G1.dot(G2), G22 = G2.squaredNorm();
    const double det_G = G11 * G22 - G12 * G12;
    const double g11 = g1.squaredNorm(), g12 = g1.dot(g2), g22 = g2.squaredNorm();
    // C^a_b = G^ac g_cb with G^-1 = (G22, -G12; -G12, G11) / det G.
    const double c11 = (G22 * g11 - G12 * g12) / det_G, c12 = (G22 * g12 - G12 * g22) / det_G;
    const double c21 = (G11 * g12 - G12 * g11) / det_G, c22 = (G11 * g22 - G12 * g12) / det_G;
    return std::visit([&](const auto& law) { return tensions_from_mixed(law, c11, c12, c21, c22); }, law_);
  };
  with_element_nodes(mesh_.order, [&](auto nn) {
#pragma omp parallel for schedule(static)
    for (std::int64_t e = 0; e < n_elements; ++e)
      out[static_cast<std::size_t>(e)] = at_centroid.template operator()<nn()>(e);
  });
  return out;
}

}  // namespace capsflow::membrane
