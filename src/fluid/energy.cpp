// The flow's energy budget: kinetic energy, dissipation, boundary work, face power. The
// discrete definitions are in energy.hpp.
#include "fluid/energy.hpp"

#include <algorithm>
#include <array>

#include "parallel/compensated_sum.hpp"

namespace capsflow::fluid {

namespace {

template <int D>
double volume_of(double h) {
  double v = 1.0;
  for (int d = 0; d < D; ++d) v *= h;
  return v;
}

// N sums over the fine faces, each face once: f(d, lo, hi, h, level) returns the N terms of
// one face (faces.hpp's visit), on the rank that owns the leaf computing that face; the first
// sum's terms of a leaf of size h are multiplied by first_scale(h).
template <int D, int N, class F, class Scale>
std::array<double, N> face_sums(const tree::Tree<D>& t, F&& f, Scale&& first_scale) {
  std::array<parallel::ExactSum, N> total;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double h = t.cell_size(l);
    const Index base = lv.base, active_end = lv.active_end(), halo_begin = lv.halo_begin();
    const auto [begin, end] = t.owned_range(l);  // the whole level on one rank
    const double scale = first_scale(h);
#pragma omp parallel if (end - begin > tree::kParallelMin)
    {
      std::array<parallel::CompensatedSum, N> s;
      std::array<double, N> leaf_sum{};
      auto add = [&](int d, Index lo, Index hi, double hh, const tree::Level<D>& level) {
        const std::array<double, N> terms = f(d, lo, hi, hh, level);
        for (int k = 0; k < N; ++k) leaf_sum[k] += terms[k];
      };
#pragma omp for schedule(static) nowait
      for (Index i = begin; i < end; ++i)
        if (lv.leaf[i] && t.owns(base + i)) {
          // A leaf's faces in a fixed order, then one compensated term per leaf: the sum does
          // not depend on how the leaves are split over threads and ranks.
          leaf_sum.fill(0.0);
          detail::faces_of_leaf<D>(lv, base + i, h, active_end, halo_begin, add);
          leaf_sum[0] *= scale;
          for (int k = 0; k < N; ++k) s[k].add(leaf_sum[k]);
        }
#pragma omp critical(capsflow_face_sums)
      for (int k = 0; k < N; ++k) s[k].add_scaled_to(total[k], 1.0);
    }
  }
  std::array<double, N> out;
  for (int k = 0; k < N; ++k) out[k] = t.global_sum(total[k]);
  return out;
}

}  // namespace

template <int D>
double kinetic_energy(const NavierStokes<D>& ns) {
  const tree::Tree<D>& t = ns.tree();
  std::array<std::span<const double>, D> u;
  for (int d = 0; d < D; ++d) u[d] = t.values(ns.velocity(d));
  // With embedded walls, each cell's fluid part.
  const double* volume = ns.embedded() ? ns.embedded()->volume().data() : nullptr;
  return detail::leaf_integral<D>(t, [&](Index c) {
           double s = 0.0;
           for (int d = 0; d < D; ++d) s += u[d][c] * u[d][c];
           return 0.5 * ns.cell_density(c) * s * (volume ? volume[c] : 1.0);
         }).first;
}

template <int D>
FlowEnergy flow_energy(NavierStokes<D>& ns) {
  tree::Tree<D>& t = ns.tree();
  std::array<tree::FieldId, D> ids;
  for (int d = 0; d < D; ++d) ids[d] = ns.velocity(d);
  t.sync(std::span<const tree::FieldId>(ids));  // boundary cells hold the boundary values at ns.time()
  std::array<std::span<const double>, D> u;
  for (int d = 0; d < D; ++d) u[d] = t.values(ids[d]);
  const std::span<const double> p = t.values(ns.pressure());
  const FaceField<D>& uf = ns.face_velocity();
  // Before the first step (and after an adaptation) there is no projected face velocity: the
  // face mean of the cell velocity then gives u.n on the sides.
  const bool projected = ns.face_velocity_current();
  const bool advection = !ns.options().stokes;
  const FlowConditions<D>& conditions = ns.conditions();

  ns.refresh_properties();
  FlowEnergy e;
  e.kinetic = kinetic_energy(ns);
  // Per face: the dissipation without its factor mu h^(D-2) where mu is constant (the leaf's
  // sum is scaled once: every face of a leaf has the leaf's h), and the boundary power.
  const bool variable = ns.variable_properties();
  const double mu_constant = variable ? 1.0 : ns.face_viscosity(0, 0, 0, t.level(0));
  // Embedded walls: each face's fluid part (the solver's face coefficients).
  const FaceField<D>* open = ns.embedded() ? &ns.embedded()->faces() : nullptr;
  const auto [dissipation, boundary] = face_sums<D, 2>(t, [&](int d, Index lo, Index hi, double h,
                                                              const tree::Level<D>& lv) -> std::array<double, 2> {
    const double mu = (variable ? ns.face_viscosity(d, lo, hi, lv) : 1.0) * (open ? (*open)[d][hi] : 1.0);
    const Index outer = std::max(lo, hi);  // boundary cells come last in a level
    if (outer < lv.boundary_begin()) {
      double s = 0.0;
      for (int k = 0; k < D; ++k) s += (u[k][hi] - u[k][lo]) * (u[k][hi] - u[k][lo]);
      // Next to a coarser leaf (a halo cell on one side) the face stands for the dual cell
      // from the coarse centre to the fine one, 1.5 h long: the dual cells then tile the
      // domain along d, and the sum stays second order on adaptive grids.
      const double dual = outer >= lv.halo_begin() ? 1.5 : 1.0;
      return {dual * mu * s, 0.0};
    }
    const Index c = outer == hi ? lo : hi;
    double jump2 = 0.0, work = 0.0, speed2 = 0.0;
    for (int k = 0; k < D; ++k) {
      const double at_face = 0.5 * (u[k][outer] + u[k][c]);
      const double jump = u[k][outer] - u[k][c];  // h times the outward derivative
      jump2 += jump * jump;
      work += at_face * jump;
      speed2 += at_face * at_face;
    }
    // The pressure on the side from its condition (homogeneous: 0 where Dirichlet, the cell's
    // value where Neumann), not from the boundary cell, which the projection need not have refreshed.
    const int side = lv.boundary_side[static_cast<std::size_t>(outer - lv.boundary_begin())];
    const double p_side = conditions.pressure.side[side].kind == tree::BcKind::dirichlet ? 0.0 : p[c];
    const double area = volume_of<D>(h) / h;
    const double normal = projected ? uf[d][hi] : 0.5 * (u[d][outer] + u[d][c]);
    const double un = outer == hi ? normal : -normal;  // outward normal velocity
    double power = mu * mu_constant * work * area / h - p_side * un * area;
    if (advection) power -= 0.5 * ns.cell_density(c) * speed2 * un * area;
    return {0.5 * mu * jump2, power};
  }, [&](double h) { return mu_constant * volume_of<D>(h) / (h * h); });
  e.dissipation = dissipation;
  e.boundary_power = boundary;
  if (const WallFlux<D>* walls = ns.wall_flux()) {
    // The walls' flux mu q_c = mu grad u(x_w) . N / h^D (per unit volume, the wall's value
    // included). A moving wall (u_w) works on the fluid at sum_c u_w . mu q_c h^D; the rest of
    // u . mu q, -sum_c (u_c - u_w) . mu q_c h^D, is the walls' share of the dissipation.
    const double mu = ns.face_viscosity(0, 0, 0, t.level(0));
    const bool moving = !ns.wall_velocity()[0].empty();
    // Each cut cell's (u - u_w) . q and u_w . q.
    auto parts = [&](Index c, bool worked) {
      if (!walls->cut(c)) return 0.0;
      double sum = 0.0;
      for (int k = 0; k < D; ++k) {
        const double uw = ns.wall_velocity(k, c);
        sum += (worked ? uw : u[k][c] - uw) * walls->flux(c, u[k], uw);
      }
      return mu * sum;
    };
    const double share = detail::leaf_integral<D>(t, [&](Index c) { return parts(c, false); }).first;
    const double work = moving ? detail::leaf_integral<D>(t, [&](Index c) { return parts(c, true); }).first : 0.0;
    e.dissipation -= share;
    e.boundary_power += work;
  }
  if (ns.variable_properties()) {  // the transpose stress's share: -sum u . T h^D
    const std::span<const double> mu = t.values(ns.viscosity_field());
    std::vector<double> stress(static_cast<std::size_t>(t.num_cells()), 0.0);
    for (int i = 0; i < D; ++i) {
      transpose_stress<D>(t, u, mu, ns.face_viscosities(), i, stress, &ns.varying_viscosity_leaves());
      e.dissipation -= detail::leaf_integral<D>(t, [&](Index c) { return u[i][c] * stress[c]; }).first;
    }
  }
  return e;
}

template <int D>
double face_power(const tree::Tree<D>& t, const FaceField<D>& force, const FaceField<D>& uf, const FaceField<D>* open) {
  CAPSFLOW_ASSERT(spans_cells<D>(force, t) && spans_cells<D>(uf, t), "face_power: a face field does not span the tree");
  return face_sums<D, 1>(
      t, [&](int d, Index, Index hi, double, const tree::Level<D>&) -> std::array<double, 1> {
        return {force[d][hi] * uf[d][hi] * (open ? (*open)[d][hi] : 1.0)};
      },
      [](double h) { return volume_of<D>(h); })[0];
}

template double kinetic_energy<2>(const NavierStokes<2>&);
template double kinetic_energy<3>(const NavierStokes<3>&);
template FlowEnergy flow_energy<2>(NavierStokes<2>&);
template FlowEnergy flow_energy<3>(NavierStokes<3>&);
template double face_power<2>(const tree::Tree<2>&, const FaceField<2>&, const FaceField<2>&, const FaceField<2>*);
template double face_power<3>(const tree::Tree<3>&, const FaceField<3>&, const FaceField<3>&, const FaceField<3>*);

}  // namespace capsflow::fluid
