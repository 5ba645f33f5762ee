#pragma once
// Incompressible Navier-Stokes and unsteady Stokes on the adaptive tree: Basilisk's
// centered solver (Popinet 2003, 2009; src/navier-stokes/centered.h), dimensionless with
// rho = 1 and mu = 1/Re unless given:
//   du/dt + (u.grad)u = (1/rho) (-grad p + div(mu grad u)) + a,   div u = 0.
// Cell-centred velocity u and pressure p, face (MAC) velocity uf; one step is the sequence
//   stability   dt = min(dt_max, cfl h / |u|)                        (or fixed)
//   advection   uf = BCG prediction of u at t + dt/2 on faces, projected with pf (dt/2);
//               u -= dt div(u_face uf)                                (skipped for Stokes)
//   viscosity   (rho/dt)(u - u*) = div(mu grad u), implicit (backward Euler, or
//               Crank-Nicolson: the mean of div(mu grad) at u and u*), one Helmholtz
//               solve per component (around it u +- dt g: the solve sees full momentum)
//   acceleration uf = face average of u + dt a_face                    (a: body force / rho)
//   projection  div(alpha grad p) = div(uf)/dt, alpha = 1/rho; uf -= dt alpha grad p;
//               g = centred mean of (a - alpha grad p) on faces;  u += dt g
// A face body force that is a discrete gradient is balanced exactly by the pressure.
//
// Density and viscosity are the constants of FlowOptions unless set_properties gives cell
// fields (flow_properties.hpp: face means, the explicit transpose stress). Then mu and
// alpha = 1/rho are face arrays in every stage, the viscous stage solves
//   (rho/dt)(u - u*) = div(mu grad u) + T,  T = div(mu grad u^T) (explicit, from u^n),
// and the advection source is g + (1/rho)(div(mu grad u) + T). Without it the solver reads
// no coefficient array (the benchmarked constant path).
#include <algorithm>
#include <array>
#include <functional>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "fluid/embedded_geometry.hpp"
#include "fluid/faces.hpp"
#include "fluid/flow_boundary.hpp"
#include "fluid/flow_properties.hpp"
#include "fluid/multigrid/multigrid.hpp"
#include "fluid/multigrid/wall_flux.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

template <int D>
struct FlowOptions {
  double Re = 1.0;
  bool stokes = false;  // drop (u.grad)u: unsteady Stokes
  double density = 1.0;
  double viscosity = -1.0;  // mu; -1: 1/Re
  double dt = 1e-3;         // the step when cfl == 0, else the largest step
  double cfl = 0.0;         // 0: fixed dt
  bool limited_slopes = false;  // minmod slopes in the advection (else central, 2nd order)
  // Viscosity by Crank-Nicolson (second order in time) instead of backward Euler (first
  // order, L-stable: Basilisk's choice and the default).
  bool crank_nicolson = false;
  // The viscous solve sees u^n + dt g with g from this step's body force (and the last
  // pressure) instead of the last step's (Basilisk's lag): a force that changes every step
  // (immersed membranes) then drives u^(n+1) without a one-step delay (issue 17).
  bool current_force_in_viscous = false;
  // The acceleration stage starts from the last projected face velocity plus the face mean
  // of this step's change of the cell velocity (advection, viscosity), instead of the face
  // mean of the cell velocity: the difference of the two, dt (A C - I) of the face
  // acceleration, is then not applied one step late. With an immersed-boundary force (grid
  // scale) that lag made the coupled step first order in time (issue 17). Falls back to the
  // face mean after a restart, and after an adaptation on the faces whose cells changed
  // (face_velocity_carried()).
  bool carry_faces = false;
  // The unsteady term by BDF2 with a variable step (w = dt / dt_last):
  //   u(t + dt) = u^ + b dt R(u(t + dt)),  u^ = u^n + (w^2 / (1 + 2 w)) (u^n - u^(n-1)),
  //   b = (1 + w) / (1 + 2 w):
  // the stages of a backward-Euler step of length b dt from u^ (the first step, and the
  // first after a restart without u^(n-1), is backward Euler). u^(n-1) is kept as the tree
  // fields u.prev.*, carried by adapt and checkpoints. The faces then accelerate by the face
  // mean of the cells' acceleration g = C(a - alpha grad p^n), and the projection solves for
  // the pressure's increment (an incremental pressure correction on the collocated grid):
  // adding dt a to the faces, as the default does, leaves dt (I - A C) a in the face velocity
  // (A the face mean, C the cell mean), a first-order error for a grid-scale force; carrying
  // the faces instead (carry_faces) leaves its sum over the steps, which viscosity never
  // damps (the quick relaxation's D12 at t = 0.2 converged in dt to 0.226 against 0.249).
  // Second order in time for unsteady Stokes with a force at t + dt (the implicit capsule
  // coupling's, whose BDF2 node update takes the same weights, ibm::NodeScheme::bdf2); the
  // advection stays explicit, from u^ over b dt, first order. Needs
  // current_force_in_viscous; not with crank_nicolson or carry_faces.
  bool bdf2 = false;
  // BDF2 steps: at most this many GMRES iterations on the step's pressure, each a viscous
  // solve and a projection taken again (ns_pressure_iterations.cpp), so that the pressure is
  // consistent with the velocity. One projection from p^n (0, the default) lags at steps
  // above the flow's viscous times, rho / (mu k^2) for a mode of wavenumber k: there the
  // quick relaxation's D12 at t = 4 was off by 0.03 at dt = 0.5 (docs/numerics.md).
  int pressure_iterations = 0;
  std::array<SideFlow<D>, 2 * D> boundaries{};
  // Tolerances are dimensionless, as Basilisk's TOLERANCE: the projection stops when
  // max |div uf| dt <= tolerance (the relative volume change of a cell in one step), the
  // viscous solve when its residual in velocity units is <= tolerance. Each solve scales
  // them to the residual it sees (1/dt^2 and rho/dt; with set_properties, the smallest rho).
  MultigridOptions projection{.tolerance = 1e-3};
  MultigridOptions viscous{.tolerance = 1e-3};
};

// Throws std::invalid_argument naming the key for a non-positive Re, viscosity or density,
// a negative CFL or a non-positive dt.
template <int D>
void validate(const FlowOptions<D>& o);

struct [[nodiscard]] StepStats {
  double t = 0.0;   // after the step
  double dt = 0.0;
  int pressure_passes = 0;  // FlowOptions::pressure_iterations: viscous solves and projections taken again
  double pressure_residual = 0.0;  // and the increment they left, relative to the first one
  int projection_cycles = 0;
  int prediction_cycles = 0;
  int viscous_cycles = 0;
  bool converged = true;  // every solve reached its tolerance
  int unconverged = 0;    // solves that stopped at max_cycles above their tolerance
  int cycles() const { return projection_cycles + prediction_cycles + viscous_cycles; }
  void count_solve(bool solve_converged) {
    converged = converged && solve_converged;
    if (!solve_converged) ++unconverged;
  }
};

template <int D>
class NavierStokes {
 public:
  NavierStokes(tree::Tree<D>& tree, FlowOptions<D> options);

  tree::Tree<D>& tree() { return tree_; }
  const tree::Tree<D>& tree() const { return tree_; }
  const FlowOptions<D>& options() const { return options_; }
  // Scales the viscous and projection solves' tolerances (1: the options' own) for the steps
  // that follow. The implicit coupling's products take their flow steps looser
  // (implicit_coupling.cpp).
  void set_tolerance_scale(double scale);
  // FlowOptions::bdf2: the pressure increment the last step's projection added (per cell).
  std::span<const double> pressure_increment() const;
  const FlowConditions<D>& conditions() const { return conditions_; }
  double time() const { return time_; }
  void set_time(double t) { time_ = t; }
  // The length of the last step (0 before the first step of this object, also after a
  // restart): with time(), the interval the last step covered.
  double last_dt() const { return last_dt_; }
  // The next steps are at most `cap` long (to land on an output or final time).
  void limit_dt(double cap) { dt_cap_ = cap; }
  // FlowOptions::bdf2: the step u.prev.* holds the start of (0: none yet, the next step is
  // backward Euler). A checkpoint keeps it, so a restart takes the same BDF2 steps.
  double history_dt() const { return history_dt_; }
  void set_history_dt(double dt) { history_dt_ = dt; }

  tree::FieldId velocity(int d) const { return u_[d]; }
  tree::FieldId pressure() const { return p_; }
  std::span<double> u(int d) { return tree_.values(u_[d]); }
  std::span<double> p() { return tree_.values(p_); }
  const FaceField<D>& face_velocity() const { return uf_; }
  // Whether face_velocity() is the projected face velocity of the current u: true after a
  // step, false before the first one and after adapt() (which resets the faces).
  bool face_velocity_current() const { return faces_current_; }
  // After an adapt() that rebuilt the tree: face_velocity() holds the last projected face
  // velocity on every face whose two cells are the same leaves as before (a membrane band
  // at the max level keeps all of its faces), and the face mean of the cell velocity on
  // the others. Then the faces around a membrane are still discretely divergence-free
  // (issue 17: the midpoint node scheme's u^n after an adaptation). On N ranks the same
  // faces, carried through the migration.
  bool face_velocity_carried() const { return faces_carried_; }
  // The face velocity for a checkpoint (issue 17: a restarted run with the midpoint node
  // scheme or carry_faces must start from the same u^n faces as the uninterrupted one):
  // for each leaf by (level, Morton key), its lower then upper face along each axis
  // (2D values); empty when the faces are neither current nor carried. On N ranks this
  // rank's owned leaves (tree::owned_leaves_by_key), the rows the checkpoint writer places.
  std::vector<double> leaf_faces() const;
  // The leaves by (level, key), the order of leaf_faces().
  std::vector<std::pair<int, tree::Key>> leaf_order() const;
  // Restores what leaf_faces() gave, as current faces when `current`, else as carried ones:
  // the values of this rank's owned leaves in leaf_order(). Throws std::invalid_argument for a
  // size that is not 2D per leaf. Collective on N ranks.
  void restore_leaf_faces(std::span<const double> values, bool current);

  // Body force per unit volume on faces, filled by the caller before each step's
  // acceleration stage (IBM forces, gravity, a pressure drop). Zero when not set.
  using FaceForce = std::function<void(const tree::Tree<D>&, FaceField<D>& force)>;
  void set_face_force(FaceForce f) {
    face_force_ = std::move(f);
    if (!face_force_)
      for (auto& component : force_) std::fill(component.begin(), component.end(), 0.0);
  }

  // Density and viscosity as cell fields: `f` fills rho and mu (> 0) on the leaves this rank
  // owns (N ranks: the ghosts then take their owners' values); it is
  // called at the start of every step, after any adapt, so the properties may follow a
  // moving interface. They are tree fields "rho" and "mu" (registered by the first call)
  // that adapt() only resizes: nothing is carried, since f refills them. The constants of
  // FlowOptions are then not used.
  using Properties = std::function<void(const tree::Tree<D>&, std::span<double> rho, std::span<double> mu)>;
  void set_properties(Properties f);
  bool variable_properties() const { return static_cast<bool>(properties_); }
  // With set_properties: evaluates them now if the tree changed since they were last
  // evaluated (before the first step, after an adapt or a restart), so that a reader between
  // steps (the energy diagnostics) reads this tree's values. Collective on N ranks.
  void refresh_properties() {
    if (properties_ && properties_stale_) update_properties();
  }
  // The leaves' densities of this step (for a gravity force rho_f g, with the solver's
  // rho_f = the mean of the two cells).
  std::span<const double> density() const { return tree_.values(rho_field_); }
  // rho of leaf c and mu on the fine face (lo, hi) along d, as the last step used them:
  // the constants, or the cell field and its face mean (fluid/energy.hpp).
  double cell_density(Index c) const { return properties_ ? tree_.values(rho_field_)[c] : options_.density; }
  double face_viscosity(int d, Index lo, Index hi, const tree::Level<D>& lv) const {
    return properties_ ? face_coefficient<D>(lv, mu_faces_, d, lo, hi) : mu_;
  }
  // With set_properties: the viscosity field and its face means (2D per cell slot).
  tree::FieldId viscosity_field() const { return mu_field_; }
  const std::vector<double>& face_viscosities() const { return mu_faces_; }
  // With set_properties: the leaves (and levels) where a face viscosity differs from the
  // leaf's, where the transpose stress lives (varying_viscosity).
  const std::vector<std::pair<Index, int>>& varying_viscosity_leaves() const { return varying_; }
  // Embedded walls (issue "Walls of any shape"): the solid is no-slip fluid-free space. The
  // viscous and pressure operators take the fluid fractions and the walls' fluxes
  // (multigrid/wall_flux.hpp), the divergence is that of each cell's fluid part, faces
  // without fluid carry no velocity and cells without fluid none; the advection carries the
  // open parts' fluxes (ns_advection.cpp). Rebuilt by every adapt(). Constant properties and
  // no carry_faces for now (std::invalid_argument otherwise). Collective on N ranks.
  void set_solid(geometry::SolidPtr solid);
  // The embedded walls, or nullptr.
  const EmbeddedGeometry<D>* embedded() const { return embedded_.get(); }
  // Their flux stencils (the viscous operator's wall terms, for mu = 1), or nullptr.
  const WallFlux<D>* wall_flux() const { return wall_flux_.get(); }
  // Moving embedded walls (geometry::moving_wall): component d of the wall's velocity at the
  // wall centroid of each cut active cell (per cell slot), the no-slip value the viscous
  // solve imposes; empty when no wall moves.
  const std::array<std::vector<double>, D>& wall_velocity() const { return wall_velocity_; }
  // Component d of it at cut cell c (0 when no wall moves).
  double wall_velocity(int d, Index c) const {
    return wall_velocity_[d].empty() ? 0.0 : wall_velocity_[d][static_cast<std::size_t>(c)];
  }

  // The body force of the last step on faces, as the acceleration stage applied it (zero on
  // the faces of sides with a prescribed normal velocity, which carry the force).
  const FaceField<D>& face_force() const { return force_; }

  StepStats step();

  // What a step changes: the velocity, the pressure and its gradient, the faces and the
  // time. An implicit coupling takes several steps from one start (fluid/time_step.hpp);
  // restoring and stepping again repeats the step to the last bit. Only on the tree it was
  // saved on: restore_state throws std::invalid_argument when the cell count differs.
  struct State {
    std::vector<std::vector<double>> fields;
    FaceField<D> faces;
    double time = 0.0, last_dt = 0.0, history_dt = 0.0;
    bool faces_current = false, faces_carried = false;
  };
  [[nodiscard]] State save_state() const;
  void restore_state(const State& s);

  // Adapts the tree (velocity wavelets at `tolerance`, plus the options' forced levels),
  // carrying every field; returns the tree's counts. With relative > 0 the tolerance is
  // velocity_tolerance(tolerance, relative).
  tree::AdaptCounts adapt(double tolerance, tree::AdaptOptions<D> options, double relative = 0.0);
  // Refines the tree to required_level (Tree::refine_to: forced levels only), carrying every
  // field, and rebuilds what depends on the tree (the embedded walls) as adapt does.
  tree::AdaptCounts refine_to(const std::function<int(const tree::Box<D>&)>& required_level);
  // The wavelet tolerance of an adapt: min(tolerance, relative max|u|) for relative > 0, but
  // at least 1e-3 tolerance, so that round-off in a fluid at rest refines nothing. A fixed
  // tolerance lets the grid coarsen as a flow decays (a relaxing capsule: max|u| falls
  // 100x), until the coarse cells' errors are a large part of what is left of the flow.
  double velocity_tolerance(double tolerance, double relative) const;
  // max |u_d| over the leaves and components.
  double max_velocity_component() const;

  // The stages, public so tests can drive them one by one.
  double stable_dt() const;
  // With set_properties: evaluates rho and mu, their face values and the transpose stress
  // of the current velocity (boundary values at time()). The first stage of step().
  void update_properties();
  void prediction_and_advection(double dt, StepStats& stats);
  void viscosity(double dt, StepStats& stats);
  void acceleration(double dt);
  void projection(double dt, StepStats& stats);
  // viscosity, acceleration and projection; with FlowOptions::pressure_iterations, from the
  // pressure solved for first.
  void viscous_and_projection_stages(double dt, StepStats& stats);

  // max |div uf| over the leaves after the last projection.
  double max_divergence();
  // Whether velocity and pressure are finite on every leaf.
  bool leaves_finite() const;

 private:
  void resize_scratch();
  // After the tree changed: the scratch arrays, the faces (no longer projected ones) and the
  // embedded walls made again for the new cells.
  void tree_changed();
  void sync_velocity();
  int project(FaceField<D>& uf, tree::FieldId p, double dt, const MultigridOptions& opt, StepStats& stats);
  void face_average_of_velocity(FaceField<D>& uf);
  void carry_faces_through_adapt();  // uf_ from kept_faces_ after a rebuild
  // N ranks: each leaf's lower faces and a stamp of the leaf into tree fields before a
  // distributed adapt (they migrate with the leaves), and back into uf_ after it on the faces
  // whose two cells kept their stamps.
  void keep_faces_in_fields();
  void carry_faces_in_fields();
  // g = cell mean of alpha (force - grad p); u += dt g unless only_g.
  void centred_gradient(double dt, bool only_g = false);
  void evaluate_force();
  // Whether the face between lo and hi lies on a side whose normal velocity is prescribed
  // (wall, moving wall, inflow: the pressure's homogeneous Neumann sides).
  bool normal_velocity_prescribed(Index lo, Index hi, const tree::Level<D>& lv) const;
  void shift_by_g(int d, double s);  // u_d += s g_d on the leaves
  MultigridStats variable_viscous_solve(int d, double dt, double theta);
  // Crank-Nicolson's explicit half of the divided viscous equation: rhs -= (1 - theta)/theta
  // op(u^n) on the leaves, op the viscous operator without lambda, u^n = u* - dt g and the
  // sides' values at t^n.
  template <class Op>
  void subtract_explicit_half(int d, double dt, double theta, const Op& op) {
    std::span<double> u = tree_.values(u_[d]);
    const double t_new = boundary_time_;
    boundary_time_ = time_;
    shift_by_g(d, -dt);  // u^n
    tree_.sync(u, conditions_.velocity[d], tree::Prolongation::quadratic);
    op.apply_leaves(u, div_);
    shift_by_g(d, dt);
    const double w = (1.0 - theta) / theta;
    tree_.for_each_leaf([&](Index c) { rhs_[c] -= w * div_[c]; });
    boundary_time_ = t_new;
  }
  // The viscous solve's first guess for component d: u* = u^ + dt g (the right-hand side's
  // velocity, near the solution while viscosity moves little in a step) or u^ (near it once
  // the viscous time at the force's scale is short against the step, which then damps a
  // grid-scale dt g away). The one with the smaller residual (docs/numerics.md: a third to
  // a half of the cycles at long steps).
  template <class Op>
  void choose_viscous_guess(int d, double dt, const Op& op) {
    std::span<double> u = tree_.values(u_[d]);
    const std::span<const double> g = tree_.values(g_[d]);
    const double from_star = residual_max(op, u, rhs_, mg_);
    tree_.for_each_owned_leaf([&](Index c) { u[c] -= dt * g[c]; });
    if (residual_max(op, u, rhs_, mg_) < from_star) return;
    tree_.for_each_owned_leaf([&](Index c) { u[c] += dt * g[c]; });
  }
  // Embedded walls (ns_embedded.cpp): the geometry and its operators after the tree changed;
  // the viscous solve of component d; the projection's solve and face update; the cell mean
  // of the face accelerations (open faces only).
  void rebuild_embedded();
  // The fluid fractions of the faces with embedded walls (the weights of restrict_faces), or nullptr.
  const FaceField<D>* open_faces() const { return embedded_ ? &embedded_->faces() : nullptr; }
  MultigridStats embedded_viscous_solve(int d, double dt, double theta);
  // BDF2 with flow properties: the explicit transpose stress at the extrapolated velocity
  // u_e = u^n + w (u^n - u^(n-1)) is stable only while it stays below a third of the implicit
  // stress (the extrapolation's bound), and where the viscosity jumps it reaches the whole
  // of it (lambda = 0.01 and 100 blew up, 0.2 and 5 rang for tens of steps). So on the band
  // where mu varies the solves take sigma div(mu grad u) implicitly and at u_e explicitly:
  // second order still, and the explicit share in bounds. A scalar model asks sigma >= 1/2;
  // at lambda = 100 sigma = 1 still left an even-odd oscillation of the band, 3 none.
  // Backward Euler and Crank-Nicolson take it at u^n and need the same: the seed case at its
  // dt = 1e-3 rang at lambda = 5 (max |u| 5.3 to 13.9 and back) and blew up at 100 without
  // it, and at sigma = 1 still blew up at 100 (AppCapsule.ViscousInnerFluidIsStableAtTheSeedStep).
  static constexpr double kTransposeStabilisation = 3.0;
  void stabilise_band(double h);  // after update_properties, h the stages' step: the stabilised_* arrays
  void hold_transpose_velocity();  // without BDF2: transpose_velocity_ = u^n
  // With a density that varies (update_properties): the projection's face coefficients and
  // the viscous cell term's densities.
  void embedded_density();
  MultigridStats embedded_projection(FaceField<D>& uf, std::span<double> p, double dt, const MultigridOptions& opt);
  // The advection's source g + (mu/rho) lap u_d with embedded walls, on the owned leaves.
  void embedded_viscous_source(int d, std::span<const double> u, std::span<const double> g, std::vector<double>& src);
  // The least fluid fraction the advection divides a cell's balance by (ns_advection.cpp).
  static constexpr double kSmallCell = 0.5;
  template <class Body>
  void with_inverse_density(Body&& body) const;

  tree::Tree<D>& tree_;
  FlowOptions<D> options_;
  double viscous_tolerance_ = 0.0, projection_tolerance_ = 0.0;  // the options' own (set_tolerance_scale)
  FlowConditions<D> conditions_;
  tree::BoundaryConditions<D> zero_gradient_;
  double time_ = 0.0;
  double last_dt_ = 0.0;  // last_dt()
  double boundary_time_ = 0.0;
  double dt_cap_ = 1e300;  // the time boundary conditions are evaluated at
  double mu_ = 1.0;
  std::array<tree::FieldId, D> u_{}, g_{};
  std::array<tree::FieldId, D> u_prev_{};  // FlowOptions::bdf2: u^(n-1)
  tree::FieldId dp_ = -1;                  // FlowOptions::bdf2: the projection's pressure increment
  double history_dt_ = 0.0;                // history_dt()
  // FlowOptions::bdf2: u <- u^ and u.prev <- u^n on the owned leaves; returns b dt (dt
  // without a history). With flow properties and a history it also fills
  // transpose_velocity_ (synced).
  double extrapolate_start(double dt);
  tree::FieldId p_ = 0, pf_ = 0;
  FaceField<D> uf_, force_, scratch_faces_;
  // carry_faces: the projected faces and the cell velocity at the start of the step.
  FaceField<D> carried_faces_;
  std::array<std::vector<double>, D> start_velocity_;
  bool carrying_ = false;
  // The advection's (not allocated for Stokes flow): slope_[c][d] = du_c/dx_d, and the
  // fluxes of u_1..u_(D-1) (u_0's go to scratch_faces_).
  std::array<std::array<std::vector<double>, D>, D> slope_;
  std::array<FaceField<D>, D - 1> fluxes_;
  std::array<std::vector<double>, D> source_;  // advection sources g + nu lap u
  std::vector<double> div_, rhs_;
  FaceForce face_force_;
  // When set, evaluate_force copies it instead of calling face_force_: the pressure
  // iterations' passes take the step's force again without spreading it again.
  const FaceField<D>* fixed_force_ = nullptr;
  MultigridWorkspace mg_;
  // Variable properties (empty unless set_properties was called).
  Properties properties_;
  bool properties_stale_ = true;  // the tree changed since update_properties
  tree::FieldId rho_field_ = -1, mu_field_ = -1;
  std::vector<double> alpha_faces_, mu_faces_;  // 1/rho and mu, 2D per cell slot
  std::vector<double> lambda_;                  // -rho/(theta dt) of the viscous solve
  std::array<std::vector<double>, D> transpose_;  // T per component
  // The velocity the explicit transpose stress and its stabilisation take: with
  // FlowOptions::bdf2 and a history u^n + w (u^n - u^(n-1)) (extrapolate_start fills and
  // syncs it), without BDF2 u^n (hold_transpose_velocity); step() empties it at its end.
  std::array<std::vector<double>, D> transpose_velocity_;
  // The stabilisation of the explicit transpose stress (stabilise_band): the viscous
  // solves take mu_s = (1 + sigma) mu on the band's leaves implicitly and the difference
  // div((mu_s - mu) grad u) at transpose_velocity_ explicitly. Face means of mu_s, their
  // difference with mu_faces_, the cells every face of which has mu_, mu_s per cell slot;
  // with embedded walls the fractions times both, those cells also open, and mu_s restricted
  // onto the parents with its difference with cell_mu_.
  bool stabilised_ = false;  // this step's viscous solves take them
  std::vector<double> stabilised_mu_faces_, stabilising_faces_;
  std::vector<double> embedded_stabilised_faces_, embedded_stabilising_faces_, stabilised_cell_mu_, stabilising_cell_mu_;
  std::vector<std::uint8_t> stabilised_uniform_, embedded_stabilised_uniform_;
  std::vector<std::pair<Index, int>> stabilising_leaves_;  // with a stabilising face, and their levels
  double rho_min_ = 1.0;                        // scales the viscous tolerance
  double nu_max_ = 1.0;                         // the largest mu / rho: the shortest viscous times
  bool uniform_density_ = false;                // variable viscosity only
  std::vector<std::pair<Index, int>> varying_;  // the leaves where mu varies (varying_viscosity)
  std::vector<std::uint8_t> mu_uniform_;        // per cell slot: every face at the constant mu_
  // Embedded walls (empty without): the geometry, its wall stencils, and the operators'
  // coefficients (2D per cell slot for faces, one per cell).
  geometry::SolidPtr solid_;
  std::unique_ptr<EmbeddedGeometry<D>> embedded_;
  std::unique_ptr<WallFlux<D>> wall_flux_;
  tree::InjectedHalos injected_halos_;  // the solves' (EmbeddedFaces::injected)
  std::vector<double> pressure_faces_, pressure_pins_, viscous_faces_, viscous_cells_;
  double viscous_lambda_ = 0.0;  // the lambda viscous_cells_ was made for
  // Embedded walls with a viscosity that varies (update_properties): the fractions times the
  // face viscosities, the cells uniform in both, and mu per cell slot (parents: the mean).
  std::vector<double> embedded_mu_faces_, cell_mu_;
  std::vector<std::uint8_t> embedded_mu_uniform_;  // with a density that varies: also rho = density there
  // Embedded walls with a density that varies (update_properties): the fractions times the
  // faces' 1/rho and the cells open and at 1/density on every face (the projection's), and
  // rho / density per cell slot (parents: the mean), which scales the viscous cell term.
  std::vector<double> embedded_alpha_faces_, relative_density_;
  std::vector<std::uint8_t> embedded_alpha_uniform_;
  bool viscous_cells_scaled_ = false;  // viscous_cells_ carry relative_density_
  // The embedded viscous operator's face coefficients, uniform cells and wall terms: the
  // constant viscosity's, or the varying one's.
  struct EmbeddedViscous {
    const double* faces;
    const std::uint8_t* uniform;
    WallTerms<D> walls;  // walls.at(c): the cut cell's viscosity
  };
  EmbeddedViscous embedded_viscous() const;
  std::array<std::vector<double>, D> wall_velocity_;  // wall_velocity()
  bool faces_current_ = false;                  // face_velocity_current()
  bool faces_carried_ = false;                  // face_velocity_carried()
  FaceField<D> kept_faces_;                     // adapt(): uf_ of the tree before
  std::vector<std::uint8_t> old_leaf_;          // adapt(): whether each old cell was a leaf
  std::array<tree::FieldId, D + 1> kept_fields_ = [] {  // N ranks: the faces and the stamp
    std::array<tree::FieldId, D + 1> f;
    f.fill(-1);
    return f;
  }();
};

extern template class NavierStokes<2>;
extern template class NavierStokes<3>;

}  // namespace capsflow::fluid
