#pragma once
// The capsules of a case, coupled to the flow: built from the [[capsule]] tables, stepped
// by the immersed-boundary coupling, measured (the seed's diagnostics) and written out.
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ibm/capsule_coupling.hpp"
#include "io/case_config.hpp"
#include "io/checkpoint.hpp"
#include "io/pvd_series.hpp"
#include "parallel/comm.hpp"

namespace capsflow::app {

struct CapsuleDiagnostics {
  double d12 = 0.0, d12_bbox = 0.0, area_rel = 0.0, volume_rel = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  // In a shear in the x-y plane (membrane/diagnostics.hpp): the inertia ellipsoid's
  // inclination to x over pi, and the membrane's tank-treading rate about z (Keller-Skalak's
  // phase rate; 0 before the first step).
  double inclination = 0.0, omega_z = 0.0;
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();  // the nodes' bounding box: Lx, Ly, Lz
};

class CapsuleSet {
 public:
  // Builds every capsule of the case (mesh, law with Gs = 1 / (Ca Re), initial shape) and
  // the coupling on ns. Throws std::invalid_argument naming the capsule key on bad input.
  // On N ranks every rank builds every capsule; distribute() then keeps each on its owner.
  CapsuleSet(const io::CaseConfig& c, fluid::NavierStokes<3>& ns);

  ibm::CapsuleCoupling& coupling() { return *coupling_; }
  // N ranks: once the tree is distributed (and, at a restart, the capsules restored), each
  // rank keeps the capsules it owns (ibm::CapsuleCoupling::distribute). Collective.
  void distribute();
  // Capsule k, against its stress-free reference (discrete sphere: area_rel and volume_rel
  // measure the run, not the mesh's approximation of 4 pi a^2); this rank must own it.
  CapsuleDiagnostics diagnostics(int k) const;
  // capsules.csv: one row per capsule and output step, in the order of columns(): its shape
  // (as diagnostics()), centroid, energy (membrane energy, node power F . V, the work
  // of its membrane on the fluid since the run began; app/energy_budget.hpp), then its
  // inclination and rotation rate in the x-y plane, then its nodes' bounding box Lx, Ly, Lz.
  [[nodiscard]] static std::vector<std::string> columns();
  // The rows of every capsule, one after another in capsule order, on rank 0 (empty on the
  // others): each owner measures its capsules. Throws std::runtime_error (naming the step)
  // on every rank for an inverted element at the current positions. Collective.
  [[nodiscard]] std::vector<double> rows(long step, double t) const;
  // The diagnostics of a row of rows().
  [[nodiscard]] static CapsuleDiagnostics from_row(std::span<const double> row);
  // membrane_NNNNNN.vtu (one per capsule: _<i> from the second on), each written by its
  // owner; rank 0 (series non-null there only) lists them as parts 1.. of the series. Collective.
  void snapshot(const std::filesystem::path& dir, long step, double t, io::PvdSeries* series) const;
  void write_final(const std::filesystem::path& dir) const;  // membrane_final.csv, by rank 0; collective
  // Node positions and velocities, on rank 0 (empty on the others). Collective.
  std::vector<io::ExtraArray> checkpoint_extras() const;
  // From a checkpoint written after `step` steps: the positions and the adaptation state.
  void restore(const std::vector<io::ExtraArray>& extras, std::int64_t step);

 private:
  const io::CaseConfig& case_;
  parallel::Comm comm_;
  std::unique_ptr<ibm::CapsuleCoupling> coupling_;
  std::vector<double> reference_area_, reference_volume_;
};

}  // namespace capsflow::app
