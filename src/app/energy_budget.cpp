#include "app/energy_budget.hpp"

#include <fmt/format.h>

#include "parallel/all_or_none.hpp"

namespace capsflow::app {

namespace {
constexpr const char* kExtra = "energy_budget";
// The checkpoint's energy_budget array, in this order.
enum Slot { kMembraneStart, kKineticStart, kDissipated, kBoundaryWork, kKinetic, kDissipation, kBoundaryPower,
            kSpreadPower, kAdaptationLoss, kSlots };
}  // namespace

// The sum over the capsules of f(k), each on its owner, exact: the same on any number of
// ranks (and an inverted element found by one owner stops every rank). Collective.
template <int D>
template <class F>
double EnergyBudget<D>::over_capsules(F&& f) const {
  parallel::ExactSum sum;
  parallel::all_or_none(comm_, [&] {
    for (int k = 0; coupling_ && k < coupling_->num_capsules(); ++k)
      if (coupling_->owns(k)) sum.add(f(k));
  });
  return ns_.tree().global_sum(sum);
}

template <int D>
double EnergyBudget<D>::membrane_energy() const {
  return over_capsules([this](int k) { return coupling_->membrane_energy(k); });
}

template <int D>
double EnergyBudget<D>::membrane_work() const {
  return over_capsules([this](int k) { return coupling_->capsule(k).work; });
}

template <int D>
double EnergyBudget<D>::node_power() const {
  return over_capsules([this](int k) { return coupling_->node_power(k); });
}

template <int D>
void EnergyBudget<D>::measure(bool spread) {
  flow_ = fluid::flow_energy(ns_);
  // Before the first step there is neither a force nor a projected face velocity.
  if (spread)
    spread_power_ = ns_.face_velocity_current()
                        ? fluid::face_power<D>(ns_.tree(), ns_.face_force(), ns_.face_velocity(),
                                               ns_.embedded() ? &ns_.embedded()->faces() : nullptr)
                        : 0.0;
}

template <int D>
void EnergyBudget<D>::start() {
  measure(true);
  membrane_start_ = membrane_energy();
  kinetic_start_ = flow_.kinetic;
  dissipated_ = boundary_work_ = adaptation_loss_ = 0.0;
}

template <int D>
void EnergyBudget<D>::restore(const std::vector<io::ExtraArray>& extras) {
  for (const io::ExtraArray& e : extras)
    if (e.name == kExtra && e.values.size() == kSlots) {
      const std::vector<double>& v = e.values;
      membrane_start_ = v[kMembraneStart];
      kinetic_start_ = v[kKineticStart];
      dissipated_ = v[kDissipated];
      boundary_work_ = v[kBoundaryWork];
      flow_ = {v[kKinetic], v[kDissipation], v[kBoundaryPower]};
      spread_power_ = v[kSpreadPower];
      adaptation_loss_ = v[kAdaptationLoss];
      return;
    }
  start();
}

template <int D>
void EnergyBudget<D>::after_step(double dt, bool row) {
  const fluid::FlowEnergy before = flow_;
  measure(row);
  dissipated_ += 0.5 * dt * (before.dissipation + flow_.dissipation);
  boundary_work_ += 0.5 * dt * (before.boundary_power + flow_.boundary_power);
}

template <int D>
void EnergyBudget<D>::after_adaptation() {
  // Phi and P_b stay the step's (the next step's trapezoid starts from them): what the
  // transfer changes in them is of the transfer's order, and re-measuring them would cost a
  // sync and a pass over the faces at every adaptation.
  ns_.refresh_properties();  // an inner fluid's density on the new cells
  const double kinetic = fluid::kinetic_energy(ns_);
  adaptation_loss_ += flow_.kinetic - kinetic;
  flow_.kinetic = kinetic;
}

template <int D>
std::vector<std::string> EnergyBudget<D>::columns() {
  return {"E_membrane", "E_kinetic",     "P_nodes",    "P_spread",     "dissipation",    "P_boundary",
          "W_membrane", "W_dissipation", "W_boundary", "W_adaptation", "energy_residual"};
}

template <int D>
std::vector<double> EnergyBudget<D>::row() const {
  const double membrane = membrane_energy();
  const double residual = (membrane_start_ - membrane) + (kinetic_start_ - flow_.kinetic) + boundary_work_ -
                          dissipated_ - adaptation_loss_;
  return {membrane,        flow_.kinetic, node_power(),   spread_power_,    flow_.dissipation, flow_.boundary_power,
          membrane_work(), dissipated_,   boundary_work_, adaptation_loss_, residual};
}

template <int D>
std::vector<io::ExtraArray> EnergyBudget<D>::checkpoint_extras() const {
  std::vector<double> v(kSlots);
  v[kMembraneStart] = membrane_start_;
  v[kKineticStart] = kinetic_start_;
  v[kDissipated] = dissipated_;
  v[kBoundaryWork] = boundary_work_;
  v[kKinetic] = flow_.kinetic;
  v[kDissipation] = flow_.dissipation;
  v[kBoundaryPower] = flow_.boundary_power;
  v[kSpreadPower] = spread_power_;
  v[kAdaptationLoss] = adaptation_loss_;
  return {{kExtra, {static_cast<std::size_t>(kSlots)}, std::move(v)}};
}

template class EnergyBudget<2>;
template class EnergyBudget<3>;

}  // namespace capsflow::app
