// The time step of the centered Navier-Stokes solver: stability, viscosity, acceleration,
// projection (the advection stage is in ns_advection.cpp). See navier_stokes.hpp.
#include "fluid/navier_stokes.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <fmt/format.h>

#include "fluid/flow_properties.hpp"
#include "fluid/multigrid/elliptic_operator.hpp"
#include "parallel/sparse_exchange.hpp"
#include "tree/distributed_forest.hpp"
#include "tree/leaf_order.hpp"

namespace capsflow::fluid {

template <int D>
void validate(const FlowOptions<D>& o) {
  auto positive = [](double v, const char* key) {
    if (!(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument(fmt::format("{} = {}: must be > 0", key, v));
  };
  positive(o.Re, "fluid.Re");
  positive(o.density, "fluid.density");
  if (o.viscosity != -1.0) positive(o.viscosity, "fluid.viscosity");
  positive(o.dt, "time.dt");
  if (o.pressure_iterations < 0)
    throw std::invalid_argument(fmt::format("fluid.pressure_iterations = {}: must be >= 0", o.pressure_iterations));
  if (o.pressure_iterations > 0 && !o.bdf2)
    throw std::invalid_argument(fmt::format(
        "fluid.pressure_iterations = {}: the pressure is iterated in BDF2 steps only (time.node_scheme = \"bdf2\"), "
        "whose projection adds an increment to p^n",
        o.pressure_iterations));
  if (o.bdf2 && (o.crank_nicolson || o.carry_faces || !o.current_force_in_viscous))
    throw std::invalid_argument(
        "the flow's BDF2 steps (time.node_scheme = \"bdf2\") take this step's force in the viscous solve, and "
        "neither fluid.crank_nicolson nor fluid.carry_faces");
  if (!(o.cfl >= 0.0)) throw std::invalid_argument(fmt::format("time.cfl = {}: must be >= 0", o.cfl));
}

template <int D>
NavierStokes<D>::NavierStokes(tree::Tree<D>& tree, FlowOptions<D> options)
    : tree_(tree), options_(std::move(options)) {
  validate(options_);
  viscous_tolerance_ = options_.viscous.tolerance;
  projection_tolerance_ = options_.projection.tolerance;
  conditions_ = make_flow_conditions<D>(options_.boundaries, tree_.options(), &boundary_time_);
  mu_ = options_.viscosity == -1.0 ? 1.0 / options_.Re : options_.viscosity;
  zero_gradient_ = tree::BoundaryConditions<D>::all(tree::BcKind::neumann);
  static const char* kAxis[] = {"x", "y", "z"};
  for (int d = 0; d < D; ++d)
    u_[d] = tree_.add_field({.name = fmt::format("u.{}", kAxis[d]), .bc = conditions_.velocity[d]});
  p_ = tree_.add_field({.name = "p", .bc = conditions_.pressure});
  pf_ = tree_.add_field({.name = "pf", .bc = conditions_.pressure});
  for (int d = 0; d < D; ++d)
    g_[d] = tree_.add_field({.name = fmt::format("g.{}", kAxis[d]), .bc = zero_gradient_});
  if (options_.bdf2) {
    for (int d = 0; d < D; ++d)
      u_prev_[d] = tree_.add_field({.name = fmt::format("u.prev.{}", kAxis[d]), .bc = conditions_.velocity[d]});
    dp_ = tree_.add_field({.name = "dp", .bc = conditions_.pressure, .saved = false});
  }
  resize_scratch();
}

template <int D>
void NavierStokes<D>::set_tolerance_scale(double scale) {
  if (!(scale >= 1.0 && std::isfinite(scale)))
    throw std::invalid_argument(fmt::format("NavierStokes::set_tolerance_scale: {} is not a finite scale >= 1", scale));
  options_.viscous.tolerance = scale * viscous_tolerance_;
  options_.projection.tolerance = scale * projection_tolerance_;
}

template <int D>
std::span<const double> NavierStokes<D>::pressure_increment() const {
  if (!options_.bdf2) throw std::logic_error("NavierStokes::pressure_increment: only BDF2 steps project an increment");
  return tree_.values(dp_);
}

template <int D>
double NavierStokes<D>::extrapolate_start(double dt) {
  const bool history = history_dt_ > 0.0;
  const double w = history ? dt / history_dt_ : 0.0;
  const double c = w * w / (1.0 + 2.0 * w);
  // The transpose stress is explicit: at u^n + w (u^n - u^(n-1)), the extrapolation to
  // t^(n+1) where the step's implicit terms are, it keeps the step second order (at u^n
  // or u^ it is first order: TimeOrder.ImplicitBdf2WithAnInnerFluid).
  const bool extrapolate_transpose = properties_ && history;
  for (int d = 0; d < D; ++d) {
    const std::span<double> u = tree_.values(u_[d]);
    const std::span<double> prev = tree_.values(u_prev_[d]);
    std::vector<double>& next = transpose_velocity_[d];
    if (extrapolate_transpose) next.assign(u.size(), 0.0);
    else next.clear();
    tree_.for_each_owned_leaf([&](Index i) {
      const double now = u[i];
      if (extrapolate_transpose) next[i] = now + w * (now - prev[i]);
      if (history) u[i] = now + c * (now - prev[i]);
      prev[i] = now;
    });
  }
  if (extrapolate_transpose) {  // synced as a velocity at t^(n+1): the walls then
    const double start = boundary_time_;
    boundary_time_ = time_ + dt;
    for (int d = 0; d < D; ++d)
      tree_.sync(transpose_velocity_[d], conditions_.velocity[d], tree::Prolongation::quadratic);
    boundary_time_ = start;
  }
  history_dt_ = dt;
  return history ? dt * (1.0 + w) / (1.0 + 2.0 * w) : dt;
}

// Backward Euler and Crank-Nicolson: the explicit transpose stress at u^n, held (synced at
// t^n) for the band's stabilisation as BDF2 holds its extrapolation (stabilise_band).
template <int D>
void NavierStokes<D>::hold_transpose_velocity() {
  for (int d = 0; d < D; ++d) {
    const std::span<double> u = tree_.values(u_[d]);
    tree_.sync(u, conditions_.velocity[d], tree::Prolongation::quadratic);
    transpose_velocity_[d].assign(u.begin(), u.end());
  }
}

template <int D>
void NavierStokes<D>::resize_scratch() {
  const auto n = static_cast<std::size_t>(tree_.num_cells());
  for (auto* f : {&uf_, &force_, &scratch_faces_}) resize<D>(*f, tree_);
  if (!options_.stokes) {
    for (auto& component : slope_)
      for (auto& s : component) s.assign(n, 0.0);
    for (auto& f : fluxes_) resize<D>(f, tree_);
  }
  for (auto& s : source_) s.assign(n, 0.0);
  div_.assign(n, 0.0);
  rhs_.assign(n, 0.0);
  properties_stale_ = true;
  if (properties_) {
    lambda_.assign(n, 0.0);
    for (auto& s : transpose_) s.assign(n, 0.0);
  }
}


template <int D>
std::vector<double> NavierStokes<D>::leaf_faces() const {
  if (!(faces_current_ || faces_carried_)) return {};  // the same on every rank
  std::vector<double> out;
  out.reserve(tree_.owned_leaves().size() * 2 * D);
  for (const Index c : tree::owned_leaves_by_key(tree_)) {
    const Index* row = tree_.level(tree_.level_of(c)).face_row(c);
    for (int d = 0; d < D; ++d) {
      out.push_back(uf_[d][c]);
      out.push_back(uf_[d][row[2 * d + 1]]);
    }
  }
  return out;
}

template <int D>
std::vector<std::pair<int, tree::Key>> NavierStokes<D>::leaf_order() const {
  std::vector<std::pair<int, tree::Key>> order;
  for (const Index c : tree::owned_leaves_by_key(tree_)) {
    const int l = tree_.level_of(c);
    order.emplace_back(l, tree_.level(l).keys[static_cast<std::size_t>(c - tree_.level(l).base)]);
  }
  return order;
}

template <int D>
void NavierStokes<D>::restore_leaf_faces(std::span<const double> values, bool current) {
  const std::vector<Index> leaves = tree::owned_leaves_by_key(tree_);  // leaf_order()
  if (values.size() != leaves.size() * 2 * D)
    throw std::invalid_argument(fmt::format("face velocity: {} values for {} leaves (2D per leaf expected)",
                                            values.size(), leaves.size()));
  resize_scratch();
  std::size_t k = 0;
  for (const Index c : leaves) {
    const Index* row = tree_.level(tree_.level_of(c)).face_row(c);
    for (int d = 0; d < D; ++d) {
      uf_[d][c] = values[k++];
      uf_[d][row[2 * d + 1]] = values[k++];
    }
  }
  tree_.update_ghosts(components<D>(uf_));  // the ghosts' faces from their owners
  faces_current_ = current;
  faces_carried_ = !current;
}

// Calls body(alpha, faces) with alpha(d, lo, hi, level) the value of 1/rho on a fine face
// and `faces` the same as the elliptic operator's coefficient type: the constant
// (ConstantFaces) or the face array (FaceArray). Two instantiations of body, so the
// constant path reads no array.
template <int D>
template <class Body>
void NavierStokes<D>::with_inverse_density(Body&& body) const {
  if (properties_ && !uniform_density_) {
    const std::vector<double>& a = alpha_faces_;
    auto alpha = [&a](int d, Index lo, Index hi, const tree::Level<D>& lv) {
      return face_coefficient<D>(lv, a, d, lo, hi);
    };
    body(alpha, FaceArray<D>{a.data()});
  } else {
    const double inv_rho = 1.0 / (properties_ ? rho_min_ : options_.density);
    body([inv_rho](int, Index, Index, const tree::Level<D>&) { return inv_rho; }, ConstantFaces{inv_rho});
  }
}

template <int D>
void NavierStokes<D>::sync_velocity() {
  tree_.sync(u_);  // the D components together (one message per level and neighbour rank)
}

template <int D>
double NavierStokes<D>::stable_dt() const {
  double dt = std::min(options_.dt, dt_cap_);
  if (options_.cfl == 0.0) return dt;
  // From the cell velocities (a checkpointed field), so a restarted run repeats the steps.
  double fastest = 0.0;  // max |u_d| / h over the (owned) leaves
  for (int l = 0; l <= tree_.depth(); ++l) {
    const tree::Level<D>& lv = tree_.level(l);
    const double inv_h = 1.0 / tree_.cell_size(l);
#pragma omp parallel for schedule(static) reduction(max : fastest) if (lv.n_active > tree::kParallelMin)
    for (Index i = 0; i < lv.n_active; ++i) {
      if (!lv.leaf[i] || !tree_.owns(lv.base + i)) continue;
      for (int d = 0; d < D; ++d) fastest = std::max(fastest, std::abs(tree_.values(u_[d])[lv.base + i]) * inv_h);
    }
  }
  fastest = tree_.global_max(fastest);
  return fastest > 0.0 ? std::min(dt, options_.cfl / fastest) : dt;
}

template <int D>
StepStats NavierStokes<D>::step() {
  if (uf_[0].size() != static_cast<std::size_t>(tree_.num_cells())) resize_scratch();
  // A step starts from a finite flow: a run stops at the first non-finite velocity (the
  // app and the IBM coupling check after every step), so a NaN here is a caller that kept
  // stepping a blown-up flow, or a bug that wrote one between steps (an adapt, a restart).
  CAPSFLOW_ASSERT(leaves_finite(), "NavierStokes::step: the velocity or pressure entering the step is not finite");
  StepStats stats;
  const double dt = stable_dt();
  // The stages' step: dt, or BDF2's b dt from the extrapolated start.
  const double h = options_.bdf2 ? extrapolate_start(dt) : dt;
  // Stages that read u^n see boundary values at t^n; the implicit ones solve for t^n+1.
  boundary_time_ = time_;
  carrying_ = options_.carry_faces && (faces_current_ || faces_carried_);
  if (carrying_) {
    carried_faces_ = uf_;
    for (int d = 0; d < D; ++d) {
      const std::span<const double> u = tree_.values(u_[d]);
      start_velocity_[d].assign(u.begin(), u.end());
    }
  }
  if (properties_) {
    if (!options_.bdf2) hold_transpose_velocity();
    update_properties();
    stabilise_band(h);
  }
  if (!options_.stokes) prediction_and_advection(h, stats);
  boundary_time_ = time_ + dt;
  if (options_.current_force_in_viscous && face_force_) {
    // The pressure's halos as the last solve left them (quadratic): after an adapt or a
    // restart they are the transfer's, and a restarted run would depart from the
    // uninterrupted one (issue 17). Restores what the solve wrote, so otherwise a no-op.
    tree_.sync(tree_.values(p_), conditions_.pressure, tree::Prolongation::quadratic);
    evaluate_force();
    centred_gradient(h, /*only_g=*/true);
  }
  viscous_and_projection_stages(h, stats);
  for (auto& v : transpose_velocity_) v.clear();  // this step's: an adapt may follow
  time_ += dt;
  last_dt_ = dt;
  stats.t = time_;
  stats.dt = dt;
  return stats;
}

template <int D>
typename NavierStokes<D>::State NavierStokes<D>::save_state() const {
  State s;
  for (int d = 0; d < D; ++d)
    for (const tree::FieldId f : {u_[d], g_[d]}) s.fields.emplace_back(tree_.values(f).begin(), tree_.values(f).end());
  for (const tree::FieldId f : {p_, pf_}) s.fields.emplace_back(tree_.values(f).begin(), tree_.values(f).end());
  if (options_.bdf2)
    for (int d = 0; d < D; ++d) s.fields.emplace_back(tree_.values(u_prev_[d]).begin(), tree_.values(u_prev_[d]).end());
  s.faces = uf_;
  s.time = time_;
  s.last_dt = last_dt_;
  s.history_dt = history_dt_;
  s.faces_current = faces_current_;
  s.faces_carried = faces_carried_;
  return s;
}

template <int D>
void NavierStokes<D>::restore_state(const State& s) {
  const auto cells = static_cast<std::size_t>(tree_.num_cells());
  if (s.fields.size() != (options_.bdf2 ? 3 * D + 2 : 2 * D + 2) || s.fields[0].size() != cells)
    throw std::invalid_argument("NavierStokes::restore_state: the state was saved on another tree");
  std::size_t k = 0;
  const auto put = [&](tree::FieldId f) {
    const std::vector<double>& v = s.fields[k++];
    std::copy(v.begin(), v.end(), tree_.values(f).begin());
  };
  for (int d = 0; d < D; ++d) {
    put(u_[d]);
    put(g_[d]);
  }
  put(p_);
  put(pf_);
  if (options_.bdf2)
    for (int d = 0; d < D; ++d) put(u_prev_[d]);
  uf_ = s.faces;
  time_ = s.time;
  last_dt_ = s.last_dt;
  history_dt_ = s.history_dt;
  faces_current_ = s.faces_current;
  faces_carried_ = s.faces_carried;
}

template <int D>
void NavierStokes<D>::viscosity(double dt, StepStats& stats) {
  // u* + dt g carries the previous pressure gradient and acceleration through the
  // implicit solve; they are taken out again after it (Basilisk's correction(+-dt)).
  // Owned leaves only: the solve's first sync brings the ghosts' u* from their owners, and
  // the face mean after it (sync_velocity) their corrected u.
  auto correct = [&](double sign) {
    tree_.for_each_owned_leaf([&](Index c) {
      for (int d = 0; d < D; ++d) tree_.values(u_[d])[c] += sign * dt * tree_.values(g_[d])[c];
    });
  };
  correct(1.0);
  const double lambda = -options_.density / dt;
  const double theta = options_.crank_nicolson ? 0.5 : 1.0;  // implicit share
  for (int d = 0; d < D; ++d) {
    if (properties_ || embedded_) {
      const auto s = embedded_ ? embedded_viscous_solve(d, dt, theta) : variable_viscous_solve(d, dt, theta);
      stats.viscous_cycles += s.cycles;
      stats.count_solve(s.converged);
      continue;
    }
    std::span<double> u = tree_.values(u_[d]);
    tree_.for_each_owned_leaf([&](Index c) { rhs_[c] = lambda * u[c]; });  // a ghost's residual is its owner's
    if (theta < 1.0) {  // explicit half: rhs -= (1 - theta) div(mu grad u^n), walls at t^n
      const double t_new = boundary_time_;
      boundary_time_ = time_;
      EllipticOperator<D> explicit_part(tree_, {(1.0 - theta) * mu_}, {}, conditions_.velocity[d]);
      shift_by_g(d, -dt);  // u^n
      tree_.sync(u, conditions_.velocity[d], tree::Prolongation::quadratic);
      explicit_part.apply_leaves(u, div_);
      shift_by_g(d, dt);
      tree_.for_each_leaf([&](Index c) { rhs_[c] -= div_[c]; });
      boundary_time_ = t_new;
    }
    EllipticOperator<D, ConstantFaces, ConstantCells> op(tree_, {theta * mu_}, {lambda}, conditions_.velocity[d]);
    MultigridOptions opt = options_.viscous;
    opt.tolerance *= options_.density / dt;  // residual of (rho/dt) u - div(mu grad u)
    choose_viscous_guess(d, dt, op);
    const auto s = solve(op, u, rhs_, mg_, opt);
    stats.viscous_cycles += s.cycles;
    stats.count_solve(s.converged);
  }
  correct(-1.0);
}

// Component d of u is u* = u^n + dt g during the viscous solve; shift_by_g(d, -dt) makes it
// u^n and shift_by_g(d, dt) u* again. Crank-Nicolson's explicit half must act on u^n: on u*
// it adds dt (1 - theta) div(mu grad g) to every step, a first-order error wherever a body
// force or pressure gradient varies (the coupled IBM step stayed first order, issue 17).
template <int D>
void NavierStokes<D>::shift_by_g(int d, double s) {
  std::span<double> u = tree_.values(u_[d]);
  const std::span<const double> g = tree_.values(g_[d]);
  tree_.for_each_leaf([&](Index c) { u[c] += s * g[c]; });
}

template <int D>
void NavierStokes<D>::face_average_of_velocity(FaceField<D>& uf) {
  sync_velocity();
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double, const tree::Level<D>&) {
    const std::span<const double> u = tree_.values(u_[d]);
    uf[d][hi] = 0.5 * (u[lo] + u[hi]);
  });
}

template <int D>
void NavierStokes<D>::evaluate_force() {
  // Without a callback the field stays zero (resize_scratch and set_face_force zero it, the
  // acceleration writes zeros only): no fill of D x num_cells values every step.
  if (!face_force_) return;
  if (fixed_force_) {
    force_ = *fixed_force_;
    return;
  }
  for (auto& f : force_) std::fill(f.begin(), f.end(), 0.0);
  face_force_(tree_, force_);
  // On a side where the normal velocity is prescribed (wall, moving wall, inflow) the wall
  // carries the normal force: zero there, for every stage that reads it (the faces'
  // acceleration, and g = C(force - grad p) before the viscous solve and after the projection,
  // which must agree: otherwise u = u' + dt (g_after - g_before) keeps dt times the force on
  // the cells beside such a side).
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double, const tree::Level<D>& lv) {
    if (normal_velocity_prescribed(lo, hi, lv)) force_[d][hi] = 0.0;
  });
}

template <int D>
bool NavierStokes<D>::normal_velocity_prescribed(Index lo, Index hi, const tree::Level<D>& lv) const {
  const Index outside = std::max(lo, hi);
  return outside >= lv.boundary_begin() &&
         conditions_.pressure.side[lv.boundary_side[outside - lv.boundary_begin()]].kind == tree::BcKind::neumann;
}

template <int D>
void NavierStokes<D>::acceleration(double dt) {
  evaluate_force();
  // The force enters the face velocities unchecked: a NaN would surface as a NaN pressure
  // after the projection, far from its cause. (The IBM coupling checks its nodal forces.)
  CAPSFLOW_ASSERT(spans_cells<D>(force_, tree_), "NavierStokes: the face force callback resized the force field");
  CAPSFLOW_ASSERT(std::ranges::all_of(force_, [](const auto& f) { return std::ranges::all_of(f, [](double v) { return std::isfinite(v); }); }),
                  "NavierStokes: the body force is not finite on every face");
  face_average_of_velocity(uf_);
  if (carrying_) {  // uf = carried + A(u' - u^n), u' the velocity after viscosity
    const double t_new = boundary_time_;
    boundary_time_ = time_;  // the start velocity's walls
    for (int d = 0; d < D; ++d) tree_.sync(start_velocity_[d], conditions_.velocity[d]);
    boundary_time_ = t_new;
    for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double, const tree::Level<D>&) {
      uf_[d][hi] += carried_faces_[d][hi] - 0.5 * (start_velocity_[d][lo] + start_velocity_[d][hi]);
    });
  }
  // BDF2: the faces take the face mean of g, whose halos (coarse-fine and the domain's sides)
  // must be this step's.
  if (options_.bdf2) tree_.sync(g_);
  std::array<std::span<const double>, D> g;
  for (int d = 0; d < D; ++d) g[d] = tree_.values(g_[d]);
  with_inverse_density([&](auto alpha, auto) {
    for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double, const tree::Level<D>& lv) {
      // On a side where the normal velocity is prescribed (wall, moving wall, inflow) no
      // acceleration (evaluate_force zeroed the force there): the face keeps its prescribed
      // velocity and the homogeneous Neumann pressure balances the rest exactly.
      if (normal_velocity_prescribed(lo, hi, lv)) return;
      if (options_.bdf2) {  // the face mean of the cells' acceleration (FlowOptions::bdf2)
        uf_[d][hi] += dt * 0.5 * (g[d][lo] + g[d][hi]);
        return;
      }
      uf_[d][hi] += dt * alpha(d, lo, hi, lv) * force_[d][hi];
    });
  });
  restrict_faces<D>(tree_, uf_, open_faces());
}

template <int D>
int NavierStokes<D>::project(FaceField<D>& uf, tree::FieldId p, double dt, const MultigridOptions& opt,
                             StepStats& stats) {
  std::span<double> pv = tree_.values(p);
  MultigridOptions scaled = opt;
  scaled.tolerance /= dt * dt;  // residual of div(alpha grad p) = div(uf)/dt
  if (properties_ && !uniform_density_) scaled.krylov_on_growth = true;  // a density jump: as the viscous solves
  MultigridStats s;
  if (embedded_) {
    s = embedded_projection(uf, pv, dt, scaled);
  } else {
    divergence<D>(tree_, uf, div_);
    tree_.for_each_owned_leaf([&](Index c) { rhs_[c] = div_[c] / dt; });  // a ghost's residual is its owner's
    with_inverse_density([&](auto alpha, auto faces) {
      const EllipticOperator<D, decltype(faces)> op(tree_, faces, {}, conditions_.pressure);
      s = solve(op, pv, rhs_, mg_, scaled);  // leaves p synced (quadratic halos)
      for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double h, const tree::Level<D>& lv) {
        uf[d][hi] -= dt * alpha(d, lo, hi, lv) * (pv[hi] - pv[lo]) / h;
      });
    });
  }
  stats.count_solve(s.converged);
  restrict_faces<D>(tree_, uf, open_faces());
  // Distributed: a ghost's coarse face is the mean of fine faces this rank may not have;
  // the owners' projected faces instead (the advection reads the ghosts' faces).
  tree_.update_ghosts(components<D>(uf));
  return s.cycles;
}

template <int D>
void NavierStokes<D>::projection(double dt, StepStats& stats) {
  if (options_.bdf2) {
    // The faces hold the last pressure's gradient already (acceleration): the solve is for
    // its increment, from zero.
    std::span<double> increment = tree_.values(dp_);
    std::ranges::fill(increment, 0.0);
    stats.projection_cycles += project(uf_, dp_, dt, options_.projection, stats);
    std::span<double> p = tree_.values(p_);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] += increment[i];  // halos too: both synced alike
  } else {
    stats.projection_cycles += project(uf_, p_, dt, options_.projection, stats);
  }
  centred_gradient(dt);
  faces_current_ = true;
  faces_carried_ = false;
}

template <int D>
void NavierStokes<D>::centred_gradient(double dt, bool only_g) {
  // g = cell mean of the face acceleration a - alpha grad p, so that u += dt g; a face
  // force that is a discrete gradient cancels with the pressure exactly.
  const std::span<const double> p = tree_.values(p_);
  FaceField<D>& gf = scratch_faces_;
  with_inverse_density([&](auto alpha, auto) {
    for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double h, const tree::Level<D>& lv) {
      gf[d][hi] = alpha(d, lo, hi, lv) * (force_[d][hi] - (p[hi] - p[lo]) / h);
    });
  });
  restrict_faces<D>(tree_, gf, open_faces());
  // With embedded walls, the mean of the open faces' accelerations weighted by their fluid
  // fractions; a cell with every face open (kStencilUniform) takes the plain mean, the same
  // bits, without reading its faces' fractions (the loop is memory-bound).
  const FaceField<D>* open = embedded_ ? &embedded_->faces() : nullptr;
  const std::uint8_t* flag = embedded_ ? embedded_->uniform().data() : nullptr;
  for_each_owned_leaf_level<D>(tree_, [&](Index c, int l, double) {  // the ghosts' come by the exchange below
    const Index* row = tree_.level(l).face_row(c);
    const bool plain = !flag || flag[c] == kStencilUniform;
    for (int d = 0; d < D; ++d) {
      const Index up = row[2 * d + 1];
      double g = 0.0;
      if (plain) {
        g = 0.5 * (gf[d][c] + gf[d][up]);
      } else {
        const FaceField<D>& f = *open;
        const double weight = f[d][c] + f[d][up];
        if (weight > 0.0) g = (f[d][c] * gf[d][c] + f[d][up] * gf[d][up]) / weight;
      }
      tree_.values(g_[d])[c] = g;
      if (!only_g) tree_.values(u_[d])[c] += dt * g;
    }
  });
  // Distributed: a ghost's faces may lie past the ghost layer; its owner's values instead
  // (g and u in one message per neighbour rank).
  std::array<std::span<double>, 2 * D> gu;
  for (int d = 0; d < D; ++d) {
    gu[d] = tree_.values(g_[d]);
    gu[D + d] = tree_.values(u_[d]);
  }
  tree_.update_ghosts(gu);
}

template <int D>
bool NavierStokes<D>::leaves_finite() const {
  std::int64_t bad = 0;
  for (const Index c : tree_.owned_leaves()) {
    for (int d = 0; d < D; ++d)
      if (!std::isfinite(tree_.values(u_[d])[c])) bad = 1;
    if (!std::isfinite(tree_.values(p_)[c])) bad = 1;
    if (bad) break;
  }
  return tree_.global_max(bad) == 0;
}

template <int D>
double NavierStokes<D>::max_divergence() {
  divergence<D>(tree_, uf_, div_, open_faces());
  double worst = 0.0;
  for (const Index c : tree_.owned_leaves()) worst = std::max(worst, abs_or_infinity(div_[c]));
  return tree_.global_max(worst);
}

template <int D>
double NavierStokes<D>::max_velocity_component() const {
  double fastest = 0.0;
  for (const Index c : tree_.owned_leaves())
    for (int d = 0; d < D; ++d) fastest = std::max(fastest, std::abs(tree_.values(u_[d])[c]));
  return tree_.global_max(fastest);
}

template <int D>
double NavierStokes<D>::velocity_tolerance(double tolerance, double relative) const {
  if (relative <= 0.0) return tolerance;
  return std::max(std::min(tolerance, relative * max_velocity_component()), 1e-3 * tolerance);
}

namespace {
// A number of the leaf (level, key) that no other leaf, and no value an adaptation's transfer
// makes from other leaves' numbers (means, prolongations), can equal: 52 bits of a mixed
// hash in [1, 2). A leaf whose stamp survives an adaptation unchanged is the same leaf.
double leaf_stamp(int level, tree::Key key) {
  std::uint64_t h = key * 64 + static_cast<std::uint64_t>(level) + 0x9e3779b97f4a7c15ULL;
  h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ULL;
  h = (h ^ (h >> 27)) * 0x94d049bb133111ebULL;
  h ^= h >> 31;
  return std::bit_cast<double>(0x3FF0000000000000ULL | (h >> 12));
}
}  // namespace

template <int D>
void NavierStokes<D>::keep_faces_in_fields() {
  static const char* kAxis[] = {"x", "y", "z"};
  if (kept_fields_[0] < 0) {  // registered once, on every rank alike; no checkpoint keeps them
    for (int d = 0; d < D; ++d)
      kept_fields_[d] = tree_.add_field({.name = fmt::format("uf.kept.{}", kAxis[d]), .saved = false});
    kept_fields_[D] = tree_.add_field({.name = "uf.kept.stamp", .saved = false});
  }
  for_each_leaf_level<D>(tree_, [&](Index c, int l, double) {
    const tree::Level<D>& lv = tree_.level(l);
    for (int d = 0; d < D; ++d) tree_.values(kept_fields_[d])[c] = uf_[d][c];  // each leaf's lower faces
    tree_.values(kept_fields_[D])[c] = leaf_stamp(l, lv.keys[static_cast<std::size_t>(c - lv.base)]);
  });
}

template <int D>
void NavierStokes<D>::carry_faces_in_fields() {
  face_average_of_velocity(uf_);  // where a face's cells changed
  const std::span<const double> stamp = tree_.values(kept_fields_[D]);
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double, const tree::Level<D>& lv) {
    auto same = [&](Index c) {  // the same leaf as before the adapt
      return c < lv.active_end() && lv.is_leaf(c) &&
             stamp[c] == leaf_stamp(tree_.level_of(c), lv.keys[static_cast<std::size_t>(c - lv.base)]);
    };
    if (same(lo) && same(hi)) uf_[d][hi] = tree_.values(kept_fields_[d])[hi];
  });
  restrict_faces<D>(tree_, uf_);
  tree_.update_ghosts(components<D>(uf_));
  faces_carried_ = true;
}

template <int D>
tree::AdaptCounts NavierStokes<D>::adapt(double tolerance, tree::AdaptOptions<D> opt, double relative) {
  tolerance = velocity_tolerance(tolerance, relative);
  for (int d = 0; d < D; ++d) opt.criteria.push_back({u_[d], tolerance});
  // Cells wholly inside solids hold no flow: their wavelets (the jump to zero across the
  // wall) refined the solid along the walls to the finest level (the seed channel as an
  // embedded box: 30 000 solid leaves among 120 000).
  std::vector<std::uint8_t> has_fluid;
  if (embedded_) {
    const std::span<const double> volume = embedded_->volume();
    if (volume.size() != static_cast<std::size_t>(tree_.num_cells()))
      throw std::logic_error("NavierStokes::adapt: the embedded walls were made on another tree (set_solid again after changing the tree)");
    has_fluid.resize(volume.size());
    for (std::size_t c = 0; c < volume.size(); ++c) has_fluid[c] = volume[c] > 0.0 ? 1 : 0;
    opt.criteria_mask = has_fluid;
  }
  // The projected faces survive where the adaptation leaves the cells on both sides of a
  // face as they were. On N ranks a distributed adapt renumbers and migrates the leaves, so
  // each leaf's lower faces travel as tree fields with a stamp of the leaf.
  const bool keep_distributed = (faces_current_ || faces_carried_) && tree_.distributed();
  if (keep_distributed) keep_faces_in_fields();
  const bool keep = (faces_current_ || faces_carried_) && !tree_.distributed();
  if (keep) {
    kept_faces_ = uf_;
    old_leaf_.assign(static_cast<std::size_t>(tree_.num_cells()), 0);
    for (int l = 0; l <= tree_.depth(); ++l) {
      const tree::Level<D>& lv = tree_.level(l);
      for (Index i = 0; i < lv.n_active; ++i) old_leaf_[static_cast<std::size_t>(lv.base + i)] = lv.leaf[i] != 0;
    }
  }
  const Index cells_before = tree_.num_cells();
  properties_stale_ = true;  // the tree's adapt refills no property field, even when nothing changed
  const auto counts = tree_.adapt(opt);
  if (keep && counts.refined == 0 && counts.coarsened == 0 && tree_.num_cells() == cells_before) {
    return counts;  // no rebuild: the same cells, the faces still the projected ones
  }
  // N ranks: no rank refined or merged, so no rank rebuilt (DistributedForest::adapt).
  if (keep_distributed && tree_.global_sum(std::int64_t{counts.refined + counts.coarsened}) == 0) return counts;
  tree_changed();
  if (keep) carry_faces_through_adapt();
  if (keep_distributed) carry_faces_in_fields();
  return counts;
}

template <int D>
tree::AdaptCounts NavierStokes<D>::refine_to(const std::function<int(const tree::Box<D>&)>& required_level) {
  const tree::AdaptCounts counts = tree_.refine_to(required_level);
  tree_changed();
  return counts;
}

template <int D>
void NavierStokes<D>::tree_changed() {
  resize_scratch();
  faces_current_ = false;
  faces_carried_ = false;
  if (embedded_) rebuild_embedded();
}

template <int D>
void NavierStokes<D>::carry_faces_through_adapt() {
  face_average_of_velocity(uf_);  // where a face's cells changed
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double, const tree::Level<D>& lv) {
    auto old = [&lv, this](Index c) -> Index {  // the same leaf before the adapt, or kNone
      if (c < lv.active_begin() || c >= lv.active_end() || !lv.is_leaf(c)) return tree::kNone;
      const Index o = lv.old_index[static_cast<std::size_t>(c - lv.base)];
      return o != tree::kNone && old_leaf_[static_cast<std::size_t>(o)] != 0 ? o : tree::kNone;
    };
    const Index olo = old(lo), ohi = old(hi);
    if (olo != tree::kNone && ohi != tree::kNone) uf_[d][hi] = kept_faces_[d][ohi];
  });
  restrict_faces<D>(tree_, uf_);
  faces_carried_ = true;
}

template void validate<2>(const FlowOptions<2>&);
template void validate<3>(const FlowOptions<3>&);
template class NavierStokes<2>;
template class NavierStokes<3>;

}  // namespace capsflow::fluid
