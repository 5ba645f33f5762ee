#pragma once
// The immersed-boundary time step of the seed paper ("Coupling strategy and method"), for
// one or more capsules in one flow:
//   1. F = -dE/dX at X(t)                                  (membrane/, per capsule)
//   2. f_d = sum_X F_d delta_c(x_f - X) / dx^3 on the max-level faces normal to d
//                                                           (spread.hpp, spread_faces)
//   3. one step of the flow solver with f: u(t) -> u(t + dt) (fluid/, explicit coupling)
//   4. V_d = sum_faces uf_d(t + dt) delta_l(x_f - X)        (interpolate.hpp, faces)
//   5. X(t + dt) = X(t) + dt V^n                             (forward Euler, as the seed)
//      or, with NodeScheme::ab2, X(t + dt) = X(t) + dt ((1 + r/2) V^n - (r/2) V^(n-1)),
//      r = dt / dt_prev (Adams-Bashforth 2; its first step is Euler),
//      or, with NodeScheme::midpoint, stages 1, 2 and 4 at X* = X(t) + (dt/2) V^(n-1) and
//      X(t + dt) = X(t) + dt (J(X*) u(t) + J(X*) u(t + dt)) / 2,
// These are the named stages of fluid/time_step.hpp (forces, spreading, flow, interpolation,
// motion): the coupling attaches to a fluid::TimeStep, which runs the flow step between them;
// then the run's adapt stage (fluid/adaptation.hpp), the same for runs without capsules:
// velocity wavelets, walls at their level, and the membrane bands at the max level that this
// class provides as a fluid::BodyRefinement, so that the next step's stencils exist.
//
// Stages 2 and 4 work on the MAC faces (KernelChoice::staggered, the default): the projection
// makes the face velocity uf divergence-free to its tolerance, the cell-centred u only
// approximately, and nodes moved with the cell velocity let closed membranes gain volume
// steadily (a capsule in shear: +0.77% at strain 2, dx = a/8). With the same kernel on both
// stages, face spreading is the adjoint of face interpolation. staggered = false is the
// seed's scheme (cells, face force = mean of two cells, interpolation of the cell velocity),
// kept for comparison. KernelChoice::divergence_free (the default) uses the kernels'
// divergence-free forms on the faces (kernels.hpp, Bao et al. 2017): the node velocity is
// then exactly divergence-free as a function of position where uf is discretely, and the
// drift of the capsule in shear falls from -0.18% to -0.045% at strain 2 (docs/numerics.md).
//
// V^n is interpolated from u(t + dt) at X(t). On the relaxing capsule at Re = 1 all three
// node schemes measured first order in time (ibm_long_tests TimeOrder; docs/numerics.md)
// with the flow step's defaults; the midpoint scheme with Crank-Nicolson and the carried
// faces (fluid::FlowOptions::carry_faces) is second order (ibm_tests TimeOrder). The midpoint scheme was
// 4-6 times more accurate than Euler, AB2 half as accurate (and AB2's stability interval
// is half of Euler's); Euler stays the default until the midpoint's stability is measured.
//
// The coupling is explicit, so dt is bounded by the membrane's stiffness (stability_limit(),
// measured), and steps longer than that make the membrane oscillate and blow up. Blow-up is detected (non-finite
// forces or velocities, an inverted element, a node leaving the domain) and reported as a
// std::runtime_error naming the step, the time and the likely cause; the node positions
// then stay those of the last good step.
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fluid/adaptation.hpp"
#include "fluid/navier_stokes.hpp"
#include "fluid/time_step.hpp"
#include "ibm/kernels.hpp"
#include "ibm/node_routing.hpp"
#include "ibm/refinement_tags.hpp"
#include "ibm/spread.hpp"
#include "ibm/stencil.hpp"
#include "ibm/wall_weights.hpp"
#include "membrane/forces.hpp"
#include "tree/distributed_forest.hpp"

namespace capsflow::ibm {

// The membrane shear modulus in the solver's units. DESIGN.md and the seed scale lengths by
// l, velocities by V and forces by rho V^2 l^2, so a tension (force per length) is scaled
// by rho V^2 l and Gs' = Gs / (rho V^2 l) = (Gs / (mu V)) (mu / (rho V l)) = 1 / (Ca Re),
// with rho' = 1 and mu' = 1/Re (the seed's relation Ca/Re = mu^2 / (rho Gs l) is the same
// statement). The stability scale mu' dx / Gs' is then Ca dx, independent of Re.
[[nodiscard]] constexpr double shear_modulus(double ca, double re) { return 1.0 / (ca * re); }

struct KernelChoice {
  KernelKind spread = KernelKind::cosine;  // the seed's delta_c
  // The same kernel: interpolation is then spreading's adjoint and the coupling neither
  // creates nor destroys energy (the seed interpolates with its delta_l, the hat kernel:
  // P_nodes exceeds P_spread by 26% at dx = 1/8, and a relaxing capsule loses 10-16% of the
  // energy it releases, tests/app/app_energy_test.cpp).
  KernelKind interpolate = KernelKind::cosine;
  bool staggered = true;  // spread to and interpolate from the MAC faces (else cell centres)
  // On faces: DivergenceFree<K> of both kernels (kernels.hpp), so that the node velocity is
  // exactly divergence-free where the projected face velocity is. Ignored on cells.
  bool divergence_free = true;
};

struct Capsule {
  membrane::MembraneModel model;
  Eigen::Matrix3Xd x;         // node positions X
  KernelChoice kernels{};
  Eigen::Matrix3Xd forces;    // F(X(t)) of the last step
  Eigen::Matrix3Xd velocity;  // V of the last step (V^(n-1) of the next one's AB2)
  Eigen::Matrix3Xd previous_velocity;  // V of the step before (scratch of advance_nodes)
  // (X(t + dt) - X(t)) / dt of the last step: BDF2's history (NodeScheme::bdf2); empty
  // before the first step.
  Eigen::Matrix3Xd motion;
  Eigen::Matrix3Xd x_mid;              // midpoint and bdf2 schemes: X*, where forces and velocities are taken
  Eigen::Matrix3Xd start_velocity;     // midpoint scheme: J(X*) u^n
  Eigen::Matrix3Xd x_at_adapt;  // X at the last adaptation (may_wait)
  Eigen::Matrix3Xd response;    // implicit coupling: J u of its latest flow step (scratch)
  double energy = 0.0;        // E at the positions the last step took the forces at
  // The work the membrane forces did on the fluid since the run began: the sum over the
  // steps of dt F . (X(t + dt) - X(t)) / dt, with F the step's forces (Euler: at X(t); the
  // midpoint scheme: at X*). E(X(0)) - E(X(t)) - work is the node update's own energy
  // error: O(dt) for Euler, O(dt^2) for the midpoint scheme (issue 32).
  double work = 0.0;
  MembraneTags tags;
};

// Wall-clock seconds spent in each stage since construction.
struct StageTimes {
  double membrane = 0.0;       // forces
  double spreading = 0.0;      // cell force and face force
  double fluid = 0.0;          // the flow step (without the face force)
  double interpolation = 0.0;  // velocities and the position update
};

// How stage 5 moves the nodes.
// midpoint: forces at X* = X + (dt/2) V^(n-1), X += dt (J(X*) u^n + J(X*) u^(n+1)) / 2, one
// flow solve per step (Peskin 2002 section 6, Griffith & Peskin 2005); second order with
// Crank-Nicolson viscosity, whose (u^n + u^(n+1))/2 is the flow at t + dt/2, and the
// projected faces carried between steps (measured, docs/numerics.md).
// bdf2: X(t + dt) = X + dt (a V_last + b J(X*) u(t + dt)) with X* = X + dt V_last and BDF2's
// variable-step weights (bdf2_weights), V_last the last step's motion (the first step:
// Euler). The forces are taken at X* too: with the implicit coupling (below) the step is
// BDF2 on the membrane's own dynamics, second order, and needs the flow's BDF2 steps with the
// same weights (fluid::FlowOptions::bdf2, which the app sets). The explicit steps of
// time.coupling = "auto" take the same rule with F(X*) (Euler's there, against the flow's
// BDF2 steps, drove the step control's estimate up without end: measured).
enum class NodeScheme : unsigned char { euler, ab2, midpoint, bdf2 };

struct [[nodiscard]] CouplingStep {
  fluid::StepStats fluid;
};

class CapsuleCoupling final : public fluid::BodyRefinement<3>, public fluid::StepBody {
 public:
  // Installs the face force on ns (removed again by the destructor): ns must outlive this.
  // margin: max-level cells tagged beyond the kernels' half support around every node.
  explicit CapsuleCoupling(fluid::NavierStokes<3>& ns, int margin = 2);
  ~CapsuleCoupling() override;
  CapsuleCoupling(const CapsuleCoupling&) = delete;
  CapsuleCoupling& operator=(const CapsuleCoupling&) = delete;

  // Another body force (a pressure drop, gravity) to which the capsules' force is added;
  // the coupling owns the flow's face force, so other forces go through here.
  void set_background_force(fluid::NavierStokes<3>::FaceForce f) { background_ = std::move(f); }

  // Adds a capsule at positions x (3 x the model's nodes); returns its index (its id).
  int add_capsule(membrane::MembraneModel model, Eigen::Matrix3Xd x, KernelChoice kernels = {});

  // N ranks (docs/parallel.md, "Capsules"). Every rank adds every capsule; once the tree is
  // distributed, distribute() keeps on each rank the capsules it owns (the owner of the
  // max-level cell holding the mean of its nodes) and drops the others. From then on a
  // capsule follows its centroid from rank to rank (its state moves, its reference membrane
  // is rebuilt there by `factory`), its nodes go to the owners of their stencils' cells for
  // spreading and interpolation (node_routing.hpp), and every collective decision (the band,
  // when to adapt, failures) is reduced over the ranks. The numbers are one rank's to the
  // last bit. On one rank (a tree without distribution) nothing changes. Collective.
  using ModelFactory = std::function<membrane::MembraneModel(int capsule)>;
  void distribute(ModelFactory factory);
  [[nodiscard]] bool distributed() const { return forest_ != nullptr; }
  // Whether this rank holds capsule k's state (every capsule on one rank).
  [[nodiscard]] bool owns(int k) const {
    return k >= 0 && k < num_capsules() && capsules_[static_cast<std::size_t>(k)] != nullptr;
  }
  // What a checkpoint keeps of a capsule, every capsule's on rank 0 (in id order; empty on
  // the others). Collective.
  struct SavedState {
    Eigen::Matrix3Xd x, x_at_adapt, velocity, motion;  // velocity, motion: empty before the first step
    double work = 0.0;
  };
  [[nodiscard]] std::vector<SavedState> gather_on_root() const;
  // N ranks: the partition weight of a leaf (tree::LeafWeight): `band_weight` for a
  // max-level leaf in a membrane's band near this rank's cells (the bands of the last
  // update_region, which every adaptation calls before it repartitions), 1 elsewhere.
  [[nodiscard]] std::int64_t leaf_weight(int level, tree::Key key, std::int64_t band_weight) const;

  // Inner fluids (issue 29): capsule k holds a liquid `viscosity_ratio` times as viscous and
  // `density_ratio` times as dense as the one around it (1 and 1, the default: the same).
  struct InnerFluid {
    double viscosity_ratio = 1.0;
    double density_ratio = 1.0;
    [[nodiscard]] bool same() const { return viscosity_ratio == 1.0 && density_ratio == 1.0; }
  };
  void set_inner_fluid(int k, InnerFluid f);
  [[nodiscard]] const InnerFluid& inner_fluid(int k) const { return inner_.at(static_cast<std::size_t>(k)); }
  [[nodiscard]] bool any_inner_fluid() const;
  // The flow's density and viscosity on the leaves this rank owns, from the capsules' node
  // positions X:
  //   rho = rho_out (1 + sum_k (r_k - 1) I_k),  1/mu = (1 + sum_k (1/lambda_k - 1) I_k) / mu_out,
  // I_k the inside of capsule k (indicator.hpp: its flat triangles, the hat kernel's profile
  // at the max level, kInsideProfile), added in capsule order. The viscosity is the harmonic mean of
  // the two fluids weighted by I: across a jump the two parts of a cell conduct the shear in
  // series, and the harmonic cell mean is second order where the arithmetic one is first
  // (fluid_tests FlowProperties.TwoLayerPoiseuilleOffFaceInterfaceHarmonicCellMeanSecondOrder). N ranks: each owner sends its
  // capsule's positions to the ranks that own cells within reach of its bounding box
  // (tree::box_owners), and each rank adds the capsules in id order: one rank's numbers to
  // the bit. The ghosts are left to the caller (NavierStokes exchanges them). Collective.
  void inner_properties(double rho_out, double mu_out, std::span<double> rho, std::span<double> mu);
  // The inside's profile across the membrane: the hat kernel's, a transition of 2h, whatever
  // kernel spreads the forces. The cosine kernel's 4h smears the viscosity jump over half a
  // radius at dx = a/8: a capsule with lambda = 5 then relaxes 26% too fast at t = mu a / G
  // against the small-deformation theory, 9% with the hat's at dt = 5e-4 (docs/numerics.md:
  // part of that agreement is the explicit coupling's time-step error).
  static constexpr KernelKind kInsideProfile = KernelKind::hat;
  // sum_k I_k of the capsules with an inner fluid on the owned leaves, as the last
  // inner_properties left it (sized to the tree then), for the snapshots.
  [[nodiscard]] std::span<const double> inside() const { return inside_; }
  // Seconds spent in inner_properties since construction.
  [[nodiscard]] double inside_seconds() const { return inside_seconds_; }

  // Capsules this rank handed to another since construction (their centroid left its cells).
  [[nodiscard]] std::int64_t migrations() const { return migrations_; }
  // What this rank sent to other ranks in the steps since construction (adaptations aside):
  // node routings, interpolated values going back, migrating capsules (64-bit words); and
  // the most capsules and nodes one routing of a step brought to it. For the weak-scaling
  // model and the test that this traffic follows the capsules near a rank, not all of them.
  struct Traffic {
    std::int64_t words_sent = 0;
    std::int64_t most_capsules_received = 0, most_nodes_received = 0;
  };
  [[nodiscard]] const Traffic& traffic() const { return traffic_; }

  // The stages of a coupled step (fluid/time_step.hpp), for a fluid::TimeStep that runs the
  // flow step between spreading and interpolation:
  //   forces         X* (midpoint scheme) and the membrane forces there;
  //   spreading      onto the faces the flow step reads (N ranks: routed to the owners of the
  //                  stencils' cells), then J(X*) u^n (midpoint scheme);
  //   interpolation  J u^(n+1) at the stage positions;
  //   motion         X += dt (the scheme's velocity), each new position checked first.
  void forces() override;
  void spreading() override;
  void flow_failed() override;
  void interpolation() override;
  void motion(const fluid::StepStats& flow, double flow_seconds) override;
  // One coupled step with these stages alone (a TimeStep of this one body); the caller's
  // fluid::Adaptation adapts after it.
  CouplingStep step();

  // The membrane bands, for fluid::Adaptation: every cell within `margin` cells beyond the
  // kernels' half support of a node is forced to the max level (refinement_tags.hpp).
  void update_region() override;  // tags from the current positions
  [[nodiscard]] int required_level(const tree::Box<3>& b) const override;
  // Whether every stencil of every capsule (both kernels) exists at the max level.
  [[nodiscard]] bool stencils_ready() const override;
  // An adaptation may wait, up to max_interval steps after the last one, while the nodes,
  // at their mean speed since then, would move less than half the margin by then (a slowly
  // relaxing capsule needs no new band every few steps).
  [[nodiscard]] bool may_wait(int max_interval) const override;
  // Whether a node has moved, since the last adaptation, within one step's motion (at its
  // last velocity) of the band's margin: the next step takes its stencils at X (and the
  // midpoint scheme at X + dt/2 V), which must stay in the band.
  [[nodiscard]] bool must_adapt() const override;
  void adapted() override;  // remembers the positions and restarts the count of steps

  [[nodiscard]] int num_capsules() const { return static_cast<int>(capsules_.size()); }
  // E(X) of capsule k at its current positions. An element inverted there is a run failure
  // (std::runtime_error naming the step, as a blow-up in a step).
  [[nodiscard]] double membrane_energy(int k) const;
  // sum over the nodes of F . V for capsule k, the last step's forces and interpolated
  // velocities (0 before the first step): the power its membrane put into the fluid. With
  // the same kernel for both stages on faces it equals the spread force's power against the
  // face velocity, sum_faces f uf dx^3 (spreading is then the adjoint of interpolation).
  [[nodiscard]] double node_power(int k) const;
  // Capsule i's state; this rank must own it (owns(i)).
  [[nodiscard]] const Capsule& capsule(int i) const { return *owned(i); }
  [[nodiscard]] Capsule& capsule(int i) { return *owned(i); }
  [[nodiscard]] std::int64_t steps() const { return steps_; }
  // The steps taken so far (errors name step steps() + 1): a restarted run sets it to its
  // checkpoint's step.
  void set_steps(std::int64_t n) { steps_ = n; }
  // Steps since the last adaptation; a checkpoint keeps it (with each x_at_adapt) so that a
  // restarted run adapts when the uninterrupted one would.
  [[nodiscard]] std::int64_t steps_since_adapt() const { return since_adapt_; }
  void set_steps_since_adapt(std::int64_t n) { since_adapt_ = n; }
  [[nodiscard]] NodeScheme node_scheme() const { return scheme_; }
  void set_node_scheme(NodeScheme s) { scheme_ = s; }

  // The coupling in time (issue 30; implicit_coupling.cpp). Off (the default): the explicit
  // coupling above, the forces at X(t). On: linearised backward Euler. The fluid feels
  // F(X + dX) ~ F(X) - K dX, K the membranes' tangent stiffness at X
  // (membrane/stiffness_kernel.hpp) and dX the step's own displacement dt J u(t + dt); the
  // flow being affine in its force (u = u_explicit - L S K dX),
  //   (I + dt J L S K) dX = dt J u_explicit,
  // solved by FGMRES (common/gmres.hpp) whose every product is the flow step taken again from the
  // same start (fluid/time_step.hpp, rerun) with the force F - K v. The step is then taken
  // once more with F - K dX, and the nodes move with J u(t + dt) as Euler's do: by the
  // divergence-free kernels, so the volume stays. For K >= 0 the eigenvalues of
  // I + dt J L S K are >= 1 and the step is stable at any dt. With NodeScheme::bdf2 the
  // unknown is the displacement from X* and dt is b dt (implicit_coupling.cpp). Euler and
  // BDF2 nodes only.
  struct ImplicitOptions {
    bool enabled = false;
    double tolerance = 1e-3;  // FGMRES: |residual| / |dt J u_explicit|
    int max_iterations = 40;  // products (flow steps) before the step fails
    // Steps no longer than this are taken explicitly (0: none): with a step chosen by
    // accuracy, the short steps of a fast transient cost one flow step, the long ones stay stable.
    double explicit_below = 0.0;
  };
  // Throws std::invalid_argument for a tolerance outside (0, 1), max_iterations < 1, or a flow
  // without FlowOptions::current_force_in_viscous (the force a step late in the viscous solve
  // drives grid-scale cell velocities by dt f / rho, undamped: at steps above a cell's viscous
  // time the fluid then gains more energy than the force gives it, measured).
  void set_implicit(const ImplicitOptions& o);
  [[nodiscard]] const ImplicitOptions& implicit_options() const { return implicit_; }
  struct ImplicitStats {
    std::int64_t steps = 0;     // implicit steps taken
    std::int64_t products = 0;  // FGMRES products (flow steps besides each step's two)
    int most_products = 0;      // in one step
  };
  [[nodiscard]] const ImplicitStats& implicit_stats() const { return implicit_stats_; }
  // Whether this step is implicit (decided at its forces stage from the step's length).
  [[nodiscard]] bool implicit() const override { return implicit_step_; }
  void correct(const std::function<fluid::StepStats()>& rerun) override;
  // dt of the last step (0 before the first: that step is Euler). A checkpoint keeps it with
  // each capsule's velocity, so that a restarted run takes the same AB2 steps.
  [[nodiscard]] double last_dt() const { return last_dt_; }
  void set_last_dt(double dt) { last_dt_ = dt; }
  [[nodiscard]] const StageTimes& times() const { return times_; }
  // The last step's node error per unit time, for the step chosen by accuracy
  // (app/step_control.hpp), over every capsule's nodes, with d = V_last - (V_prev + V)/2
  // (V_last the step's motion, V and V_prev this and the last step's J u):
  //   Euler's steps: max |V - V_prev| / 2 = max |d|, Euler against the trapezoidal rule;
  //   BDF2's: (8/3) max |d|; d is -(dt^2/12) X''' (the trapezoidal rule's error) and BDF2's
  //   local error per unit time (2/9) dt^2 |X'''|.
  // error < 0 while some owned capsule has no V_prev (the first step, a restart).
  // Collective (a maximum over the ranks).
  struct NodeError {
    double error = -1.0;
    int order = 1;  // of the step's scheme: the controller's exponent is 1 / order
  };
  [[nodiscard]] NodeError node_error() const;
  // The spread force of the capsules with staggered = false, on cells (zero if none).
  [[nodiscard]] const CellVector& cell_force() const { return force_; }
  // The spread force of the capsules with staggered = true, on faces (zero if none).
  [[nodiscard]] const fluid::FaceField<3>& face_force() const { return face_force_; }
  // The explicit coupling's stability limit, measured (docs/numerics.md, issue 17): the
  // largest dt at which a relaxing capsule stayed stable for 150 steps fitted, over
  // Re 0.01-10, Ca 0.01-1, dx = 1/8 and 1/16 and both laws, by
  //   dt_lim = min(kInertialLimit sqrt(rho dx^3 / G), kViscousLimit mu dx / G),
  // with G = Gs (Skalak: Gs max(1, (1 + 2C)/3), its area modulus relative to C = 1, the
  // measured case), i.e. in the seed's units min(0.53 sqrt(Ca Re dx^3), 0.42 Ca dx): the
  // limit depends on Re dx / Ca, and the Stokes limit (small Re dx / Ca) is the stricter.
  // No inner fluid lowers it (viscosity ratios 0.01-100 measured, docs/numerics.md), so it
  // takes none. Smallest over the capsules; 0 without capsules.
  [[nodiscard]] double stability_limit() const;
  static constexpr double kInertialLimit = 0.53, kViscousLimit = 0.42;
  // Embedded walls (fluid/embedded_geometry.hpp). A node within its kernels' reach of a wall
  // (the half-diagonal of its widest stencil box at the max level, embedded_wall_reach)
  // spreads onto and interpolates from the open faces only (wall_weights.hpp). A membrane
  // touches a wall when a node comes within embedded_wall_contact() of it, a quarter of the
  // finest cell: closer, the grid cannot put fluid between them, and contact forces are not
  // modelled yet. The coupling then stops the run (Cause::wall), and a case whose capsule
  // starts that close is refused.
  [[nodiscard]] double embedded_wall_reach(int k) const;
  [[nodiscard]] double embedded_wall_contact() const;
  // The fraction of stability_limit() that a solver-chosen dt uses (time.cfl > 0): the
  // measured limits hold for 150 steps; long runs and strong deformations need a margin.
  static constexpr double kSafety = 0.5;
  // The longest step time.coupling = "auto" takes explicitly. Its explicit steps (BDF2's
  // nodes with the forces at X*, this step's force in the viscous solve, the flow stepped by
  // BDF2) stay stable far above stability_limit(), which is the lag's with Euler's nodes:
  // 150 steps held at 9.5 to more than 64 times it over Re / Ca = 0.01 to 1000 (the least at
  // Re = 1, Ca = 0.1), and the seed case ran its 2500 steps at 6.1 times it. kAutoExplicit is
  // two thirds of the least. A capsule whose inside is less viscous than the fluid around it
  // folds an element sooner (viscosity ratios 0.05-0.2 at kAutoExplicit on the quick
  // relaxation; 0.01: stable at 2.8, folding at 3.4 times the limit), so with any ratio below
  // kThinInside the multiple is kAutoExplicitThinInside (docs/numerics.md, "The explicit steps
  // of auto"). With Euler's nodes (forces at X) it is kSafety, the explicit coupling's margin.
  [[nodiscard]] double auto_explicit_limit() const;
  static constexpr double kAutoExplicit = 6.3, kAutoExplicitThinInside = 2.0, kThinInside = 0.5;

 private:
  void compute_forces(int step);
  void spread_forces(int step);
  // The midpoint scheme's X* (place_midpoints) and J(X*) u^n, before the flow step.
  void place_midpoints();
  void predict_midpoint(int step);
  // boxes_[i] for the nodes at `x_of(i)` of each of `count` staggered capsules or ranges
  // (kernels_of(i) their kernels); timed as spreading.
  void find_boxes(std::size_t count, const std::function<Eigen::Ref<const Eigen::Matrix3Xd>(std::size_t)>& x_of,
                  const std::function<const KernelChoice&(std::size_t)>& kernels_of, const OwnedPositions& own);
  [[nodiscard]] const NodeBoxes* boxes(std::size_t i) const {
    return i < boxes_.size() && boxes_[i].nodes() > 0 ? &boxes_[i] : nullptr;
  }
  // The open fractions of the same nodes' stencils next to embedded walls, for the spreading
  // and the interpolation kernel (nullptr: none near a wall).
  [[nodiscard]] const WallWeights* spread_walls(std::size_t i) const {
    return i < spread_walls_.size() && spread_walls_[i].near_nodes() > 0 ? &spread_walls_[i] : nullptr;
  }
  [[nodiscard]] const WallWeights* interpolation_walls(std::size_t i) const {
    if (i < interpolation_walls_.size() && interpolation_walls_[i].near_nodes() > 0) return &interpolation_walls_[i];
    return same_kernel_walls_[i] ? spread_walls(i) : nullptr;
  }
  // Where the stages take forces and velocities: X, or X* with the midpoint and bdf2 schemes.
  [[nodiscard]] const Eigen::Matrix3Xd& stage_positions(const Capsule& c) const {
    return scheme_ == NodeScheme::midpoint || scheme_ == NodeScheme::bdf2 ? c.x_mid : c.x;
  }
  // BDF2 (implicit_coupling.cpp): whether this step is one (a step after one whose motion
  // every capsule holds), X* = X + dt V_last, and the weights of
  //   X(t + dt) = X(t) + dt (a V_last + b J u(t + dt)),  w = dt / dt_last,
  //   a = w / (1 + 2 w), b = (1 + w) / (1 + 2 w)      (Euler: a = 0, b = 1).
  struct Bdf2Weights {
    double a = 0.0, b = 1.0;
  };
  [[nodiscard]] Bdf2Weights bdf2_weights(double dt, double dt_last) const;
  // The node velocity of an Euler or BDF2 step whose interpolated velocity is v:
  // X(t + dt) = X + dt (a V_last + b v) (advance_nodes, and the implicit step's end check).
  [[nodiscard]] Eigen::Matrix3Xd step_motion(const Capsule& c, const Bdf2Weights& w, const Eigen::Matrix3Xd& v) const {
    if (!bdf2_step_) return v;
    return w.a * c.motion + w.b * v;
  }
  void place_bdf2_predictions();
  // What a failure's message names as its likely cause: the explicit coupling's instability
  // (when dt is above the measured limit; else a wall or a fold), a node out of the refined
  // band (instability, or a band that did not follow the membrane), or a wall.
  // The implicit coupling's solve that did not converge is its own cause.
  enum class Cause : unsigned char { instability, band, wall, implicit_solve };
  // Throws std::runtime_error naming the step, the time, `what` and the likely cause with the
  // keys that change it: one message a user can act on, with no internal name in it. Throws
  // fluid::StepTooLong (the same message) where a shorter step may succeed and nothing has
  // moved yet (shorter_may_help): the caller decides (app/run_case.cpp takes the step again
  // at half its length under time.tolerance, and stops otherwise).
  [[noreturn]] void fail(int step, const std::string& what, Cause cause = Cause::instability) const;
  // Between the forces and the interpolation (the flow restored, the nodes not moved), a
  // failure at positions the step's length sets: BDF2's extrapolated X* = X + dt V_last,
  // the implicit step's end (check_step_end), or the implicit solve itself.
  [[nodiscard]] bool shorter_may_help(Cause cause) const;
  // Between the forces and the interpolation, before the end check: the stages work at
  // BDF2's prediction X* = X + dt V_last.
  [[nodiscard]] bool at_prediction() const {
    return stage_open_ && !at_step_end_ && scheme_ == NodeScheme::bdf2 && bdf2_step_;
  }
  // Where the implicit step will leave capsule k's nodes, before they move: an element
  // folded, a node on an embedded wall or within the kernels' reach of the domain's side
  // there fails (shorter_may_help), where the step would otherwise stop the next one.
  void check_step_end(int step, int k, const Eigen::Matrix3Xd& end);
  [[noreturn]] void fail_stencil(int step, int k, const StencilError& e) const;
  [[nodiscard]] Capsule* owned(int i) const;
  // Embedded walls: fails (Cause::wall) when a node at `at` of capsule k touches one (comes
  // within embedded_wall_contact(); nothing without solids).
  void check_embedded_walls(int step, int k, const Eigen::Matrix3Xd& at) const;
  // Fails (Cause::wall) when a stencil of a node at `at` of capsule k would cross a
  // non-periodic side of the domain, where the next step's stages would fail.
  void check_brick_sides(int step, int k, const Eigen::Matrix3Xd& at) const;
  // Fails (Cause::wall) when a node of box set i (capsule k; node_of names its node in the
  // capsule) has no open face in its stencils: it is inside a solid.
  void require_open_faces(int step, int k, std::size_t i,
                          const std::function<std::int64_t(Eigen::Index)>& node_of) const;
  // V^(n-1) <- V and V <- J u(t + dt) for every owned capsule.
  void interpolate_velocities(int step);
  // J u of the current flow at the stage positions into velocity_of(c) of every owned
  // capsule (this step's boxes; on N ranks routed). Collective.
  void interpolate_into(int step, const std::function<Eigen::Matrix3Xd&(Capsule&)>& velocity_of);
  // X += dt (the scheme's motion) for every owned capsule, each new position checked first.
  void advance_nodes(int step, double dt, double previous_dt);

  // The force field no capsule spread into this step (cell-centred or face) is zero, sized to
  // the tree: the flow step reads both.
  void zero_unspread_forces();
  // The face velocity the midpoint predictor interpolates u^n from (start_faces_ when the
  // flow holds no projected faces).
  const fluid::FaceField<3>& start_face_velocity();
  // N ranks (capsule_distribution.cpp): the routed forms of the stages.
  void distributed_forces(int step);
  void distributed_spreading(int step);
  void migrate();  // owned capsules whose centroid left this rank's cells go to its owner
  [[nodiscard]] int owner_of(const Eigen::Matrix3Xd& x) const;
  [[nodiscard]] OwnedPositions owned_positions() const;
  // Every owned capsule's nodes at `at(c)` (with `with_forces` their forces) to the owners of
  // the cells within `reach(k)` max-level cells of them, or with `stencil_boxes` of their
  // spreading and interpolation stencils' box (NodeBoxes: the ranks that spread into their
  // own cells or interpolate, no others); the result is what this rank received. Collective.
  [[nodiscard]] RoutedNodes route(const std::function<const Eigen::Matrix3Xd&(const Capsule&)>& at, bool with_forces,
                                  const std::function<int(int)>& reach, bool stencil_boxes = false) const;
  [[nodiscard]] int stencil_reach(int k) const;
  [[nodiscard]] int band(int k) const;
  void spread_routed(int step);
  // The velocities from uf at the routed nodes, completed on the owners into velocity_of(c)
  // (taken at stage_positions). Collective.
  void interpolate_routed(int step, const fluid::FaceField<3>& uf,
                          const std::function<Eigen::Matrix3Xd&(Capsule&)>& velocity_of);
  // all_or_none over the run's ranks (one rank: f runs as it is).
  void collectively(const std::function<void()>& f) const;
  [[nodiscard]] bool any_rank(bool local) const;

  fluid::NavierStokes<3>& ns_;
  int margin_;
  std::vector<std::unique_ptr<Capsule>> capsules_;  // by id; null where another rank owns it
  std::vector<KernelChoice> kernels_;              // by id, every capsule
  std::vector<double> moduli_;                     // by id: the stability limit's effective modulus
  std::vector<InnerFluid> inner_;                  // by id, every capsule
  // By id, every capsule: its flat triangles (membrane::flat_triangles), shared by capsules
  // of one mesh, so that any rank can cut any capsule from its positions alone.
  std::vector<std::shared_ptr<const std::vector<std::array<int, 3>>>> surfaces_;
  double inside_seconds_ = 0.0;
  std::vector<double> inside_;  // per cell: sum_k I_k (inner_properties)
  // N ranks: the plan of the distributed tree (nullptr on one rank), the capsules' rebuilder,
  // the nodes routed for this step's stages, and the bands of every capsule near this rank's
  // cells (built from the nodes routed at the last update_region).
  const tree::DistributedForest<3>* forest_ = nullptr;
  ModelFactory factory_;
  RoutedNodes routed_;
  std::vector<MembraneTags> bands_;
  std::int64_t migrations_ = 0;
  Traffic traffic_;
  CellVector force_;
  fluid::FaceField<3> face_force_;
  // Which of the two the last spreading filled, so the flow reads it (on N ranks the face
  // force on every rank wherever a capsule spreads on faces: ghosts hold neighbours' sums).
  bool any_cells_ = false, any_faces_ = false;
  bool force_zero_ = false, face_force_zero_ = false;  // known to hold zeros only (zero_unspread_forces)
  SpreadWorkspace workspace_;
  // This step's stencil boxes (node_boxes.hpp): per capsule on one rank, per routed range on
  // N ranks; found once the stage positions are known, cleared at the step's end.
  std::vector<NodeBoxes> boxes_;
  std::vector<WallWeights> spread_walls_, interpolation_walls_;
  std::vector<std::uint8_t> same_kernel_walls_;  // the interpolation reads spread_walls_
  bool force_ready_ = false;
  std::int64_t steps_ = 0;
  std::int64_t since_adapt_ = 0;
  StageTimes times_;
  double face_seconds_ = 0.0;  // face-force time inside the last fluid step
  double last_dt_ = 0.0;       // of the last fluid step (0 before the first)
  NodeScheme scheme_ = NodeScheme::euler;
  std::vector<Eigen::Matrix3Xd> motion_;  // per capsule: the node velocity of stage 5
  fluid::FaceField<3> start_faces_;       // midpoint scheme: u^n on faces at the first step and after a restart
  fluid::NavierStokes<3>::FaceForce background_;
  ImplicitOptions implicit_;
  bool implicit_step_ = false;  // implicit(): this step's
  bool bdf2_step_ = false;      // this step is BDF2's (bdf2_weights)
  bool bdf2_last_ = false;      // the last step was (node_error)
  bool stage_open_ = false;     // from forces() to interpolation() (shorter_may_help)
  bool at_step_end_ = false;    // inside check_step_end
  // correct() left J u of the step's last flow in each capsule's response: the interpolation
  // stage takes it as V (the same bits) instead of interpolating again.
  bool end_velocity_ready_ = false;
  ImplicitStats implicit_stats_;
  double implicit_seconds_ = 0.0;  // inside correct(), besides its flow steps (see motion)
};

}  // namespace capsflow::ibm
