// The advection stage of the centered solver: Bell-Colella-Glaz (1989) second-order
// upwind prediction of face values at t + dt/2, as in Basilisk's bcg.h and centered.h.
//
// For a face along d between cells L and R, with un = dt u_n / h and s = sign(un), the
// upwind cell i (L if s > 0, else R) gives
//   f_face = f_i + s (1 - s un) (df/dx_d)_i h / 2 + (dt/2) src_i
//            - dt v_t (f_i - f_{i-t}) / (2h)   for each transverse direction t (upwinded)
// 1. prediction: f = u_d on faces along d (advecting with the cell velocities), src = g +
//    (mu/rho) lap u_d; the face field is then projected with the half-step pressure pf.
// 2. advection: each component u_c is advanced conservatively with the projected uf,
//    u_c -= dt div(u_c,face uf), src = g_c + (mu/rho) lap u_c.
// With variable properties the viscous source is (1/rho)(div(mu grad u_c) + T_c), T the
// transpose stress of the step (flow_properties.hpp).
// The viscous term in the source keeps the predicted face values consistent at a steady
// state (Basilisk's source is g alone, which leaves an O(dt) = O(h) error of
// (dt/2) nu lap u in steady flows: measured here, the cavity error vs Ghia fell by only
// 1.3x from 64^2 to 128^2 without it).
// At a resolution jump whose upwind cell is a halo cell (the coarse side), the coarse
// leaf's slope is used and the transverse term dropped: first order there, only there.
// An upwind boundary cell (inflow) gives the boundary value.
#include <algorithm>
#include <cmath>

#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/navier_stokes.hpp"
#include "tree/prolongation.hpp"

namespace capsflow::fluid {

namespace {

// The slopes of every component along every direction on the leaves (central or minmod),
// halo injected: slope[c][d] = du_c/dx_d. Distributed: on the owned groups only; the
// ghosts' slopes come from their owners.
template <int D>
void slopes(const tree::Tree<D>& t, const std::array<std::span<const double>, D>& u, bool limited,
            std::array<std::array<std::vector<double>, D>, D>& out) {
  for_each_owned_leaf_level<D>(t, [&](Index c, int l, double h) {
    const Index* row = t.level(l).face_row(c);
    for (int k = 0; k < D; ++k) {
      const std::span<const double> f = u[k];
      for (int d = 0; d < D; ++d) {
        const double lo = f[row[2 * d]], hi = f[row[2 * d + 1]];
        out[k][d][c] = limited ? tree::minmod(hi - f[c], f[c] - lo) / h : (hi - lo) / (2.0 * h);
      }
    }
  });
  // Distributed: a ghost's slope from its owner (its own stencil may reach past the ghost
  // layer), before the halos copy it.
  std::array<std::span<double>, D * D> all;
  for (int k = 0; k < D; ++k)
    for (int d = 0; d < D; ++d) all[k * D + d] = out[k][d];
  t.update_ghosts(all);
  for (std::span<double> s : all) inject_halo<D>(t, s);
}

// The BCG face values (see above) of the components first..last of u on the face along d
// between lo and hi, into value[first..last]; `vt(e, i, row)` is the transverse velocity of
// cell i, whose face row is `row`. The components share the upwind cell and the transverse velocities, which is why they
// are computed together (each component's arithmetic is its own, in the same order).
template <int D, class Transverse>
void bcg_face(const tree::Level<D>& lv, int d, Index lo, Index hi, double h, double un, int first, int last,
              const std::array<std::span<const double>, D>& u,
              const std::array<std::array<std::vector<double>, D>, D>& slope,
              const std::array<std::span<const double>, D>& src, double src_step, double dt, Transverse&& vt,
              std::array<double, D>& value) {
  const double s = un > 0.0 ? 1.0 : -1.0;
  const Index i = s > 0.0 ? lo : hi;
  if (i >= lv.boundary_begin()) {  // boundary value
    for (int k = first; k <= last; ++k) value[k] = 0.5 * (u[k][lo] + u[k][hi]);
    return;
  }
  for (int k = first; k <= last; ++k)
    value[k] = u[k][i] + s * (1.0 - s * un) * slope[k][d][i] * 0.5 * h + src_step * src[k][i];
  if (i >= lv.active_end()) return;  // halo: no transverse neighbours
  const Index* row = lv.face_row(i);
  for (int e = 0; e < D; ++e) {
    if (e == d) continue;
    const double w = vt(e, i, row);
    const Index n = w < 0.0 ? row[2 * e + 1] : row[2 * e];
    for (int k = first; k <= last; ++k) {
      const double diff = w < 0.0 ? u[k][n] - u[k][i] : u[k][i] - u[k][n];
      value[k] -= dt * w * diff / (2.0 * h);
    }
  }
}

}  // namespace

template <int D>
void NavierStokes<D>::prediction_and_advection(double dt, StepStats& stats) {
  tree_.sync(g_);
  std::array<std::span<const double>, D> u, g;
  std::array<std::span<double>, D> velocity;
  for (int d = 0; d < D; ++d) u[d] = velocity[d] = tree_.values(u_[d]);
  // Sources: g + (mu/rho) lap u per component, valid on leaves and (injected) halos; the
  // Laplacian reads quadratic halos.
  tree_.sync(velocity, conditions_.velocity, tree::Prolongation::quadratic);
  for (int d = 0; d < D; ++d) {
    std::vector<double>& src = source_[d];
    const std::span<const double> gd = tree_.values(g_[d]);
    if (embedded_) {
      embedded_viscous_source(d, u[d], gd, src);
    } else if (properties_) {
      const EllipticOperator<D, FaceArray<D>> viscous(tree_, {mu_faces_.data()}, {}, conditions_.velocity[d]);
      viscous.apply_leaves(u[d], src);
      const std::span<const double> rho = tree_.values(rho_field_);
      const std::vector<double>& transpose = transpose_[d];
      tree_.for_each_owned_leaf([&](Index c) { src[c] = gd[c] + (src[c] + transpose[c]) / rho[c]; });
    } else {
      const EllipticOperator<D> laplacian(tree_, {mu_ / options_.density}, {}, conditions_.velocity[d]);
      laplacian.apply_leaves(u[d], src);
      tree_.for_each_owned_leaf([&](Index c) { src[c] += gd[c]; });
    }
    g[d] = src;
  }
  tree_.update_ghosts(components<D>(source_));  // distributed: as the slopes (owned leaves computed)
  for (int d = 0; d < D; ++d) inject_halo<D>(tree_, source_[d]);
  sync_velocity();  // back to the linear halos the slopes and faces use
  // 1. Prediction of the normal velocity on every face, then its approximate projection.
  // The slopes of every component, for the prediction (u_d along d) and the advection.
  std::array<std::array<std::vector<double>, D>, D>& sl = slope_;
  slopes<D>(tree_, u, options_.limited_slopes, sl);
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double h, const tree::Level<D>& lv) {
    const double un = dt * 0.5 * (u[d][lo] + u[d][hi]) / h;
    std::array<double, D> v;
    bcg_face<D>(lv, d, lo, hi, h, un, d, d, u, sl, g, 0.0, dt, [&](int e, Index i, const Index*) { return u[e][i]; }, v);
    // The source is the face mean of g, as Basilisk's (g[] + g[-1]) dt / 4.
    uf_[d][hi] = v[d] + 0.25 * dt * (g[d][lo] + g[d][hi]);
  });
  // Distributed: the ghosts' lower faces from their owners; the advection's transverse
  // velocities read the faces of the cells next to the owned ones.
  tree_.update_ghosts(components<D>(uf_));
  restrict_faces<D>(tree_, uf_);
  stats.prediction_cycles += project(uf_, pf_, 0.5 * dt, options_.projection, stats);

  // 2. Conservative advection of each component by the projected face velocity. With
  // embedded walls each face carries its open part's flux and each cell's fluid part takes
  // the balance, divided by at least half a cell (kSmallCell): the fluid parts smaller than
  // that change more slowly than their momentum balance asks (not conservative there), so
  // that small cut cells do not limit the time step.
  const FaceField<D>* open = open_faces();
  const std::span<const double> volume = embedded_ ? embedded_->volume() : std::span<const double>{};
  // flux[c][d]: of u_c through the faces along d.
  std::array<FaceField<D>*, D> flux{&scratch_faces_};
  for (int c = 1; c < D; ++c) flux[c] = &fluxes_[c - 1];
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double h, const tree::Level<D>& lv) {
    const double un = dt * uf_[d][hi] / h;
    std::array<double, D> f;
    bcg_face<D>(lv, d, lo, hi, h, un, 0, D - 1, u, sl, g, 0.5 * dt, dt, [&](int e, Index i, const Index* row) {
      return 0.5 * (uf_[e][i] + uf_[e][row[2 * e + 1]]);
    }, f);
    for (int c = 0; c < D; ++c) (*flux[c])[d][hi] = f[c] * uf_[d][hi] * (open ? (*open)[d][hi] : 1.0);
  });
  for (int c = 0; c < D; ++c) restrict_faces<D>(tree_, *flux[c]);
  std::array<std::span<double>, D> advected;
  for (int c = 0; c < D; ++c) advected[c] = tree_.values(u_[c]);
  // Distributed: owned groups only; the ghosts' new values come by the exchange below.
  for_each_owned_leaf_level<D>(tree_, [&](Index cell, int l, double h) {
    const Index* row = tree_.level(l).face_row(cell);
    const double fluid = embedded_ ? volume[static_cast<std::size_t>(cell)] : 1.0;
    for (int c = 0; c < D; ++c) {
      double div = 0.0;
      for (int d = 0; d < D; ++d) div += (*flux[c])[d][row[2 * d + 1]] - (*flux[c])[d][cell];
      if (!embedded_) {
        advected[c][cell] -= dt * div / h;
      } else if (fluid > 0.0) {
        advected[c][cell] -= dt * div / (h * std::max(fluid, kSmallCell));
      }
    }
  });
  // Distributed: the ghosts' new values from their owners.
  tree_.update_ghosts(advected);
}

template <int D>
void NavierStokes<D>::embedded_viscous_source(int d, std::span<const double> u, std::span<const double> g,
                                             std::vector<double>& src) {
  // (mu/rho) times the embedded viscous operator (fractions, the walls' flux with a moving
  // wall's value), per unit of each cell's fluid part (at least kSmallCell of the cell).
  const EmbeddedViscous v = embedded_viscous();
  const EllipticOperator<D, EmbeddedFaces<D>, ZeroCells, WallTerms<D>> viscous(
      tree_, {mu_, v.faces, v.uniform}, {}, conditions_.velocity[d], v.walls);
  const double* transpose = properties_ ? transpose_[d].data() : nullptr;
  viscous.apply_leaves(u, src);
  const std::span<const double> volume = embedded_->volume();
  tree_.for_each_owned_leaf([&](Index c) {
    const double fluid = volume[static_cast<std::size_t>(c)];
    if (!(fluid > 0.0)) {
      src[c] = 0.0;
      return;
    }
    double s = src[c] + (transpose ? fluid * transpose[c] : 0.0);
    if (wall_flux_->cut(c)) s += v.walls.at(c) * wall_flux_->wall(c) * wall_velocity(d, c);
    src[c] = g[c] + s / (cell_density(c) * std::max(fluid, kSmallCell));
  });
}

template void NavierStokes<2>::embedded_viscous_source(int, std::span<const double>, std::span<const double>,
                                                       std::vector<double>&);
template void NavierStokes<3>::embedded_viscous_source(int, std::span<const double>, std::span<const double>,
                                                       std::vector<double>&);
template void NavierStokes<2>::prediction_and_advection(double, StepStats&);
template void NavierStokes<3>::prediction_and_advection(double, StepStats&);

}  // namespace capsflow::fluid
