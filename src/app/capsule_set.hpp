#pragma once
// The capsules of a case, coupled to the flow: built from the [[capsule]] tables, stepped
// by the immersed-boundary coupling, measured (the seed's diagnostics) and written out.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "ibm/capsule_coupling.hpp"
#include "io/case_config.hpp"
#include "io/checkpoint.hpp"
#include "io/pvd_series.hpp"

namespace capsflow::app {

struct CapsuleDiagnostics {
  double d12 = 0.0, d12_bbox = 0.0, area_rel = 0.0, volume_rel = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
};

class CapsuleSet {
 public:
  // Builds every capsule of the case (mesh, law with Gs = 1 / (Ca Re), initial shape) and
  // the coupling on ns. Throws std::invalid_argument naming the capsule key on bad input.
  CapsuleSet(const io::CaseConfig& c, fluid::NavierStokes<3>& ns);

  ibm::CapsuleCoupling& coupling() { return *coupling_; }
  // Capsule k, against its stress-free reference (discrete sphere: area_rel and volume_rel
  // measure the run, not the mesh's approximation of 4 pi a^2).
  CapsuleDiagnostics diagnostics(int k) const;
  // capsules.csv: one row per capsule and output step, in the order of columns(): its shape
  // (as diagnostics()), centroid, and energy (membrane energy, node power F . V, the work
  // of its membrane on the fluid since the run began; app/energy_budget.hpp).
  [[nodiscard]] static std::vector<std::string> columns();
  // The rows of every capsule, one after another. Throws std::runtime_error (naming the step)
  // for an inverted element at the current positions.
  [[nodiscard]] std::vector<double> rows(long step, double t) const;
  // membrane_NNNNNN.vtu (one per capsule: _<i> from the second on), parts 1.. of the series.
  void snapshot(const std::filesystem::path& dir, long step, double t, io::PvdSeries& series) const;
  void write_final(const std::filesystem::path& dir) const;  // membrane_final.csv
  std::vector<io::ExtraArray> checkpoint_extras() const;     // node positions, velocities
  // From a checkpoint written after `step` steps: the positions and the adaptation state.
  void restore(const std::vector<io::ExtraArray>& extras, std::int64_t step);

 private:
  std::unique_ptr<ibm::CapsuleCoupling> coupling_;
  std::vector<double> reference_area_, reference_volume_;
};

}  // namespace capsflow::app
