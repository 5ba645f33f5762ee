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
// one face (faces.hpp's visit), on the rank that owns the leaf computing that face.
template <int D, int N, class F>
std::array<double, N> face_sums(const tree::Tree<D>& t, F&& f) {
  std::array<parallel::ExactSum, N> total;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double h = t.cell_size(l);
    const Index base = lv.base, active_end = lv.active_end(), halo_begin = lv.halo_begin();
    const auto [begin, end] = t.owned_range(l);  // the whole level on one rank
#pragma omp parallel if (end - begin > tree::kParallelMin)
    {
      std::array<parallel::CompensatedSum, N> s;
      auto add = [&](int d, Index lo, Index hi, double hh, const tree::Level<D>& level) {
        const std::array<double, N> terms = f(d, lo, hi, hh, level);
        for (int k = 0; k < N; ++k) s[k].add(terms[k]);
      };
#pragma omp for schedule(static) nowait
      for (Index i = begin; i < end; ++i)
        if (lv.leaf[i] && t.owns(base + i)) detail::faces_of_leaf<D>(lv, base + i, h, active_end, halo_begin, add);
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
FlowEnergy flow_energy(NavierStokes<D>& ns) {
  tree::Tree<D>& t = ns.tree();
  std::array<tree::FieldId, D> ids;
  for (int d = 0; d < D; ++d) ids[d] = ns.velocity(d);
  t.sync(std::span<const tree::FieldId>(ids));  // ghosts hold the boundary values at ns.time()
  std::array<std::span<const double>, D> u;
  for (int d = 0; d < D; ++d) u[d] = t.values(ids[d]);
  const std::span<const double> p = t.values(ns.pressure());
  const FaceField<D>& uf = ns.face_velocity();
  // Before the first step (and after an adaptation) there is no projected face velocity: the
  // face mean of the cell velocity then gives u.n on the sides.
  const bool projected = ns.face_velocity_current();
  const bool advection = !ns.options().stokes;
  const FlowConditions<D>& conditions = ns.conditions();

  FlowEnergy e;
  e.kinetic = detail::leaf_integral<D>(t, [&](Index c) {
                double s = 0.0;
                for (int d = 0; d < D; ++d) s += u[d][c] * u[d][c];
                return 0.5 * ns.cell_density(c) * s;
              }).first;
  const auto [dissipation, boundary] = face_sums<D, 2>(t, [&](int d, Index lo, Index hi, double h,
                                                              const tree::Level<D>& lv) -> std::array<double, 2> {
    const double mu = ns.face_viscosity(d, lo, hi, lv);
    const double volume = volume_of<D>(h);
    const Index ghost = std::max(lo, hi);  // ghosts come last in a level
    if (ghost < lv.ghost_begin()) {
      double s = 0.0;
      for (int k = 0; k < D; ++k) s += (u[k][hi] - u[k][lo]) * (u[k][hi] - u[k][lo]);
      // Next to a coarser leaf (a halo cell on one side) the face stands for the dual cell
      // from the coarse centre to the fine one, 1.5 h long: the dual cells then tile the
      // domain along d, and the sum stays second order on adaptive grids.
      const double dual = ghost >= lv.halo_begin() ? 1.5 : 1.0;
      return {dual * mu * s * volume / (h * h), 0.0};
    }
    const Index c = ghost == hi ? lo : hi;
    double gradient2 = 0.0, work = 0.0, speed2 = 0.0;
    for (int k = 0; k < D; ++k) {
      const double at_face = 0.5 * (u[k][ghost] + u[k][c]);
      const double dn = (u[k][ghost] - u[k][c]) / h;  // outward derivative
      gradient2 += dn * dn;
      work += at_face * dn;
      speed2 += at_face * at_face;
    }
    // The pressure on the side from its condition (homogeneous: 0 where Dirichlet, the cell's
    // value where Neumann), not from the ghost, which the projection need not have refreshed.
    const int side = lv.ghost_side[static_cast<std::size_t>(ghost - lv.ghost_begin())];
    const double p_side = conditions.pressure.side[side].kind == tree::BcKind::dirichlet ? 0.0 : p[c];
    const double area = volume / h;
    const double normal = projected ? uf[d][hi] : 0.5 * (u[d][ghost] + u[d][c]);
    const double un = ghost == hi ? normal : -normal;  // outward normal velocity
    double power = mu * work * area - p_side * un * area;
    if (advection) power -= 0.5 * ns.cell_density(c) * speed2 * un * area;
    return {0.5 * mu * gradient2 * volume, power};
  });
  e.dissipation = dissipation;
  e.boundary_power = boundary;
  if (ns.variable_properties()) {  // the transpose stress's share: -sum u . T h^D
    const std::span<const double> mu = t.values(ns.viscosity_field());
    std::vector<double> stress(static_cast<std::size_t>(t.num_cells()), 0.0);
    for (int i = 0; i < D; ++i) {
      transpose_stress<D>(t, u, mu, ns.face_viscosities(), i, stress);
      e.dissipation -= detail::leaf_integral<D>(t, [&](Index c) { return u[i][c] * stress[c]; }).first;
    }
  }
  return e;
}

template <int D>
double face_power(const tree::Tree<D>& t, const FaceField<D>& force, const FaceField<D>& uf) {
  CAPSFLOW_ASSERT(spans_cells<D>(force, t) && spans_cells<D>(uf, t), "face_power: a face field does not span the tree");
  return face_sums<D, 1>(t, [&](int d, Index, Index hi, double h, const tree::Level<D>&) -> std::array<double, 1> {
    return {force[d][hi] * uf[d][hi] * volume_of<D>(h)};
  })[0];
}

template FlowEnergy flow_energy<2>(NavierStokes<2>&);
template FlowEnergy flow_energy<3>(NavierStokes<3>&);
template double face_power<2>(const tree::Tree<2>&, const FaceField<2>&, const FaceField<2>&);
template double face_power<3>(const tree::Tree<3>&, const FaceField<3>&, const FaceField<3>&);

}  // namespace capsflow::fluid
