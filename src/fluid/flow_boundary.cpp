#include "fluid/flow_boundary.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "fluid/duct_profile.hpp"

namespace capsflow::fluid {

std::string side_name(int side) {
  static const char* kNames[] = {"x_lo", "x_hi", "y_lo", "y_hi", "z_lo", "z_hi"};
  return kNames[side];
}

namespace {

template <int D>
[[noreturn]] void fail(int side, const std::string& why) {
  throw std::invalid_argument(fmt::format("fluid.boundary.{}: {}", side_name(side), why));
}

// Normal inflow speed at x on `side`: the profile, scaled to the mean velocity.
template <int D>
std::function<double(const tree::Point<D>&)> inflow_speed(const SideFlow<D>& s, int side,
                                                          const tree::TreeOptions<D>& o) {
  const int n = side / 2;
  std::array<double, D> centre{}, half{};
  for (int d = 0; d < D; ++d) {
    half[d] = 0.5 * o.roots[d] * o.root_size;
    centre[d] = o.origin[d] + half[d];
  }
  const double sign = (side & 1) ? -1.0 : 1.0;  // entering the domain
  const double mean = s.mean_velocity * sign;
  switch (s.profile) {
    case InflowProfile::uniform:
      return [mean](const tree::Point<D>&) { return mean; };
    case InflowProfile::parabolic:
      return [=](const tree::Point<D>& x) {
        double v = mean;
        for (int d = 0; d < D; ++d) {
          if (d == n) continue;
          const double eta = (x[d] - centre[d]) / half[d];
          v *= 1.5 * (1.0 - eta * eta);  // mean of 1.5 (1 - eta^2) over [-1, 1] is 1
        }
        return v;
      };
    case InflowProfile::pipe: {
      if constexpr (D != 3) fail<D>(side, "the pipe profile needs a 3D domain");
      if (!(s.pipe_radius > 0.0) || !std::isfinite(s.pipe_radius)) fail<D>(side, "the pipe profile needs a radius > 0");
      const double r2 = s.pipe_radius * s.pipe_radius;
      const std::array<double, D> axis = s.pipe_centre;
      return [=](const tree::Point<D>& x) {
        double rho2 = 0.0;
        for (int d = 0; d < D; ++d)
          if (d != n) rho2 += (x[d] - axis[d]) * (x[d] - axis[d]);
        return rho2 < r2 ? 2.0 * mean * (1.0 - rho2 / r2) : 0.0;
      };
    }
    case InflowProfile::square_duct: {
      if constexpr (D != 3) fail<D>(side, "the square_duct profile needs a 3D domain");
      const int t1 = (n + 1) % D, t2 = (n + 2) % D;
      double a = half[t1], b = half[t2];
      const bool swap = a > b;
      if (swap) std::swap(a, b);
      const double scale = mean / duct_mean_velocity(a, b);
      const DuctProfileMemo profile(a, b);
      return [=](const tree::Point<D>& x) {
        double y = x[t1] - centre[t1], z = x[t2] - centre[t2];
        if (swap) std::swap(y, z);
        return scale * profile(y, z);
      };
    }
  }
  return {};
}

}  // namespace

template <int D>
FlowConditions<D> make_flow_conditions(const std::array<SideFlow<D>, 2 * D>& sides,
                                       const tree::TreeOptions<D>& o, const double* time) {
  FlowConditions<D> fc;
  for (int s = 0; s < 2 * D; ++s) {
    const SideFlow<D>& sf = sides[s];
    const int n = s / 2;
    const bool tree_periodic = o.periodic[n];
    const bool periodic = sf.kind == SideKind::periodic;
    if (periodic != (sides[s ^ 1].kind == SideKind::periodic))
      fail<D>(s, fmt::format("a periodic side must face a periodic side ({} is not)",
                             side_name(periodic ? s ^ 1 : s)));
    if (periodic != tree_periodic)
      fail<D>(s, periodic ? "periodic, but domain.periodic is false in that direction"
                          : "domain.periodic is true in that direction: the side must be periodic");
    if (periodic) continue;
    auto& p = fc.pressure.side[s];
    p = {sf.kind == SideKind::outflow ? tree::BcKind::dirichlet : tree::BcKind::neumann, 0.0, {}};
    for (int d = 0; d < D; ++d) {
      auto& u = fc.velocity[d].side[s];
      switch (sf.kind) {
        case SideKind::wall:
          u = {tree::BcKind::dirichlet, 0.0, {}};
          break;
        case SideKind::moving_wall:
          if (d == n && sf.velocity[d] != 0.0) fail<D>(s, "a moving wall must move tangentially (normal velocity 0)");
          u = {tree::BcKind::dirichlet, sf.velocity[d], {}};
          break;
        case SideKind::inflow:
          if (!(std::isfinite(sf.mean_velocity))) fail<D>(s, "inflow mean_velocity must be finite");
          u = {tree::BcKind::dirichlet, 0.0, d == n ? inflow_speed<D>(sf, s, o) : nullptr};
          break;
        case SideKind::outflow:
          u = {tree::BcKind::neumann, 0.0, {}};
          break;
        case SideKind::prescribed: {
          if (!sf.prescribed) fail<D>(s, "a prescribed side needs a velocity function");
          auto f = sf.prescribed;
          u = {tree::BcKind::dirichlet, 0.0, [f, d, time](const tree::Point<D>& x) { return f(x, d, *time); }};
          break;
        }
        case SideKind::periodic:
          break;
      }
    }
  }
  return fc;
}

template FlowConditions<2> make_flow_conditions<2>(const std::array<SideFlow<2>, 4>&, const tree::TreeOptions<2>&,
                                                   const double*);
template FlowConditions<3> make_flow_conditions<3>(const std::array<SideFlow<3>, 6>&, const tree::TreeOptions<3>&,
                                                   const double*);

}  // namespace capsflow::fluid
