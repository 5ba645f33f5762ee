#pragma once
// The energy budget of a run (issue 32), as columns of diagnostics.csv. A relaxing capsule
// turns the elastic energy of its membrane into kinetic energy and viscous dissipation; the
// sides of the domain may add work (a moving wall, an inflow). Integrated over [0, t]:
//   E_membrane(0) + E_kinetic(0) + W_boundary(t) = E_membrane(t) + E_kinetic(t) + W_dissipation(t)
// holds for the continuous problem; the column energy_residual is the left side minus the
// right side (and minus W_adaptation, below), the discrete scheme's error in that balance. Instantaneous powers, each with
// its time integral carried from step to step:
//   P_nodes     sum over the membrane nodes of F . V (ibm/capsule_coupling.hpp)
//   P_spread    the spread force against the projected face velocity (fluid/energy.hpp);
//               equal to P_nodes when spreading and interpolation are adjoint
//   dissipation int mu |grad u|^2, integrated by the trapezoidal rule into W_dissipation
//   P_boundary  the work rate of the sides, integrated into W_boundary
//   W_membrane  the membranes' work on the fluid, sum of dt F . (X(t + dt) - X(t)) / dt
//   W_adaptation the kinetic energy the adaptations removed (their transfer of the velocity
//               to the new cells: coarsening averages), so that
//   E_membrane(0) + E_kinetic(0) + W_boundary = E_membrane + E_kinetic + W_dissipation + W_adaptation + residual.
// The integrals and the values at the run's start travel in checkpoints, so a restarted run
// writes the same columns as the uninterrupted one. Fluid quantities are taken after each
// flow step, before the adaptation changes the grid (what the adaptation's transfer does to
// the kinetic energy shows in the residual).
#include <string>
#include <vector>

#include "fluid/energy.hpp"
#include "ibm/capsule_coupling.hpp"
#include "io/checkpoint.hpp"
#include "parallel/comm.hpp"

namespace capsflow::app {

template <int D>
class EnergyBudget {
 public:
  // coupling: the run's capsules, or nullptr (then the membrane columns are 0).
  EnergyBudget(fluid::NavierStokes<D>& ns, const ibm::CapsuleCoupling* coupling)
      : ns_(ns), coupling_(coupling), comm_(parallel::Comm::world()) {}

  // The reference state at the start of a new run (the integrals start at 0). Collective.
  void start();
  // A restarted run: the reference values and integrals from the checkpoint (a checkpoint
  // written before the budget existed starts it anew here). Collective.
  void restore(const std::vector<io::ExtraArray>& extras);
  // After each flow step of length dt, before the adaptation; `row`: a diagnostics row
  // follows (P_spread is measured for it only). Collective.
  void after_step(double dt, bool row);
  // After an adaptation changed the grid: the kinetic energy its transfer of the velocity
  // added or removed (restriction averages, so coarsening removes some) goes to
  // W_adaptation. Collective.
  void after_adaptation();

  [[nodiscard]] static std::vector<std::string> columns();
  // The current values in the order of columns().
  [[nodiscard]] std::vector<double> row() const;
  [[nodiscard]] std::vector<io::ExtraArray> checkpoint_extras() const;

 private:
  template <class F>
  [[nodiscard]] double over_capsules(F&& f) const;
  [[nodiscard]] double membrane_energy() const;
  [[nodiscard]] double membrane_work() const;
  [[nodiscard]] double node_power() const;
  void measure(bool spread);  // flow_, and spread_power_ if `spread`, of the current state

  fluid::NavierStokes<D>& ns_;
  const ibm::CapsuleCoupling* coupling_;
  parallel::Comm comm_;
  double membrane_start_ = 0.0, kinetic_start_ = 0.0;  // at the run's start
  double dissipated_ = 0.0, boundary_work_ = 0.0;       // W_dissipation, W_boundary
  double adaptation_loss_ = 0.0;                        // W_adaptation
  fluid::FlowEnergy flow_;                              // after the last step
  double spread_power_ = 0.0;
};

extern template class EnergyBudget<2>;
extern template class EnergyBudget<3>;

}  // namespace capsflow::app
