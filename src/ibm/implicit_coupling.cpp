// The implicit coupling's correction (capsule_coupling.hpp, ImplicitOptions): the system on
// the step's node displacement, solved by FGMRES over flow steps taken again from one start.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "common/gmres.hpp"
#include "ibm/capsule_coupling.hpp"
#include "membrane/errors.hpp"
#include "parallel/exact_sum.hpp"

namespace capsflow::ibm {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The flow's solve tolerances scaled for a scope (NavierStokes::set_tolerance_scale): back to
// its own when the scope ends, a failed flow step too.
class ToleranceScale {
 public:
  ToleranceScale(fluid::NavierStokes<3>& ns, double scale) : ns_(ns) { ns_.set_tolerance_scale(scale); }
  ~ToleranceScale() { ns_.set_tolerance_scale(1.0); }
  ToleranceScale(const ToleranceScale&) = delete;
  ToleranceScale& operator=(const ToleranceScale&) = delete;

 private:
  fluid::NavierStokes<3>& ns_;
};

}  // namespace

void CapsuleCoupling::set_implicit(const ImplicitOptions& o) {
  if (!(o.tolerance > 0.0 && o.tolerance < 1.0))
    throw std::invalid_argument(fmt::format("implicit coupling: tolerance = {} must lie in (0, 1)", o.tolerance));
  if (!(o.explicit_below >= 0.0))
    throw std::invalid_argument(fmt::format("implicit coupling: explicit_below = {} must be >= 0", o.explicit_below));
  if (o.max_iterations < 1)
    throw std::invalid_argument(fmt::format("implicit coupling: max_iterations = {} must be >= 1", o.max_iterations));
  if (o.enabled && !ns_.options().current_force_in_viscous)
    throw std::invalid_argument(
        "implicit coupling: the flow must take each step's force in its viscous solve "
        "(fluid::FlowOptions::current_force_in_viscous); with the force a step late there, a grid-scale force drives "
        "the cells undamped and the flow's response is not the one the solve linearises");
  implicit_ = o;
}

void CapsuleCoupling::check_step_end(int step, int k, const Eigen::Matrix3Xd& end) {
  struct AtEnd {  // back when the check ends, by a throw too
    bool& flag;
    explicit AtEnd(bool& f) : flag(f) { flag = true; }
    ~AtEnd() { flag = false; }
    AtEnd(const AtEnd&) = delete;
    AtEnd& operator=(const AtEnd&) = delete;
  } at_end(at_step_end_);
  check_embedded_walls(step, k, end);
  check_brick_sides(step, k, end);
  try {
    (void)capsule(k).model.energy(end);
  } catch (const membrane::ElementError& e) {
    fail(step, fmt::format("capsule {}: element {} would end the step inverted or collapsed ({})", k, e.element(), e.what()));
  }
}

void CapsuleCoupling::correct(const std::function<fluid::StepStats()>& rerun) {
  if (!implicit()) return;
  if (scheme_ != NodeScheme::euler && scheme_ != NodeScheme::bdf2)
    throw std::logic_error("ibm: the implicit coupling moves the nodes by Euler's or BDF2's rule only");
  const int step = static_cast<int>(steps_ + 1);
  const double dt = ns_.last_dt();
  const auto t0 = Clock::now();
  const double spreading_before = times_.spreading;
  double flow_seconds = 0.0, membrane_seconds = 0.0;
  const auto flow = [&] {
    const auto f0 = Clock::now();
    (void)rerun();
    flow_seconds += seconds_since(f0);
  };

  // The node vector: the owned capsules' 3 x n blocks, by id.
  std::vector<int> ids;
  std::vector<Eigen::Index> offsets{0};
  for (int k = 0; k < num_capsules(); ++k)
    if (owns(k)) {
      ids.push_back(k);
      offsets.push_back(offsets.back() + capsule(k).x.size());
    }
  // Capsule i's part of a node vector, flat and as 3 x n.
  const auto part = [&](auto& v, std::size_t i) { return v.segment(offsets[i], offsets[i + 1] - offsets[i]); };
  const auto block = [&](Eigen::VectorXd& v, std::size_t i) {
    return Eigen::Map<Eigen::Matrix3Xd>(v.data() + offsets[i], 3, (offsets[i + 1] - offsets[i]) / 3);
  };
  const auto cblock = [&](const Eigen::VectorXd& v, std::size_t i) {
    return Eigen::Map<const Eigen::Matrix3Xd>(v.data() + offsets[i], 3, (offsets[i + 1] - offsets[i]) / 3);
  };
  // Per capsule in floating point, then exactly over the capsules (and ranks): the same
  // bits on any number of ranks, the capsules' blocks being whole on their owners.
  const auto dot = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    parallel::ExactSum sum;
    for (std::size_t i = 0; i < ids.size(); ++i) sum.add(part(a, i).dot(part(b, i)));
    return ns_.tree().global_sum(sum);
  };

  // F(X), K(X) and dt J u_explicit (the flow has taken the step with F(X) spread).
  const auto tm = Clock::now();
  std::vector<Eigen::Matrix3Xd> start_forces(ids.size());
  std::vector<const Eigen::SparseMatrix<double>*> stiffness(ids.size());
  collectively([&] {
    for (std::size_t i = 0; i < ids.size(); ++i) {
      Capsule& c = capsule(ids[i]);
      start_forces[i] = c.forces;
      try {
        stiffness[i] = &c.model.stiffness(stage_positions(c), membrane::StiffnessPart::positive);
      } catch (const membrane::ElementError& e) {
        fail(step, fmt::format("capsule {}: element {} is inverted or collapsed ({})", ids[i], e.element(), e.what()));
      }
    }
  });
  membrane_seconds = seconds_since(tm);
  times_.membrane += membrane_seconds;
  // J u of the flow as it stands, as one node vector.
  const auto interpolated = [&] {
    interpolate_into(step, [](Capsule& c) -> Eigen::Matrix3Xd& { return c.response; });
    Eigen::VectorXd v(offsets.back());
    for (std::size_t i = 0; i < ids.size(); ++i) block(v, i) = capsule(ids[i]).response;
    return v;
  };
  // K v, capsule by capsule.
  const auto stiffness_times = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd kv(offsets.back());
    for (std::size_t i = 0; i < ids.size(); ++i) part(kv, i) = *stiffness[i] * part(v, i);
    return kv;
  };
  // Spreads F - change and takes the flow step again.
  const auto step_with = [&](const Eigen::VectorXd& change) {
    for (std::size_t i = 0; i < ids.size(); ++i) capsule(ids[i]).forces = start_forces[i] - cblock(change, i);
    // The positions, so this step's stencil boxes, stay; on N ranks the forces are routed
    // with the positions.
    if (distributed()) spreading();
    else spread_forces(step);
    flow();
  };
  const Eigen::VectorXd explicit_velocity = interpolated();
  // The unknown is the step's displacement from the stage positions, y = X(t + dt) - X*; the
  // scheme moves X(t + dt) = X + dt (a V_last + b J u(t + dt)) with X* = X + dt V_last (Euler:
  // a = 0, b = 1, X* = X), and u(t + dt) = u_explicit - L S K y, so
  //   (I + b dt J L S K) y = dt (a - 1) V_last + b dt J u_explicit.
  const Bdf2Weights w = bdf2_weights(dt, last_dt_);
  Eigen::VectorXd b = (w.b * dt) * explicit_velocity;
  if (bdf2_step_)
    for (std::size_t i = 0; i < ids.size(); ++i) block(b, i) += ((w.a - 1.0) * dt) * capsule(ids[i]).motion;

  // A v = v + b dt (J u(F) - J u(F - K s v)) / s: the flow's response to -K v, by the difference
  // of two steps. The solves stop at absolute tolerances (fluid::FlowOptions), so s scales the
  // response to ten times J u_explicit, well above them, whatever the size of v or of F (a
  // capsule at rest in a flow has F = 0). The response per unit force (the gain) is taken
  // from the last product; before the first, a regularised point force's mobility,
  // 1 / (rho h^3 / dt + 6 pi mu h), inertial or viscous.
  const auto& flow_options = ns_.options();
  const double h = ns_.tree().cell_size(ns_.tree().max_level());
  const double mu = flow_options.viscosity > 0.0 ? flow_options.viscosity : 1.0 / flow_options.Re;
  double gain = 1.0 / (flow_options.density * h * h * h / dt + 6.0 * std::numbers::pi * mu * h);
  const double target = 10.0 * std::sqrt(dot(explicit_velocity, explicit_velocity));
  // A product needs its response to a fraction of the solve's tolerance, relative to the
  // response, which is ten times J u_explicit: its flow solves may stop at a multiple of the
  // flow's absolute tolerances, as large as the implicit tolerance allows (30 at the default
  // 1e-3: the quick relaxation's D12 moves by < 1e-5, its products' cycles fall by a quarter;
  // docs/numerics.md). The step itself (below) takes the flow's own tolerances.
  const double product_scale = std::clamp(3e4 * implicit_.tolerance, 1.0, 30.0);
  const auto apply = [&](const Eigen::VectorXd& v) {
    const Eigen::VectorXd kv = stiffness_times(v);
    const double kv_norm = std::sqrt(dot(kv, kv));
    if (!(kv_norm > 0.0)) return Eigen::VectorXd(v);  // K v = 0: a rigid motion, no force
    const double s = target / (gain * kv_norm);
    const ToleranceScale looser(ns_, product_scale);
    step_with(s * kv);
    const Eigen::VectorXd response = explicit_velocity - interpolated();
    gain = std::max(std::sqrt(dot(response, response)) / (s * kv_norm), 1e-300);
    return Eigen::VectorXd(v + (w.b * dt / s) * response);
  };
  const auto identity = [](const Eigen::VectorXd& v) { return v; };
  Eigen::VectorXd displacement;
  const GmresResult solved = fgmres(apply, identity, dot, b, displacement, implicit_.tolerance, implicit_.max_iterations);
  implicit_stats_.products += solved.iterations;  // a failed solve's too: they were spent
  implicit_stats_.most_products = std::max(implicit_stats_.most_products, solved.iterations);
  if (!solved.converged)
    fail(step, fmt::format("the implicit coupling's solve stopped at {} flow steps with the residual at {:.3g} of its "
                           "start, above time.implicit_tolerance = {:.3g}",
                           solved.iterations, solved.residual, implicit_.tolerance),
         Cause::implicit_solve);
  // The step itself, with F - K dX.
  step_with(stiffness_times(displacement));
  // Where the nodes will move with this flow (advance_nodes' rule): checked before they do,
  // so that a fold or a wall there fails while a shorter step can still be taken.
  const Eigen::VectorXd end_velocity = interpolated();
  collectively([&] {
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const Capsule& c = capsule(ids[i]);
      check_step_end(step, ids[i], c.x + dt * step_motion(c, w, cblock(end_velocity, i)));
    }
  });
  end_velocity_ready_ = true;   // in each capsule's response (interpolate_velocities)
  implicit_stats_.steps += 1;  // taken (a step that failed above is taken again or stops the run)
  // Besides its flow steps: the stiffness (membrane), the spreadings (spreading) and the
  // interpolations with the solve's own work (interpolation).
  const double outside_flow = seconds_since(t0) - flow_seconds;
  implicit_seconds_ += outside_flow;
  times_.interpolation += outside_flow - membrane_seconds - (times_.spreading - spreading_before);
}

}  // namespace capsflow::ibm
