// The coupled time step (stages and stability: capsule_coupling.hpp).
#include "ibm/capsule_coupling.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <variant>

#include <fmt/format.h>

#include "ibm/interpolate.hpp"
#include "ibm/stencil.hpp"
#include "membrane/errors.hpp"

namespace capsflow::ibm {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

bool all_finite(const Eigen::Matrix3Xd& m, Eigen::Index& first_bad) {
  for (Eigen::Index i = 0; i < m.cols(); ++i)
    if (!m.col(i).allFinite()) {
      first_bad = i;
      return false;
    }
  return true;
}

// Whether this rank's cells of every face stencil of both kernels of the node at x exist
// (own: every cell on one rank). One search of the stencils' common box settles most nodes:
// its owned cells include every stencil's; only a box that fails (a missing corner cell the
// stencils may not read, a wall) is searched stencil by stencil.
bool face_stencils_exist(const tree::Tree<3>& t, const KernelChoice& kc, const double* x, const OwnedPositions& own) {
  const int level = t.max_level();
  const double h = t.cell_size(level);
  const std::array kinds{kc.spread, kc.interpolate};
  Index cells[kMaxBoxWidth * kMaxBoxWidth * kMaxBoxWidth];
  const NodeBox b = node_box(t.options(), h, x, kinds, kc.divergence_free);
  if (find_owned_box(t, level, b.first, b.widths, own, cells) < 0) return true;
  bool exist = true;
  for (const KernelKind kind : kinds)
    with_face_kernel(kind, kc.divergence_free, [&]<Kernel K>(K) {
      for (int axis = 0; exist && axis < 3; ++axis) {
        const BoxStencil st = face_stencil_bounds<K>(t.options(), h, x, axis);
        exist = find_owned_box(t, level, st.first, st.n, own, cells) < 0;
      }
    });
  return exist;
}

// The non-periodic side (2 d + hi) that one of the stencils of the node at x crosses, or -1:
// the stages fail on such a stencil (a cell outside the domain, throw_missing_cell).
int side_crossed(const tree::TreeOptions<3>& o, int level, double h, const KernelChoice& kc, const double* x) {
  int side = -1;
  const auto crosses = [&](const tree::Coords<3>& first, const std::array<int, 3>& n) {
    for (int d = 0; side < 0 && d < 3; ++d) {
      const std::int64_t cells = static_cast<std::int64_t>(o.roots[d]) << level;
      if (o.periodic[d]) continue;
      if (first[d] < 0) side = 2 * d;
      else if (first[d] + n[d] > cells) side = 2 * d + 1;
    }
  };
  for (const KernelKind kind : {kc.spread, kc.interpolate}) {
    if (kc.staggered)
      with_face_kernel(kind, kc.divergence_free, [&]<Kernel K>(K) {
        for (int axis = 0; axis < 3; ++axis) {
          const BoxStencil st = face_stencil_bounds<K>(o, h, x, axis);
          crosses(st.first, st.n);
        }
      });
    else
      with_kernel(kind, [&]<Kernel K>(K) {
        const auto st = node_stencil<K>(o, h, x);
        crosses({st[0].first, st[1].first, st[2].first}, {K::kSupport, K::kSupport, K::kSupport});
      });
  }
  return side;
}

// The cell-centred coupling's stencils (one rank only).
bool cell_stencils_exist(const tree::Tree<3>& t, KernelKind kind, const Eigen::Matrix3Xd& x) {
  return with_kernel(kind, [&]<Kernel K>(K) {
    const int level = t.max_level();
    const double h = t.cell_size(level);
    Index cells[kMaxBoxWidth * kMaxBoxWidth * kMaxBoxWidth];
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      const auto st = node_stencil<K>(t.options(), h, &x(0, i));
      if (find_patch<K::kSupport>(t, level, {st[0].first, st[1].first, st[2].first}, cells) >= 0) return false;
    }
    return true;
  });
}

}  // namespace

CapsuleCoupling::CapsuleCoupling(fluid::NavierStokes<3>& ns, int margin) : ns_(ns), margin_(margin) {
  if (margin_ < 0) throw std::invalid_argument(fmt::format("ibm: band margin {} must be >= 0", margin_));
  // The flow solver asks for its body force during its acceleration stage; between
  // coupled steps (or after a failed spreading) there is none.
  ns_.set_face_force([this](const tree::Tree<3>& t, fluid::FaceField<3>& faces) {
    if (background_) background_(t, faces);
    if (!force_ready_) return;
    const auto t0 = Clock::now();
    bool add = static_cast<bool>(background_);
    if (any_cells_ || !any_faces_) {
      cell_to_face_force<3>(t, force_, faces, add ? SpreadMode::add : SpreadMode::assign);
      add = true;
    }
    if (any_faces_) add_face_force<3>(t, face_force_, faces, add ? SpreadMode::add : SpreadMode::assign);
    face_seconds_ += seconds_since(t0);
  });
}

CapsuleCoupling::~CapsuleCoupling() { ns_.set_face_force({}); }

int CapsuleCoupling::add_capsule(membrane::MembraneModel model, Eigen::Matrix3Xd x, KernelChoice kernels) {
  if (x.cols() != model.mesh().node_count())
    throw std::invalid_argument(fmt::format("ibm: capsule positions have {} nodes, its mesh {}", x.cols(),
                                            model.mesh().node_count()));
  // The stiffest membrane sets the stability limit; every rank keeps every capsule's modulus.
  moduli_.push_back(std::visit(
      [](const auto& law) {
        if constexpr (requires { law.c; }) return law.gs * std::max(1.0, (1.0 + 2.0 * law.c) / 3.0);
        else return law.gs;
      },
      model.law()));
  kernels_.push_back(kernels);
  inner_.push_back({});
  auto triangles = membrane::flat_triangles(model.mesh());
  if (!surfaces_.empty() && *surfaces_.back() == triangles) surfaces_.push_back(surfaces_.back());
  else surfaces_.push_back(std::make_shared<const std::vector<std::array<int, 3>>>(std::move(triangles)));
  capsules_.push_back(std::make_unique<Capsule>(Capsule{.model = std::move(model), .x = std::move(x), .kernels = kernels}));
  capsules_.back()->x_at_adapt = capsules_.back()->x;
  return num_capsules() - 1;
}

Capsule* CapsuleCoupling::owned(int i) const {
  if (!owns(i)) throw std::logic_error(fmt::format("ibm: capsule {} is not held by this rank", i));
  return capsules_[static_cast<std::size_t>(i)].get();
}

double CapsuleCoupling::stability_limit() const {
  const auto& o = ns_.options();
  const double mu = o.viscosity > 0.0 ? o.viscosity : 1.0 / o.Re;
  const double dx = ns_.tree().cell_size(ns_.tree().max_level());
  double g = 0.0;  // the stiffest capsule's effective modulus
  for (const double m : moduli_) g = std::max(g, m);
  if (!(g > 0.0)) return 0.0;
  return std::min(kInertialLimit * std::sqrt(o.density * dx * dx * dx / g), kViscousLimit * mu * dx / g);
}

double CapsuleCoupling::auto_explicit_limit() const {
  if (scheme_ != NodeScheme::bdf2) return kSafety * stability_limit();  // Euler's nodes: the measured limit's margin
  const bool thin_inside = std::any_of(inner_.begin(), inner_.end(),
                                       [](const InnerFluid& f) { return f.viscosity_ratio < kThinInside; });
  return (thin_inside ? kAutoExplicitThinInside : kAutoExplicit) * stability_limit();
}

double CapsuleCoupling::membrane_energy(int k) const {
  const Capsule& c = capsule(k);
  try {
    return c.model.energy(c.x);
  } catch (const membrane::ElementError& e) {
    fail(static_cast<int>(steps_), fmt::format("capsule {}: element {} is inverted or collapsed ({})", k, e.element(), e.what()));
  }
}

double CapsuleCoupling::node_power(int k) const {
  const Capsule& c = capsule(k);
  if (c.forces.cols() != c.x.cols() || c.velocity.cols() != c.x.cols()) return 0.0;
  return c.forces.cwiseProduct(c.velocity).sum();
}

void CapsuleCoupling::fail(int step, const std::string& what, Cause cause) const {
  const std::string where = fmt::format("capsule coupling: step {} (t = {:.6g}): {}", step, ns_.time(), what);
  // The step being taken (its flow taken at the step's end check), else the one that moved
  // the nodes.
  const double dt = at_step_end_ ? ns_.last_dt()
                    : stage_open_ ? ns_.stable_dt()
                                  : (last_dt_ > 0.0 ? last_dt_ : ns_.options().dt);
  const double limit = stability_limit();
  const bool above = dt > limit && !implicit_.enabled;  // the implicit coupling has no such limit
  const std::string unstable = fmt::format(
      "dt = {:.3g} above the membrane stability limit of the explicit coupling, measured {:.3g} here "
      "(min(0.53 sqrt(rho dx^3 / Gs), 0.42 mu dx / Gs)): lower time.dt, or set time.cfl > 0 to keep dt below it",
      dt, limit);
  const std::string stable =
      implicit_.enabled ? fmt::format("the implicit coupling is stable at dt = {:.3g}", dt)
                        : fmt::format("dt = {:.3g} is below the measured stability limit {:.3g}", dt, limit);
  std::string likely;
  if (at_step_end_ && cause == Cause::wall)
    likely = fmt::format("at dt = {:.3g} the step would carry the membrane there: lower time.dt, or set "
                         "time.tolerance to choose the step; a membrane that reaches the wall at any step touches "
                         "it, and contact forces are not modelled yet",
                         dt);
  else if (at_step_end_)
    likely = fmt::format("dt = {:.3g} is long for the implicit step, which takes the membrane force linearised about "
                         "the step's predicted positions: lower time.dt, or set time.tolerance to choose the step",
                         dt);
  else if (at_prediction() && cause == Cause::instability)
    likely = fmt::format("dt = {:.3g} is long for BDF2's prediction of the positions, X + dt V_last, where the step "
                         "takes the forces: lower time.dt, or set time.tolerance to choose the step",
                         dt);
  else switch (cause) {
    case Cause::instability:
      likely = above ? unstable : stable + ", so a capsule pressed against a wall or folded by the flow is likelier";
      break;
    case Cause::band:
      likely = above ? unstable + " (unstable nodes jump out of the band first)"
                     : stable + ", so the membrane moved further than the band's margin since the last adaptation: "
                                "widen adapt.membrane_band or adapt more often (adapt.interval, adapt.interval_time)";
      break;
    case Cause::wall:
      likely = above ? unstable
                     : stable + ", so the membrane touches the wall: contact forces are not modelled yet (start the "
                                "capsule further from the walls or slow the flow; by the brick's sides, refining "
                                "shortens the kernels' reach)";
      break;
    case Cause::implicit_solve:
      // The solve fails after the step's flow: the flow's last step is this one.
      likely = fmt::format("dt = {:.3g} is long for this membrane's stiffness (the solve's products grow with dt over the "
                           "explicit coupling's limit, {:.3g} here): raise time.implicit_max_iterations or lower time.dt",
                           ns_.last_dt(), limit);
      break;
  }
  // A shorter step may succeed: the caller decides (fluid::TimeStep restores the flow).
  if (shorter_may_help(cause))
    throw fluid::StepTooLong(fmt::format("{}. Likely cause: {}.", where, likely), cause != Cause::implicit_solve);
  throw std::runtime_error(fmt::format("{}. Likely cause: {}.", where, likely));
}

bool CapsuleCoupling::shorter_may_help(Cause cause) const {
  if (!stage_open_) return false;  // the nodes have moved: the step cannot be taken again
  return cause == Cause::implicit_solve || at_step_end_ || at_prediction();
}

void CapsuleCoupling::fail_stencil(int step, int k, const StencilError& e) const {
  const StencilError::Where& w = e.where();
  const std::string node = fmt::format("capsule {}: node {} at ({:.6g}, {:.6g}, {:.6g})", k, w.node, w.x[0], w.x[1], w.x[2]);
  if (e.missing() == StencilError::Missing::outside_domain)
    fail(step, fmt::format("{} came within the immersed-boundary kernel's reach of side {}", node,
                           fluid::side_name(w.side)),
         Cause::wall);
  fail(step,
       fmt::format("{} is outside the band refined to level {} around the membrane (the grid there is {})", node,
                   w.level, w.found_level >= 0 ? fmt::format("of level {}", w.found_level) : std::string("coarser")),
       Cause::band);
}

namespace {
// Stencil cells lie within support/2 cells of the node along each axis, their faces half a
// cell further: the box's half-diagonal, plus a cell for the faces of staggered stencils.
double wall_reach(const KernelChoice& kc, double dx) {
  const bool smoothed = kc.staggered && kc.divergence_free;
  const int support = std::max(support_of(kc.spread, smoothed), support_of(kc.interpolate, smoothed));
  return (0.5 * support + 1.5) * dx * std::sqrt(3.0);
}
}  // namespace

double CapsuleCoupling::embedded_wall_reach(int k) const {
  return wall_reach(kernels_[static_cast<std::size_t>(k)], ns_.tree().cell_size(ns_.tree().max_level()));
}

double CapsuleCoupling::embedded_wall_contact() const { return 0.25 * ns_.tree().cell_size(ns_.tree().max_level()); }

void CapsuleCoupling::check_embedded_walls(int step, int k, const Eigen::Matrix3Xd& at) const {
  const fluid::EmbeddedGeometry<3>* walls = ns_.embedded();
  if (walls == nullptr) return;
  const double contact = embedded_wall_contact();
  // One distance for a membrane far from every wall: phi is 1-Lipschitz, so the nodes lie at
  // least phi(centre) - (their farthest distance from the centre) from the walls.
  const Eigen::Vector3d centre = at.rowwise().mean();
  const double extent = (at.colwise() - centre).colwise().norm().maxCoeff();
  if (walls->signed_distance({centre[0], centre[1], centre[2]}) - extent > contact) return;
  for (Eigen::Index n = 0; n < at.cols(); ++n) {
    const double distance = walls->signed_distance({at(0, n), at(1, n), at(2, n)});
    if (!(distance > contact))
      fail(step,
           fmt::format("capsule {}: node {} at ({:.6g}, {:.6g}, {:.6g}) touched an embedded wall (its distance {:.4g}, "
                       "within a quarter cell {:.4g}; contact forces are not modelled yet)",
                       k, n, at(0, n), at(1, n), at(2, n), distance, contact),
           Cause::wall);
  }
}

void CapsuleCoupling::check_brick_sides(int step, int k, const Eigen::Matrix3Xd& at) const {
  const tree::Tree<3>& t = ns_.tree();
  const auto& o = t.options();
  if (std::all_of(o.periodic.begin(), o.periodic.end(), [](bool p) { return p; })) return;
  const int level = t.max_level();
  const double h = t.cell_size(level);
  // One box for a membrane far from every side: no stencil reaches beyond wall_reach.
  const double reach = wall_reach(kernels_[static_cast<std::size_t>(k)], h);
  const Eigen::Vector3d lo = at.rowwise().minCoeff(), hi = at.rowwise().maxCoeff();
  bool clear = true;
  for (int d = 0; d < 3; ++d)
    clear = clear && (o.periodic[d] || (lo[d] - reach > o.origin[d] &&
                                        hi[d] + reach < o.origin[d] + o.roots[d] * o.root_size));
  if (clear) return;
  for (Eigen::Index n = 0; n < at.cols(); ++n) {
    const int side = side_crossed(o, level, h, kernels_[static_cast<std::size_t>(k)], &at(0, n));
    if (side >= 0)
      fail(step,
           fmt::format("capsule {}: node {} would end the step at ({:.6g}, {:.6g}, {:.6g}), within the "
                       "immersed-boundary kernel's reach of side {}",
                       k, n, at(0, n), at(1, n), at(2, n), fluid::side_name(side)),
           Cause::wall);
  }
}

void CapsuleCoupling::require_open_faces(int step, int k, std::size_t i,
                                         const std::function<std::int64_t(Eigen::Index)>& node_of) const {
  for (const WallWeights* w : {spread_walls(i), interpolation_walls(i)})
    if (w && w->buried() >= 0)
      fail(step,
           fmt::format("capsule {}: node {} is inside an embedded wall (no open face in its kernel's reach)", k,
                       node_of(w->buried())),
           Cause::wall);
}

int CapsuleCoupling::required_level(const tree::Box<3>& b) const {
  int r = 0;
  if (distributed()) {
    for (const MembraneTags& tags : bands_) r = std::max(r, tags(b));
    return r;
  }
  for (const auto& c : capsules_) r = std::max(r, c->tags(b));
  return r;
}

int CapsuleCoupling::band(int k) const {
  const KernelChoice& kc = kernels_[static_cast<std::size_t>(k)];
  return band_cells(kc.spread, kc.interpolate, margin_, kc.staggered && kc.divergence_free);
}

void CapsuleCoupling::update_region() {
  const tree::Tree<3>& t = ns_.tree();
  if (!distributed()) {
    for (int k = 0; k < num_capsules(); ++k) capsule(k).tags.build(t.options(), t.max_level(), band(k), capsule(k).x);
    return;
  }
  // The bands of every capsule near this rank's cells, from the nodes whose band reaches them.
  const RoutedNodes nodes = route([](const Capsule& c) -> const Eigen::Matrix3Xd& { return c.x; }, false,
                                  [this](int k) { return band(k) + 1; });
  bands_.assign(nodes.ranges.size(), MembraneTags{});
  for (std::size_t r = 0; r < nodes.ranges.size(); ++r) {
    const RoutedNodes::Range& range = nodes.ranges[r];
    bands_[r].build(t.options(), t.max_level(), band(range.capsule),
                    nodes.x.middleCols(range.begin, range.end - range.begin));
  }
}

bool CapsuleCoupling::stencils_ready() const {
  const tree::Tree<3>& t = ns_.tree();
  if (!distributed())
    return std::all_of(capsules_.begin(), capsules_.end(), [&](const auto& p) {
      const Capsule& c = *p;
      if (c.kernels.staggered) {
        for (Eigen::Index i = 0; i < c.x.cols(); ++i)
          if (!face_stencils_exist(t, c.kernels, &c.x(0, i), {})) return false;
        return true;
      }
      return cell_stencils_exist(t, c.kernels.spread, c.x) && cell_stencils_exist(t, c.kernels.interpolate, c.x);
    });
  // Each rank checks the stencil cells it owns of the nodes that reach it.
  const RoutedNodes nodes = route([](const Capsule& c) -> const Eigen::Matrix3Xd& { return c.x; }, false,
                                  [this](int k) { return stencil_reach(k); }, true);
  const OwnedPositions own = owned_positions();
  bool ready = true;
  for (const RoutedNodes::Range& range : nodes.ranges) {
    const KernelChoice& kc = kernels_[static_cast<std::size_t>(range.capsule)];
    for (Eigen::Index i = range.begin; ready && i < range.end; ++i) ready = face_stencils_exist(t, kc, &nodes.x(0, i), own);
  }
  return !any_rank(!ready);
}

bool CapsuleCoupling::may_wait(int max_interval) const {
  if (since_adapt_ >= max_interval) return false;
  double moved = 0.0;
  for (const auto& p : capsules_)
    if (p && p->x_at_adapt.cols() == p->x.cols())
      moved = std::max(moved, (p->x - p->x_at_adapt).colwise().norm().maxCoeff());
  // The band reaches `margin` max-level cells beyond the kernels; at the mean speed since
  // the last adaptation the nodes must stay within half of that until the forced one.
  const double projected = moved * static_cast<double>(max_interval) / static_cast<double>(since_adapt_);
  return !any_rank(projected > 0.5 * margin_ * ns_.tree().cell_size(ns_.tree().max_level()));
}

bool CapsuleCoupling::must_adapt() const {
  const double reach = margin_ * ns_.tree().cell_size(ns_.tree().max_level());
  bool must = false;
  for (const auto& p : capsules_) {
    if (!p || p->x_at_adapt.cols() != p->x.cols()) continue;
    const Capsule& c = *p;
    // Per axis: the band is the union of the stencils' boxes, `margin` cells wider.
    double moved = (c.x - c.x_at_adapt).cwiseAbs().maxCoeff();
    if (c.velocity.cols() == c.x.cols()) moved += last_dt_ * c.velocity.cwiseAbs().maxCoeff();
    must = must || moved > reach;
  }
  return any_rank(must);
}

CapsuleCoupling::NodeError CapsuleCoupling::node_error() const {
  // A capsule without V_prev counts as infinite, so one maximum over the ranks carries it
  // (a change that is not finite stopped the step before: advance_nodes checks V).
  constexpr double kMissing = std::numeric_limits<double>::infinity();
  double d = 0.0;
  for (const auto& p : capsules_) {
    if (!p) continue;
    const bool missing = p->previous_velocity.cols() != p->velocity.cols() || p->velocity.cols() == 0 ||
                         p->motion.cols() != p->velocity.cols();
    d = std::max(d, missing ? kMissing
                            : (p->motion - 0.5 * (p->previous_velocity + p->velocity)).colwise().norm().maxCoeff());
  }
  const double global = ns_.tree().global_max(d);
  if (global == kMissing) return {};
  if (bdf2_last_) return {.error = 8.0 / 3.0 * global, .order = 2};
  return {.error = global, .order = 1};
}

void CapsuleCoupling::adapted() {
  for (auto& p : capsules_)
    if (p) p->x_at_adapt = p->x;
  since_adapt_ = 0;
}

void CapsuleCoupling::compute_forces(int step) {
  const auto t0 = Clock::now();
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    Capsule& c = capsule(k);
    check_embedded_walls(step, k, stage_positions(c));
    try {
      c.energy = c.model.compute_forces(stage_positions(c), c.forces);
    } catch (const membrane::ElementError& e) {
      fail(step, fmt::format("capsule {}: element {} is inverted or collapsed ({})", k, e.element(), e.what()));
    }
    Eigen::Index bad = 0;
    if (!all_finite(c.forces, bad))
      fail(step, fmt::format("capsule {}: the force on node {} is not finite", k, bad));
  }
  times_.membrane += seconds_since(t0);
}

void CapsuleCoupling::spread_forces(int step) {
  const auto t0 = Clock::now();
  const tree::Tree<3>& t = ns_.tree();
  any_cells_ = any_faces_ = false;
  for (int k = 0; k < num_capsules(); ++k) {
    Capsule& c = capsule(k);
    bool& started = c.kernels.staggered ? any_faces_ : any_cells_;
    const SpreadMode mode = started ? SpreadMode::add : SpreadMode::assign;
    require_open_faces(step, k, static_cast<std::size_t>(k), [](Eigen::Index n) { return n; });
    try {
      const Eigen::Matrix3Xd& at = stage_positions(c);
      if (c.kernels.staggered)
        spread_faces(c.kernels.spread, c.kernels.divergence_free, t, at, c.forces, face_force_, workspace_, mode, {},
                     boxes(static_cast<std::size_t>(k)), spread_walls(static_cast<std::size_t>(k)));
      else spread(c.kernels.spread, t, at, c.forces, force_, workspace_, mode);
    } catch (const StencilError& e) {
      fail_stencil(step, k, e);
    }
    started = true;
  }
  zero_unspread_forces();
  force_ready_ = true;
  times_.spreading += seconds_since(t0);
}

void CapsuleCoupling::zero_unspread_forces() {
  // A field no capsule spread into this step must be zero; one known zero at this size stays
  // so (a new tree of the same size is zero too) until a spreading or an exchange writes it.
  const auto cells = static_cast<std::size_t>(ns_.tree().num_cells());
  const auto zero = [cells](auto& field, bool& known_zero) {
    if (known_zero && field[0].size() == cells) return;
    for (auto& f : field) f.assign(cells, 0.0);
    known_zero = true;
  };
  if (!any_cells_) zero(force_, force_zero_);
  else force_zero_ = false;
  if (!any_faces_) zero(face_force_, face_force_zero_);
  else face_force_zero_ = false;
}

void CapsuleCoupling::interpolate_into(int step, const std::function<Eigen::Matrix3Xd&(Capsule&)>& velocity_of) {
  if (distributed()) {
    interpolate_routed(step, ns_.face_velocity(), velocity_of);
    return;
  }
  const tree::Tree<3>& t = ns_.tree();
  const std::array<std::span<const double>, 3> u{ns_.u(0), ns_.u(1), ns_.u(2)};
  for (int k = 0; k < num_capsules(); ++k) {
    Capsule& c = capsule(k);
    try {
      const Eigen::Matrix3Xd& at = stage_positions(c);
      if (c.kernels.staggered)
        interpolate_faces(c.kernels.interpolate, c.kernels.divergence_free, t, ns_.face_velocity(), at, velocity_of(c),
                          boxes(static_cast<std::size_t>(k)), interpolation_walls(static_cast<std::size_t>(k)));
      else interpolate(c.kernels.interpolate, t, u, at, velocity_of(c));
    } catch (const StencilError& e) {
      fail_stencil(step, k, e);
    }
  }
}

void CapsuleCoupling::interpolate_velocities(int step) {
  const auto t0 = Clock::now();
  for (int k = 0; k < num_capsules(); ++k)
    if (owns(k)) std::swap(capsule(k).previous_velocity, capsule(k).velocity);  // V^(n-1); velocity gets V^n
  if (end_velocity_ready_) {  // the implicit step's check interpolated this flow already
    for (int k = 0; k < num_capsules(); ++k)
      if (owns(k)) capsule(k).velocity = capsule(k).response;
    end_velocity_ready_ = false;
  } else {
    interpolate_into(step, [](Capsule& c) -> Eigen::Matrix3Xd& { return c.velocity; });
  }
  times_.interpolation += seconds_since(t0);
}

void CapsuleCoupling::advance_nodes(int step, double dt, double previous_dt) {
  const auto t0 = Clock::now();
  const auto& o = ns_.tree().options();
  const Bdf2Weights bdf2 = bdf2_weights(dt, previous_dt);
  motion_.resize(capsules_.size());
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    Capsule& c = capsule(k);
    Eigen::Index bad = 0;
    if (!all_finite(c.velocity, bad))
      fail(step, fmt::format("capsule {}: the velocity of node {} is not finite", k, bad));
    // AB2 with a variable step (Euler on the first step, or without V^(n-1)).
    Eigen::Matrix3Xd& m = motion_[static_cast<std::size_t>(k)];
    if (scheme_ == NodeScheme::midpoint) {
      m = 0.5 * (c.start_velocity + c.velocity);
    } else if (bdf2_step_) {
      m = step_motion(c, bdf2, c.velocity);
    } else if (scheme_ == NodeScheme::ab2 && previous_dt > 0.0 && c.previous_velocity.cols() == c.x.cols()) {
      const double r = dt / previous_dt;
      m = (1.0 + 0.5 * r) * c.velocity - (0.5 * r) * c.previous_velocity;
    } else {
      m = c.velocity;
    }
    // Check every new position before committing any: a failure keeps the last good X.
    for (Eigen::Index i = 0; i < c.x.cols(); ++i)
      for (int d = 0; d < 3; ++d) {
        const double xn = c.x(d, i) + dt * m(d, i);
        const double lo = o.origin[d], hi = lo + o.roots[d] * o.root_size;
        if (!o.periodic[d] && !(xn > lo && xn < hi))
          fail(step, fmt::format("capsule {}: node {} would leave the domain: {} = {:.6g} outside [{}, {}]", k, i,
                                 "xyz"[d], xn, lo, hi),
               Cause::wall);
      }
  }
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    Capsule& c = capsule(k);
    Eigen::Matrix3Xd& m = motion_[static_cast<std::size_t>(k)];
    c.x += dt * m;
    c.work += dt * c.forces.cwiseProduct(m).sum();
    std::swap(c.motion, m);
  }
  bdf2_last_ = bdf2_step_;
  times_.interpolation += seconds_since(t0);
}

const fluid::FaceField<3>& CapsuleCoupling::start_face_velocity() {
  // u^n on faces: the last projection's (after an adaptation, carried where the cells did not
  // change: around the membrane they stay divergence-free), or, before the first step and
  // after a restart, the face mean of the cell velocity.
  if (ns_.face_velocity_current() || ns_.face_velocity_carried()) return ns_.face_velocity();
  const tree::Tree<3>& t = ns_.tree();
  fluid::resize<3>(start_faces_, t);
  const std::array<std::span<const double>, 3> u{ns_.u(0), ns_.u(1), ns_.u(2)};
  fluid::for_each_face<3>(t, [&](int d, Index lo, Index hi, double, const tree::Level<3>&) {
    start_faces_[d][hi] = 0.5 * (u[d][lo] + u[d][hi]);
  });
  t.update_ghosts(fluid::components<3>(start_faces_));  // every ghost's faces: a node's interpolator reads them
  return start_faces_;
}

void CapsuleCoupling::place_midpoints() {
  const double dt = ns_.stable_dt();
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    Capsule& c = capsule(k);
    c.x_mid = c.x;
    if (c.velocity.cols() == c.x.cols()) c.x_mid += 0.5 * dt * c.velocity;
  }
}

CapsuleCoupling::Bdf2Weights CapsuleCoupling::bdf2_weights(double dt, double dt_last) const {
  if (!bdf2_step_) return {};
  const double w = dt / dt_last;
  return {.a = w / (1.0 + 2.0 * w), .b = (1.0 + w) / (1.0 + 2.0 * w)};
}

void CapsuleCoupling::place_bdf2_predictions() {
  // BDF2 needs every capsule's last motion: after a restart from a checkpoint without it,
  // or on the first step, the step is Euler's for all (one decision on every rank).
  bool ready = last_dt_ > 0.0;
  for (int k = 0; k < num_capsules(); ++k)
    if (owns(k)) ready = ready && capsule(k).motion.cols() == capsule(k).x.cols();
  bdf2_step_ = !any_rank(!ready);
  // X* = X + dt V_last, second order in dt: the velocity at X(t + dt) then is too, where
  // J u(t + dt) at X would be first order only.
  const double dt = ns_.stable_dt();
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    Capsule& c = capsule(k);
    c.x_mid = c.x;
    if (bdf2_step_) c.x_mid += dt * c.motion;
  }
}

void CapsuleCoupling::find_boxes(std::size_t count,
                                 const std::function<Eigen::Ref<const Eigen::Matrix3Xd>(std::size_t)>& x_of,
                                 const std::function<const KernelChoice&(std::size_t)>& kernels_of,
                                 const OwnedPositions& own) {
  boxes_.resize(count);
  spread_walls_.resize(count);
  interpolation_walls_.resize(count);
  same_kernel_walls_.assign(count, 0);
  const fluid::EmbeddedGeometry<3>* walls = ns_.embedded();
  const double dx = ns_.tree().cell_size(ns_.tree().max_level());
  for (std::size_t i = 0; i < count; ++i) {
    const KernelChoice& kc = kernels_of(i);
    spread_walls_[i].clear();
    interpolation_walls_[i].clear();
    if (!kc.staggered) {
      boxes_[i].clear();
      if (walls) throw std::invalid_argument("ibm: embedded walls need the staggered coupling (staggered = true)");
      continue;
    }
    const std::array kinds{kc.spread, kc.interpolate};
    boxes_[i].find(ns_.tree(), x_of(i), kinds, kc.divergence_free, own);
    if (!walls) continue;
    const double reach = wall_reach(kc, dx);
    spread_walls_[i].find(kc.spread, kc.divergence_free, *walls, ns_.tree(), x_of(i), reach);
    same_kernel_walls_[i] = kc.interpolate == kc.spread;
    if (!same_kernel_walls_[i])
      interpolation_walls_[i].find(kc.interpolate, kc.divergence_free, *walls, ns_.tree(), x_of(i), reach);
  }
}

void CapsuleCoupling::predict_midpoint(int step) {
  const auto t0 = Clock::now();
  const tree::Tree<3>& t = ns_.tree();
  const fluid::FaceField<3>* faces = &start_face_velocity();
  const std::array<std::span<const double>, 3> u{ns_.u(0), ns_.u(1), ns_.u(2)};
  for (int k = 0; k < num_capsules(); ++k) {
    Capsule& c = capsule(k);
    try {
      if (c.kernels.staggered) interpolate_faces(c.kernels.interpolate, c.kernels.divergence_free, t, *faces, c.x_mid, c.start_velocity,
                                                 boxes(static_cast<std::size_t>(k)), interpolation_walls(static_cast<std::size_t>(k)));
      else interpolate(c.kernels.interpolate, t, u, c.x_mid, c.start_velocity);
    } catch (const StencilError& e) {
      fail_stencil(step, k, e);
    }
  }
  times_.interpolation += seconds_since(t0);
}

// The stages of a coupled step (fluid/time_step.hpp); on N ranks each has its routed form
// (capsule_distribution.cpp). Every stage of a step takes its stencils at the stage positions
// (X*, or X), on one tree: the adaptation comes after the step.
void CapsuleCoupling::forces() {
  const int step = static_cast<int>(steps_ + 1);
  stage_open_ = true;
  end_velocity_ready_ = false;
  implicit_step_ = implicit_.enabled && num_capsules() > 0 && !(ns_.stable_dt() <= implicit_.explicit_below);
  if (distributed()) {
    distributed_forces(step);
    return;
  }
  if (scheme_ == NodeScheme::midpoint) place_midpoints();
  if (scheme_ == NodeScheme::bdf2) place_bdf2_predictions();
  compute_forces(step);
}

void CapsuleCoupling::spreading() {
  const int step = static_cast<int>(steps_ + 1);
  if (distributed()) {
    distributed_spreading(step);
    return;
  }
  const auto t0 = Clock::now();
  find_boxes(capsules_.size(),
             [this](std::size_t k) -> Eigen::Ref<const Eigen::Matrix3Xd> { return stage_positions(capsule(static_cast<int>(k))); },
             [this](std::size_t k) -> const KernelChoice& { return kernels_[k]; }, {});
  times_.spreading += seconds_since(t0);  // (on N ranks distributed_spreading times its call)
  spread_forces(step);
  if (scheme_ == NodeScheme::midpoint) predict_midpoint(step);  // J(X*) u^n, before the flow changes u
}

void CapsuleCoupling::flow_failed() { force_ready_ = false; }  // the spread force belongs to the step that failed

void CapsuleCoupling::interpolation() {
  const int step = static_cast<int>(steps_ + 1);
  stage_open_ = false;
  force_ready_ = false;
  interpolate_velocities(step);  // on N ranks routed (interpolate_into)
  for (NodeBoxes& b : boxes_) b.clear();  // their arrays are kept: a step's boxes fill them again
  for (WallWeights& w : spread_walls_) w.clear();
  for (WallWeights& w : interpolation_walls_) w.clear();
}

void CapsuleCoupling::motion(const fluid::StepStats& flow, double flow_seconds) {
  const int step = static_cast<int>(steps_ + 1);
  // The face force is spread inside the flow step, and an implicit step's correction spreads,
  // interpolates and solves between its flow steps: the stages time those themselves.
  times_.fluid += flow_seconds - face_seconds_ - implicit_seconds_;
  times_.spreading += face_seconds_;
  face_seconds_ = implicit_seconds_ = 0.0;
  const double previous_dt = last_dt_;
  last_dt_ = flow.dt;
  collectively([&] { advance_nodes(step, flow.dt, previous_dt); });
  ++steps_;
  ++since_adapt_;
}

CouplingStep CapsuleCoupling::step() {
  fluid::TimeStep<3> one(ns_);
  one.attach(*this);
  return {one.run()};
}

}  // namespace capsflow::ibm
