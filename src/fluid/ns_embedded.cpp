// The flow solver's stages with embedded walls (navier_stokes.hpp, set_solid): the viscous
// and pressure operators weighted by the fluid fractions, the walls' no-slip flux, the
// divergence of each cell's fluid part, and nothing carried by closed faces or cells without
// fluid.
#include <stdexcept>
#include <utility>

#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/multigrid/embedded_coefficients.hpp"
#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

namespace {
// Where cut cells crowd a coarse cell (a wall sloping past a thin solid layer: a tube's
// constriction near the brick's walls) the coarse levels can misrepresent the fractions
// enough that plain cycles diverge slowly (measured: x1.05 a cycle); the first cycle that
// makes the residual grow hands over to the Krylov iteration, each solve afresh (a state kept
// between solves would break exact restarts).
MultigridOptions with_krylov_on_growth(MultigridOptions o) {
  o.krylov_on_growth = true;
  return o;
}
}  // namespace

template <int D>
void NavierStokes<D>::set_solid(geometry::SolidPtr solid) {
  if (!solid) throw std::invalid_argument("NavierStokes::set_solid: no solid");
  // The carried faces miss the walls (measured: half the drag of a cylinder array).
  if (options_.carry_faces) throw std::invalid_argument("embedded walls with carried faces (carry_faces): not implemented yet");
  solid_ = std::move(solid);
  embedded_.reset();
  rebuild_embedded();
}

template <int D>
void NavierStokes<D>::rebuild_embedded() {
  // In place after an adaptation: the cuts of the cells that did not change are kept, and
  // the arrays' memory (docs/walls.md, "Cost").
  if (embedded_) embedded_->rebuild();
  else embedded_ = std::make_unique<EmbeddedGeometry<D>>(tree_, solid_);
  wall_flux_ = std::make_unique<WallFlux<D>>(tree_, *embedded_, WallFlux<D>::Band::none);  // no band passes: embedded_viscous_solve
  embedded_face_coefficients<D>(tree_, *embedded_, 1.0 / options_.density, pressure_faces_);
  embedded_cell_coefficients<D>(tree_, *embedded_, 0.0, pressure_pins_);
  embedded_face_coefficients<D>(tree_, *embedded_, mu_, viscous_faces_);
  // The halos of the cells without fluid: the solves' syncs inject them instead of a
  // quadratic prolongation each (docs/walls.md, "Cost").
  {
    std::vector<std::uint8_t> closed(embedded_->uniform().size());
    for (std::size_t c = 0; c < closed.size(); ++c) closed[c] = embedded_->uniform()[c] == kStencilEmpty;
    injected_halos_ = tree_.injected_halos(closed);
  }
  viscous_cells_.clear();  // they depend on dt: made by the first viscous solve
  for (auto& w : wall_velocity_) w.clear();
  if (solid_->moves()) {
    for (auto& w : wall_velocity_) w.assign(static_cast<std::size_t>(tree_.num_cells()), 0.0);
    for (int l = 0; l <= tree_.depth(); ++l)
      for (const Index c : embedded_->cut_cells(l)) {
        const tree::Point<D> x = embedded_->wall_centroid(c);
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        for (int d = 0; d < D; ++d) p[d] = x[d];
        const Eigen::Vector3d v = solid_->wall_velocity(p);
        for (int d = 0; d < D; ++d) wall_velocity_[d][static_cast<std::size_t>(c)] = v[d];
      }
  }
  // Nothing flows where there is no fluid (a tree just refined has prolonged values there).
  const std::span<const double> volume = embedded_->volume();
  tree_.for_each_leaf([&](Index c) {
    if (volume[static_cast<std::size_t>(c)] > 0.0) return;
    for (int d = 0; d < D; ++d) tree_.values(u_[d])[c] = tree_.values(g_[d])[c] = 0.0;
  });
  const FaceField<D>& open = embedded_->faces();
  for (int d = 0; d < D; ++d)
    for (std::size_t k = 0; k < uf_[d].size(); ++k)
      if (!(open[d][k] > 0.0)) uf_[d][k] = 0.0;
}

template <int D>
typename NavierStokes<D>::EmbeddedViscous NavierStokes<D>::embedded_viscous() const {
  if (properties_)
    return {embedded_mu_faces_.data(), embedded_mu_uniform_.data(), WallTerms<D>{wall_flux_.get(), mu_, cell_mu_.data()}};
  return {viscous_faces_.data(), embedded_->uniform().data(), WallTerms<D>{wall_flux_.get(), mu_}};
}

template <int D>
MultigridStats NavierStokes<D>::embedded_viscous_solve(int d, double dt, double theta) {
  // As variable_viscous_solve, divided by theta, each cell's balance over its fluid part:
  //   div(mu fs grad u) + walls - cs rho/(theta dt) u = -cs rho/(theta dt) u* - (1-theta)/theta (...)(u^n).
  // A density that varies: rho = density * relative_density_ per cell (embedded_density).
  std::span<double> u = tree_.values(u_[d]);
  const double lambda = -options_.density / (theta * dt);
  const bool scaled = properties_ && !uniform_density_;
  if (viscous_cells_.size() != static_cast<std::size_t>(tree_.num_cells()) || viscous_lambda_ != lambda ||
      viscous_cells_scaled_ != scaled) {
    embedded_cell_coefficients<D>(tree_, *embedded_, lambda, viscous_cells_,
                                  scaled ? std::span<const double>(relative_density_) : std::span<const double>());
    viscous_lambda_ = lambda;
    viscous_cells_scaled_ = scaled;
  }
  const std::span<const double> volume = embedded_->volume();
  // A viscosity that varies adds the transpose stress over each cell's fluid part.
  const double* transpose = properties_ ? transpose_[d].data() : nullptr;
  tree_.for_each_leaf([&](Index c) {
    const double fluid = volume[static_cast<std::size_t>(c)] * (scaled ? relative_density_[c] : 1.0);
    rhs_[c] = lambda * fluid * u[c] - (transpose ? volume[static_cast<std::size_t>(c)] * transpose[c] / theta : 0.0);
  });
  const EmbeddedViscous v = embedded_viscous();
  const WallTerms<D>& walls = v.walls;
  const std::uint8_t* uniform = v.uniform;
  if (theta < 1.0)
    subtract_explicit_half(d, dt, theta,
                           EllipticOperator<D, EmbeddedFaces<D>, ZeroCells, WallTerms<D>>(
                               tree_, {mu_, v.faces, uniform}, {}, conditions_.velocity[d], walls));
  // A moving wall's no-slip value: its part of the wall flux, mu wall(c) u_wall, at the new
  // time and (Crank-Nicolson) the old one, is a source: 1/theta of it, as the rest is divided.
  if (!wall_velocity_[d].empty())
    for (int l = 0; l <= tree_.depth(); ++l) {
      const tree::Level<D>& lv = tree_.level(l);
      for (const Index c : wall_flux_->cut_cells(l))
        if (lv.is_leaf(c))
          rhs_[c] -= v.walls.at(c) * wall_flux_->wall(c) * wall_velocity(d, c) / theta;
    }
  // The band's stabilisation (stabilise_band): the solve takes mu_s, and its difference with
  // mu at transpose_velocity_ is explicit (the walls' flux homogeneous, as in the solve: a
  // moving wall's share is the source above; zero on the uniform cells).
  EmbeddedViscous solved = v;
  if (stabilised_) {
    solved = {embedded_stabilised_faces_.data(), embedded_stabilised_uniform_.data(),
              WallTerms<D>{wall_flux_.get(), mu_, stabilised_cell_mu_.data()}};
    EllipticOperator<D, EmbeddedFaces<D>, ZeroCells, WallTerms<D>>(
        tree_, {0.0, embedded_stabilising_faces_.data(), embedded_stabilised_uniform_.data()}, {}, conditions_.velocity[d],
        WallTerms<D>{wall_flux_.get(), 0.0, stabilising_cell_mu_.data()})
        .apply_leaves(transpose_velocity_[d], div_);
    tree_.for_each_leaf([&](Index c) { rhs_[c] += div_[c]; });
  }
  const EllipticOperator<D, EmbeddedFaces<D>, EmbeddedCells, WallTerms<D>> op(
      tree_, {mu_, solved.faces, solved.uniform, &injected_halos_}, {lambda, viscous_cells_.data(), solved.uniform},
      conditions_.velocity[d],
      solved.walls);
  MultigridOptions opt = with_krylov_on_growth(options_.viscous);
  opt.tolerance *= (properties_ ? rho_min_ : options_.density) / (theta * dt);  // as variable_viscous_solve
  // The cell term rho / (theta dt) holds the cells near the walls: the band passes bought
  // no cycle (seed channel in an embedded box: 4 cycles a step with and without) and cost
  // a sixth of the step; the steady sphere and cylinder arrays (dt = 0.2) ran 2.5x faster
  // without them, to the same drag.
  opt.wall_band_passes = 0;
  choose_viscous_guess(d, dt, op);
  return solve(op, u, rhs_, mg_, opt);
}

template <int D>
MultigridStats NavierStokes<D>::embedded_projection(FaceField<D>& uf, std::span<double> p, double dt,
                                                    const MultigridOptions& opt) {
  const FaceField<D>& open = embedded_->faces();
  divergence<D>(tree_, uf, div_, &open);  // of each cell's fluid part
  tree_.for_each_owned_leaf([&](Index c) { rhs_[c] = div_[c] / dt; });
  const bool density_varies = properties_ && !uniform_density_;  // embedded_density()'s coefficients
  const EllipticOperator<D, EmbeddedFaces<D>, PinnedCells> op(
      tree_,
      {1.0 / options_.density, density_varies ? embedded_alpha_faces_.data() : pressure_faces_.data(),
       density_varies ? embedded_alpha_uniform_.data() : embedded_->uniform().data(), &injected_halos_},
      {pressure_pins_.data()}, conditions_.pressure);
  const MultigridStats s = solve(op, p, rhs_, mg_, with_krylov_on_growth(opt));  // leaves p synced
  const double inv_rho = 1.0 / options_.density;
  for_each_face<D>(tree_, [&](int d, Index lo, Index hi, double h, const tree::Level<D>& lv) {
    const double alpha = density_varies ? face_coefficient<D>(lv, alpha_faces_, d, lo, hi) : inv_rho;
    uf[d][hi] = open[d][hi] > 0.0 ? uf[d][hi] - dt * alpha * (p[hi] - p[lo]) / h : 0.0;
  });
  return s;
}

template void NavierStokes<2>::set_solid(geometry::SolidPtr);
template void NavierStokes<3>::set_solid(geometry::SolidPtr);
template NavierStokes<2>::EmbeddedViscous NavierStokes<2>::embedded_viscous() const;
template NavierStokes<3>::EmbeddedViscous NavierStokes<3>::embedded_viscous() const;
template void NavierStokes<2>::rebuild_embedded();
template void NavierStokes<3>::rebuild_embedded();
template MultigridStats NavierStokes<2>::embedded_viscous_solve(int, double, double);
template MultigridStats NavierStokes<3>::embedded_viscous_solve(int, double, double);
template MultigridStats NavierStokes<2>::embedded_projection(FaceField<2>&, std::span<double>, double, const MultigridOptions&);
template MultigridStats NavierStokes<3>::embedded_projection(FaceField<3>&, std::span<double>, double, const MultigridOptions&);

}  // namespace capsflow::fluid
