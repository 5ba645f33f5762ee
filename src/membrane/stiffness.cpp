// MembraneModel::stiffness: the pattern (built once), the element kernels in parallel and
// the assembly by gather. The kernel's equations are in stiffness_kernel.hpp.
#include "membrane/forces.hpp"
#include "membrane/stiffness_kernel.hpp"

#include <algorithm>
#include <vector>

namespace capsflow::membrane {

template <int Nn>
void MembraneModel::build_stiffness_pattern() {
  constexpr int kDofs = 3 * Nn;
  const std::int64_t n_elements = mesh_.element_count();
  const auto n = static_cast<Eigen::Index>(3 * mesh_.node_count());
  const std::int32_t* conn = mesh_.elements.data();
  const auto dof = [&](std::int64_t e, int local) {
    return static_cast<Eigen::Index>(3 * conn[e * Nn + local / 3] + local % 3);
  };
  std::vector<Eigen::Triplet<double>> pattern;
  pattern.reserve(static_cast<std::size_t>(n_elements) * kDofs * kDofs);
  for (std::int64_t e = 0; e < n_elements; ++e)
    for (int c = 0; c < kDofs; ++c)
      for (int r = 0; r < kDofs; ++r) pattern.emplace_back(dof(e, r), dof(e, c), 0.0);
  stiffness_.resize(n, n);
  stiffness_.setFromTriplets(pattern.begin(), pattern.end());
  stiffness_.makeCompressed();
  // Each element entry's value slot, then the slots' entries in element order (a counting
  // sort: entry numbers grow with the element).
  const auto* outer = stiffness_.outerIndexPtr();
  const auto* inner = stiffness_.innerIndexPtr();
  std::vector<std::int64_t> slot_of(pattern.size());
  for (std::size_t k = 0; k < pattern.size(); ++k) {
    const auto col = pattern[k].col(), row = pattern[k].row();
    slot_of[k] = std::lower_bound(inner + outer[col], inner + outer[col + 1], row) - inner;
  }
  value_offsets_.assign(static_cast<std::size_t>(stiffness_.nonZeros()) + 1, 0);
  for (const std::int64_t s : slot_of) ++value_offsets_[static_cast<std::size_t>(s) + 1];
  for (std::size_t i = 1; i < value_offsets_.size(); ++i) value_offsets_[i] += value_offsets_[i - 1];
  value_entries_.resize(slot_of.size());
  auto fill = value_offsets_;
  for (std::size_t k = 0; k < slot_of.size(); ++k)
    value_entries_[static_cast<std::size_t>(fill[static_cast<std::size_t>(slot_of[k])]++)] = static_cast<std::int64_t>(k);
  element_stiffness_.assign(pattern.size(), 0.0);
}

template <int Nn, class Law>
void MembraneModel::assemble_stiffness(const Law& law, const Eigen::Matrix3Xd& x, bool positive) {
  constexpr int kEntries = 9 * Nn * Nn;
  const ShapeDerivatives<Nn>* d = std::get<std::vector<ShapeDerivatives<Nn>>>(shape_derivatives_).data();
  const int nq = static_cast<int>(rule_.points.size());
  const std::int32_t* conn = mesh_.elements.data();
  const ReferencePoint* ref = reference_points_.data();
  const std::int64_t n_elements = mesh_.element_count();
  const auto n_values = static_cast<std::int64_t>(stiffness_.nonZeros());
  double* values = stiffness_.valuePtr();
  double* buffer = element_stiffness_.data();
  std::int64_t bad_slot = -1;
#pragma omp parallel
  {
    ElementStiffness<Nn> k;
#pragma omp for schedule(static)
    for (std::int64_t slot = 0; slot < n_elements; ++slot) {
      ElementStatus status;
      element_stiffness<Nn>(law, gather<Nn>(x, conn + slot * Nn), d, ref + slot * nq, nq, positive, k, status);
      if (!status.ok) {
#pragma omp critical(capsflow_membrane_bad_stiffness_element)
        if (bad_slot < 0 || slot < bad_slot) bad_slot = slot;
        continue;
      }
      std::copy(k.data(), k.data() + kEntries, buffer + slot * kEntries);
    }
#pragma omp for schedule(static)
    for (std::int64_t v = 0; v < n_values; ++v) {
      double sum = 0.0;
      for (std::int64_t e = value_offsets_[static_cast<std::size_t>(v)]; e < value_offsets_[static_cast<std::size_t>(v) + 1]; ++e)
        sum += buffer[value_entries_[static_cast<std::size_t>(e)]];
      values[v] = sum;
    }
  }
  if (bad_slot >= 0) throw_bad_element<Nn>(x, bad_slot);
}

const Eigen::SparseMatrix<double>& MembraneModel::stiffness(const Eigen::Matrix3Xd& x, StiffnessPart part) {
  check_configuration(x);
  with_element_nodes(mesh_.order, [&](auto nn) {
    if (value_offsets_.empty()) build_stiffness_pattern<nn()>();
    std::visit([&](const auto& law) { assemble_stiffness<nn()>(law, x, part == StiffnessPart::positive); }, law_);
  });
  return stiffness_;
}

}  // namespace capsflow::membrane
