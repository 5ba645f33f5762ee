#pragma once
// The immersed-boundary time step of the seed paper ("Coupling strategy and method"), for
// one or more capsules in one flow:
//   1. F = -dE/dX at X(t)                                  (membrane/, per capsule)
//   2. f = sum_X F delta_c(x - X) / dx^3 on the max-level cells; face force = mean of the
//      two cells                                            (spread.hpp)
//   3. one step of the flow solver with f: u(t) -> u(t + dt) (fluid/, explicit coupling)
//   4. V = sum_cells u(t + dt) delta_l(x - X)               (interpolate.hpp)
//   5. X(t + dt) = X(t) + dt V                               (forward Euler, as the seed)
//   6. when asked: adapt the tree (membrane band at the max level, walls at their level,
//      velocity wavelets elsewhere) so that the next step's stencils exist.
// The coupling is explicit, so dt is bounded by the membrane's stiffness: a node's
// relaxation time on the fluid grid is about mu dx / Gs = Ca dx (below), and steps much
// longer than that make the membrane oscillate and blow up. Blow-up is detected (non-finite
// forces or velocities, an inverted element, a node leaving the domain) and reported as a
// std::runtime_error naming the step, the time and the likely cause; the node positions
// then stay those of the last good step.
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fluid/navier_stokes.hpp"
#include "ibm/kernels.hpp"
#include "ibm/refinement_tags.hpp"
#include "ibm/spread.hpp"
#include "membrane/forces.hpp"

namespace capsflow::ibm {

// The membrane shear modulus in the solver's units. DESIGN.md and the seed scale lengths by
// l, velocities by V and forces by rho V^2 l^2, so a tension (force per length) is scaled
// by rho V^2 l and Gs' = Gs / (rho V^2 l) = (Gs / (mu V)) (mu / (rho V l)) = 1 / (Ca Re),
// with rho' = 1 and mu' = 1/Re (the seed's relation Ca/Re = mu^2 / (rho Gs l) is the same
// statement). The stability scale mu' dx / Gs' is then Ca dx, independent of Re.
[[nodiscard]] constexpr double shear_modulus(double ca, double re) { return 1.0 / (ca * re); }

struct KernelChoice {
  KernelKind spread = KernelKind::cosine;   // the seed's delta_c
  KernelKind interpolate = KernelKind::hat;  // the seed's delta_l
};

struct CouplingAdapt {
  bool enabled = false;              // adapt after every `interval`-th step
  int interval = 1;
  // > interval: an adaptation may wait, up to this many steps after the last one, while the
  // nodes, at their mean speed since then, would move less than half the margin by then
  // (a slowly relaxing capsule needs no new band every few steps). 0: every interval.
  int max_interval = 0;
  double velocity_tolerance = 1e-2;  // wavelet tolerance on each velocity component
  double velocity_tolerance_relative = 0.0;  // NavierStokes::velocity_tolerance
  int min_level = 0;
  int wall_level = 0;                // level forced on leaves touching a wall (0: none)
  int margin = 2;                    // max-level cells tagged beyond the kernels' half support
};

struct Capsule {
  membrane::MembraneModel model;
  Eigen::Matrix3Xd x;         // node positions X
  KernelChoice kernels{};
  Eigen::Matrix3Xd forces;    // F(X(t)) of the last step
  Eigen::Matrix3Xd velocity;  // V of the last step
  Eigen::Matrix3Xd x_at_adapt;  // X at the last adaptation (CouplingAdapt::max_interval)
  double energy = 0.0;        // E(X(t)) of the last step
  MembraneTags tags;
};

// Wall-clock seconds spent in each stage since construction.
struct StageTimes {
  double membrane = 0.0;       // forces
  double spreading = 0.0;      // cell force and face force
  double fluid = 0.0;          // the flow step (without the face force)
  double interpolation = 0.0;  // velocities and the position update
  double adapt = 0.0;
};

struct [[nodiscard]] CouplingStep {
  fluid::StepStats fluid;
  bool adapted = false;
  tree::AdaptCounts adapt{};
};

class CapsuleCoupling {
 public:
  // Installs the face force on ns (removed again by the destructor): ns must outlive this.
  explicit CapsuleCoupling(fluid::NavierStokes<3>& ns, CouplingAdapt adapt = {});
  ~CapsuleCoupling();
  CapsuleCoupling(const CapsuleCoupling&) = delete;
  CapsuleCoupling& operator=(const CapsuleCoupling&) = delete;

  // Another body force (a pressure drop, gravity) to which the capsules' force is added;
  // the coupling owns the flow's face force, so other forces go through here.
  void set_background_force(fluid::NavierStokes<3>::FaceForce f) { background_ = std::move(f); }

  // Adds a capsule at positions x (3 x the model's nodes); returns its index.
  int add_capsule(membrane::MembraneModel model, Eigen::Matrix3Xd x, KernelChoice kernels = {});

  // Refines (never coarsens) until every capsule's band is at the tree's max level and the
  // walls at their level: call once before the first step.
  tree::AdaptCounts refine_initial();
  // One coupled step (stages 1-5), then stage 6 if adaptation is enabled and due.
  CouplingStep step();
  // Stage 6: tags from the current positions, one wavelet adapt with them, then forced
  // refinement passes only if some stencil still misses a max-level cell.
  tree::AdaptCounts adapt();
  // Whether every stencil of every capsule (both kernels) exists at the max level.
  [[nodiscard]] bool stencils_ready() const;

  [[nodiscard]] int num_capsules() const { return static_cast<int>(capsules_.size()); }
  [[nodiscard]] const Capsule& capsule(int i) const { return capsules_.at(i); }
  [[nodiscard]] Capsule& capsule(int i) { return capsules_.at(i); }
  [[nodiscard]] std::int64_t steps() const { return steps_; }
  // The steps taken so far, tested against CouplingAdapt::interval: a restarted run sets it
  // to its checkpoint's step, so that it adapts after the same steps as the uninterrupted one.
  void set_steps(std::int64_t n) { steps_ = n; }
  // Steps since the last adaptation; a checkpoint keeps it (with each x_at_adapt) so that a
  // restarted run adapts when the uninterrupted one would.
  [[nodiscard]] std::int64_t steps_since_adapt() const { return since_adapt_; }
  void set_steps_since_adapt(std::int64_t n) { since_adapt_ = n; }
  [[nodiscard]] const StageTimes& times() const { return times_; }
  [[nodiscard]] const CellVector& cell_force() const { return force_; }
  [[nodiscard]] const CouplingAdapt& adapt_options() const { return adapt_; }
  // The membrane time scale mu dx / Gs (= Ca dx in the seed's units), smallest over the
  // capsules: stable steps are a modest multiple of it at most.
  [[nodiscard]] double membrane_time_scale() const;
  // The forced level of a leaf box: the capsules' bands and the walls.
  [[nodiscard]] int required_level(const tree::Box<3>& b) const;

 private:
  void build_tags();
  void compute_forces(int step);
  void spread_forces(int step);
  void move_nodes(int step, double dt);
  // Throws std::runtime_error naming the step and time; `unstable` adds the likely cause
  // of a blow-up (stencil errors carry their own).
  [[noreturn]] void fail(int step, const std::string& what, bool unstable = true) const;
  bool touches_wall(const tree::Box<3>& b) const;
  // Whether stage 6 runs after this step (interval, and max_interval's waiting rule).
  bool adapt_due() const;

  fluid::NavierStokes<3>& ns_;
  CouplingAdapt adapt_;
  std::vector<Capsule> capsules_;
  CellVector force_;
  SpreadWorkspace workspace_;
  bool force_ready_ = false;
  std::int64_t steps_ = 0;
  std::int64_t since_adapt_ = 0;
  StageTimes times_;
  double face_seconds_ = 0.0;  // face-force time inside the last fluid step
  double last_dt_ = 0.0;       // of the last fluid step (0 before the first)
  fluid::NavierStokes<3>::FaceForce background_;
};

}  // namespace capsflow::ibm
