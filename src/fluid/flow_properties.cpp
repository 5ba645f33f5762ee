// Variable density and viscosity: the transpose stress, and the NavierStokes stages that
// evaluate the properties and solve the viscous step with them. See flow_properties.hpp.
#include "fluid/flow_properties.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>

#include <fmt/format.h>

#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

namespace {

// kCorner<D>[i][j][si][sj]: the neighbour slot of offset (si ? +1 : -1) e_i + (sj ? +1 : -1) e_j.
template <int D>
constexpr auto kCorner = [] {
  std::array<std::array<std::array<std::array<int, 2>, 2>, D>, D> slot{};
  for (int i = 0; i < D; ++i)
    for (int j = 0; j < D; ++j)
      for (int si = 0; si < 2; ++si)
        for (int sj = 0; sj < 2; ++sj) {
          if (i == j) continue;
          tree::Offset<D> o{};
          o[i] = si ? 1 : -1;
          o[j] = sj ? 1 : -1;
          slot[i][j][si][sj] = tree::slot_of<D>(o);
        }
  return slot;
}();

}  // namespace

template <int D>
void transpose_stress(const tree::Tree<D>& t, const std::array<std::span<const double>, D>& u,
                      std::span<const double> mu_cells, const std::vector<double>& mu_faces, int i,
                      std::span<double> out, const std::vector<std::pair<Index, int>>* only) {
  constexpr int F = 2 * D;
  auto at = [&](Index c, int l, double h) {
    const tree::Level<D>& lv = t.level(l);
    const Index* row = lv.face_row(c);
    const double mu_c = mu_cells[c];
    double sum = 0.0;
    for (int j = 0; j < D; ++j)
      for (int s = 0; s < 2; ++s) {
        const double dmu = mu_faces[static_cast<std::size_t>(c) * F + 2 * j + s] - mu_c;
        if (dmu == 0.0) continue;  // constant mu: no term at all
        double g = 0.0;            // d_i u_j on the face
        if (j == i) {
          g = s ? (u[i][row[2 * i + 1]] - u[i][c]) / h : (u[i][c] - u[i][row[2 * i]]) / h;
        } else {
          const std::span<const double> uj = u[j];
          const auto& k = kCorner<D>[i][j];
          g = (uj[row[2 * i + 1]] + uj[lv.neighbor(c, k[1][s])] - uj[row[2 * i]] -
               uj[lv.neighbor(c, k[0][s])]) /
              (4.0 * h);
        }
        sum += s ? dmu * g : -dmu * g;
      }
    out[c] = sum / h;
  };
  if (!only) {
    for_each_leaf_level<D>(t, at);
    return;
  }
  const auto n = static_cast<std::int64_t>(only->size());
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
  for (std::int64_t k = 0; k < n; ++k) {
    const auto [c, l] = (*only)[static_cast<std::size_t>(k)];
    at(c, l, t.cell_size(l));
  }
}

template <int D>
std::vector<std::pair<Index, int>> varying_viscosity(const tree::Tree<D>& t, std::span<const double> mu_cells,
                                                     const std::vector<double>& mu_faces) {
  constexpr int F = 2 * D;
  std::vector<std::pair<Index, int>> out;
  std::vector<std::uint8_t> varies;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const Index n = lv.n_active;
    varies.assign(static_cast<std::size_t>(n), 0);
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
    for (Index i = 0; i < n; ++i) {
      if (!lv.leaf[i]) continue;
      const Index c = lv.base + i;
      for (int k = 0; k < F; ++k)
        if (mu_faces[static_cast<std::size_t>(c) * F + k] != mu_cells[c]) varies[static_cast<std::size_t>(i)] = 1;
    }
    for (Index i = 0; i < n; ++i)
      if (varies[static_cast<std::size_t>(i)]) out.push_back({lv.base + i, l});
  }
  return out;
}

template <int D>
void NavierStokes<D>::set_properties(Properties f) {
  if (!properties_) {  // scratch fields: refilled every step, so adapt only resizes them
    rho_field_ = tree_.add_field({.name = "rho", .prolongation = tree::Prolongation::none});
    mu_field_ = tree_.add_field({.name = "mu", .prolongation = tree::Prolongation::none});
  }
  properties_ = std::move(f);
  resize_scratch();
}

template <int D>
void NavierStokes<D>::update_properties() {
  const std::span<double> rho = tree_.values(rho_field_), mu = tree_.values(mu_field_);
  properties_(tree_, rho, mu);
  if (tree_.distributed()) {  // the face means read the neighbours: ghosts take their owners' values
    std::array<std::span<double>, 2> both{rho, mu};
    tree_.update_ghosts(tree::Distribution::Fields(both.data(), both.size()));
  }
  double rho_min = 1e300, mu_min = 1e300, rho_max = 0.0, nu_max = 0.0;
  for (const Index c : tree_.owned_leaves()) {
    rho_max = std::max(rho_max, rho[c]);
    rho_min = std::min(rho_min, rho[c]);
    mu_min = std::min(mu_min, mu[c]);
    nu_max = std::max(nu_max, mu[c] / rho[c]);
  }
  nu_max_ = tree_.global_max(nu_max);
  // The least over all ranks: it scales the viscous solves' tolerance, which must be one
  // number on every rank (a per-rank value let ranks stop at different cycles). NaN stays NaN.
  rho_min = -tree_.global_max(-rho_min);
  mu_min = -tree_.global_max(-mu_min);
  if (!(rho_min > 0.0) || !(mu_min > 0.0) || rho_min == 1e300 || mu_min == 1e300)
    throw std::invalid_argument(
        fmt::format("flow properties: min density {}, min viscosity {}: both must be > 0", rho_min, mu_min));
  rho_min_ = rho_min;
  // One density everywhere (inner fluids of another viscosity only): the projection and the
  // viscous solves keep their constant density terms, the cheaper operators.
  uniform_density_ = tree_.global_max(rho_max) == rho_min;
  properties_stale_ = false;
  if (!uniform_density_) face_coefficients<D>(tree_, rho, FaceMean::inverse_arithmetic, alpha_faces_);
  face_coefficients<D>(tree_, mu, FaceMean::harmonic, mu_faces_);
  // The explicit transpose stress, from the velocity at the start of the step (walls at
  // t^n), or with BDF2 its extrapolation to t^(n+1) (extrapolate_start): a
  // steady state then satisfies the full discrete stress balance exactly.
  std::array<std::span<const double>, D> u;
  for (int d = 0; d < D; ++d) {
    if (!transpose_velocity_[d].empty()) {
      u[d] = transpose_velocity_[d];
      continue;
    }
    tree_.sync(tree_.values(u_[d]), conditions_.velocity[d], tree::Prolongation::quadratic);
    u[d] = tree_.values(u_[d]);
  }
  // The cells whose every face has the constant viscosity of FlowOptions (outside the inner
  // fluids): the viscous operator takes their stencil as constant (EmbeddedFaces).
  const std::size_t slots = mu_faces_.size() / (2 * D);
  mu_uniform_.assign(slots, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t c = 0; c < slots; ++c) {
    bool uniform = true;
    for (int k = 0; k < 2 * D; ++k) uniform = uniform && mu_faces_[c * 2 * D + static_cast<std::size_t>(k)] == mu_;
    mu_uniform_[c] = uniform ? kStencilUniform : kStencilArrays;
  }
  if (embedded_) {
    // Embedded walls: the fractions times the face viscosities (the fractions' arrays hold
    // fraction * mu_), the cells uniform in both, and mu per cell slot for the walls' flux.
    if (!uniform_density_) embedded_density();
    embedded_mu_faces_.resize(viscous_faces_.size());
    embedded_mu_uniform_.assign(slots, 0);
    const std::span<const std::uint8_t> open_uniform = embedded_->uniform();
#pragma omp parallel for schedule(static)
    for (std::size_t c = 0; c < slots; ++c) {
      for (int k = 0; k < 2 * D; ++k) {
        const std::size_t i = c * 2 * D + static_cast<std::size_t>(k);
        embedded_mu_faces_[i] = viscous_faces_[i] * (mu_faces_[i] / mu_);
      }
      const std::uint8_t open = c < open_uniform.size() ? open_uniform[c] : kStencilArrays;
      const bool constant = constant_stencil(open);
      embedded_mu_uniform_[c] = open == kStencilEmpty ? kStencilEmpty : mu_uniform_[c] && constant ? open : kStencilArrays;
      // The constant stencils take the constant cell term rho / (theta dt) too.
      if (constant && !uniform_density_ && relative_density_[c] != 1.0) embedded_mu_uniform_[c] = kStencilArrays;
    }
    cell_mu_.assign(mu.begin(), mu.end());
    tree_.restrict_and_exchange(cell_mu_);
  }
  // Where the viscosity varies only (an inner fluid's membrane band); zero elsewhere.
  varying_ = varying_viscosity<D>(tree_, mu, mu_faces_);
  for (int d = 0; d < D; ++d) {
    std::fill(transpose_[d].begin(), transpose_[d].end(), 0.0);
    transpose_stress<D>(tree_, u, mu, mu_faces_, d, transpose_[d], &varying_);
  }
}

template <int D>
void NavierStokes<D>::stabilise_band(double h) {
  // With a transpose velocity only (BDF2 with a history, and every backward Euler or
  // Crank-Nicolson step: transpose_velocity_), and only as far as the step is stiff
  // at the finest cells: sigma x / (1 + x), x = nu h / dx^2 (one number on every rank). A
  // step short against the cells' viscous time is stable without it, and sigma's O(dt^2)
  // term then only adds error (TimeOrder.ImplicitBdf2WithAnInnerFluid).
  stabilised_ = false;
  if (transpose_velocity_[0].empty()) return;
  const double finest = tree_.cell_size(tree_.max_level());
  const double x = nu_max_ * h / (finest * finest);
  const double sigma = kTransposeStabilisation * x / (1.0 + x);
  stabilised_ = true;
  // mu_s: (1 + sigma) mu on the leaves where mu varies (every rank has them for its ghosts
  // too), mu elsewhere; its face means as mu_faces_'s. Kept in a member between steps: a
  // new array each step paid its page faults every step.
  const std::span<const double> mu = tree_.values(mu_field_);
  std::vector<double>& mu_s = stabilised_cell_mu_;
  mu_s.assign(mu.begin(), mu.end());
  for (const auto& [c, level] : varying_) mu_s[static_cast<std::size_t>(c)] *= 1.0 + sigma;
  face_coefficients<D>(tree_, mu_s, FaceMean::harmonic, stabilised_mu_faces_);
  const std::size_t slots = stabilised_mu_faces_.size() / (2 * D);
  stabilising_faces_.resize(stabilised_mu_faces_.size());
  stabilised_uniform_.assign(slots, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t c = 0; c < slots; ++c) {
    bool uniform = true;
    for (int k = 0; k < 2 * D; ++k) {
      const std::size_t i = c * 2 * D + static_cast<std::size_t>(k);
      stabilising_faces_[i] = stabilised_mu_faces_[i] - mu_faces_[i];
      uniform = uniform && stabilised_mu_faces_[i] == mu_;
    }
    stabilised_uniform_[c] = uniform ? kStencilUniform : kStencilArrays;
  }
  // The leaves with a stabilising face: the explicit difference is zero on every other one
  // (a leaf beside a finer region has its fine faces' mean, so it is listed if they are).
  stabilising_leaves_.clear();
  for (const Index c : tree_.leaves()) {
    const std::size_t first = static_cast<std::size_t>(c) * 2 * D;
    if (std::any_of(stabilising_faces_.begin() + first, stabilising_faces_.begin() + first + 2 * D,
                    [](double v) { return v != 0.0; }))
      stabilising_leaves_.push_back({c, tree_.level_of(c)});
  }
  if (!embedded_) return;
  // With embedded walls the same times the fluid fractions, and mu_s per cell slot for the
  // walls' flux; the differences with mu's too (zero on the uniform cells).
  embedded_stabilised_faces_.resize(viscous_faces_.size());
  embedded_stabilising_faces_.resize(viscous_faces_.size());
  embedded_stabilised_uniform_.assign(slots, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t c = 0; c < slots; ++c) {
    for (int k = 0; k < 2 * D; ++k) {
      const std::size_t i = c * 2 * D + static_cast<std::size_t>(k);
      embedded_stabilised_faces_[i] = viscous_faces_[i] * (stabilised_mu_faces_[i] / mu_);
      embedded_stabilising_faces_[i] = viscous_faces_[i] * (stabilising_faces_[i] / mu_);
    }
    const std::uint8_t flag = embedded_mu_uniform_[c];
    const bool constant = constant_stencil(flag);
    embedded_stabilised_uniform_[c] = constant && !stabilised_uniform_[c] ? kStencilArrays : flag;
  }
  tree_.restrict_and_exchange(stabilised_cell_mu_);
  stabilising_cell_mu_.resize(stabilised_cell_mu_.size());
  for (std::size_t c = 0; c < stabilised_cell_mu_.size(); ++c) stabilising_cell_mu_[c] = stabilised_cell_mu_[c] - cell_mu_[c];
}

template <int D>
void NavierStokes<D>::embedded_density() {
  // The projection's face coefficients: the fluid fractions (pressure_faces_ holds them
  // times 1/density) times each face's 1/rho; uniform where the cell is open and every face
  // has 1/density.
  const double inv_rho = 1.0 / options_.density;
  const std::span<const std::uint8_t> open_uniform = embedded_->uniform();
  const std::size_t slots = alpha_faces_.size() / (2 * D);
  embedded_alpha_faces_.resize(alpha_faces_.size());
  embedded_alpha_uniform_.assign(slots, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t c = 0; c < slots; ++c) {
    const std::uint8_t open = c < open_uniform.size() ? open_uniform[c] : kStencilArrays;
    bool constant = constant_stencil(open);
    for (int k = 0; k < 2 * D; ++k) {
      const std::size_t i = c * 2 * D + static_cast<std::size_t>(k);
      embedded_alpha_faces_[i] = pressure_faces_[i] * options_.density * alpha_faces_[i];
      constant = constant && alpha_faces_[i] == inv_rho;
    }
    embedded_alpha_uniform_[c] = open == kStencilEmpty ? kStencilEmpty : constant ? open : kStencilArrays;
  }
  // The viscous solves' cell term rho / (theta dt) per cell slot, relative to the density's;
  // a parent takes the mean of its children's (the mass it stands for).
  const std::span<const double> rho = tree_.values(rho_field_);
  relative_density_.resize(rho.size());
  for (std::size_t c = 0; c < rho.size(); ++c) relative_density_[c] = rho[c] * inv_rho;
  tree_.restrict_and_exchange(relative_density_);
  viscous_cells_.clear();  // remade with these densities by the next viscous solve
}

template <int D>
MultigridStats NavierStokes<D>::variable_viscous_solve(int d, double dt, double theta) {
  // rho (u - u*)/dt = theta div(mu grad u) + (1 - theta) div(mu grad u^n) + T, divided by
  // theta so that the operator's face coefficients are mu_f itself:
  //   div(mu grad u) - rho/(theta dt) u = -rho/(theta dt) u* - (1-theta)/theta div(mu grad u^n) - T/theta.
  std::span<double> u = tree_.values(u_[d]);
  const std::span<const double> rho = tree_.values(rho_field_);
  const std::vector<double>& transpose = transpose_[d];
  tree_.for_each_leaf([&](Index c) {
    lambda_[c] = -rho[c] / (theta * dt);
    rhs_[c] = lambda_[c] * u[c] - transpose[c] / theta;
  });
  if (theta < 1.0)  // explicit part at u^n (not u*: shift_by_g), walls at t^n
    subtract_explicit_half(d, dt, theta, EllipticOperator<D, FaceArray<D>>(tree_, {mu_faces_.data()}, {}, conditions_.velocity[d]));
  // The band's stabilisation (stabilise_band), its explicit half at transpose_velocity_: BDF2's
  // u_e (synced at t^(n+1) by extrapolate_start: the sides' values enter as in the solve), or
  // u^n (synced at t^n, as the transpose stress has always read it).
  if (stabilised_) {
    const EllipticOperator<D, FaceArray<D>> stabilising(tree_, {stabilising_faces_.data()}, {}, conditions_.velocity[d]);
    const std::span<const double> v = transpose_velocity_[d];
    const auto n = static_cast<std::ptrdiff_t>(stabilising_leaves_.size());
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const auto [c, level] = stabilising_leaves_[static_cast<std::size_t>(i)];
      rhs_[c] += stabilising.apply(tree_.level(level), c, tree_.cell_size(level), v);
    }
  }
  const std::vector<double>& faces = stabilised_ ? stabilised_mu_faces_ : mu_faces_;
  const std::vector<std::uint8_t>& uniform = stabilised_ ? stabilised_uniform_ : mu_uniform_;
  // The velocity tolerance in the residual's units, rho/(theta dt), with the smallest
  // density: a residual r moves a cell's velocity by about r theta dt / rho_c, so every cell
  // is then within the velocity tolerance (as the constant path, for constant rho).
  MultigridOptions opt = options_.viscous;
  opt.tolerance *= rho_min_ / (theta * dt);
  // Where a jump makes plain cycles grow the residual, the first such cycle hands over to the
  // Krylov iteration (as with embedded walls); converging cycles never see it.
  opt.krylov_on_growth = true;
  if (uniform_density_) {
    EllipticOperator<D, EmbeddedFaces<D>, ConstantCells> op(
        tree_, {.value = mu_, .data = faces.data(), .full = uniform.data()}, {-rho_min_ / (theta * dt)},
        conditions_.velocity[d]);
    choose_viscous_guess(d, dt, op);
    return solve(op, u, rhs_, mg_, opt);
  }
  // The multigrid relaxes parents too: they take the volume mean of their children's
  // (distributed: the ghosts' from their owners).
  tree_.restrict_and_exchange(lambda_);
  EllipticOperator<D, FaceArray<D>, CellArray> op(tree_, {faces.data()}, {lambda_.data()}, conditions_.velocity[d]);
  choose_viscous_guess(d, dt, op);
  return solve(op, u, rhs_, mg_, opt);
}

template void transpose_stress<2>(const tree::Tree<2>&, const std::array<std::span<const double>, 2>&,
                                  std::span<const double>, const std::vector<double>&, int,
                                  std::span<double>, const std::vector<std::pair<Index, int>>*);
template std::vector<std::pair<Index, int>> varying_viscosity<2>(const tree::Tree<2>&, std::span<const double>,
                                                                 const std::vector<double>&);
template std::vector<std::pair<Index, int>> varying_viscosity<3>(const tree::Tree<3>&, std::span<const double>,
                                                                 const std::vector<double>&);
template void transpose_stress<3>(const tree::Tree<3>&, const std::array<std::span<const double>, 3>&,
                                  std::span<const double>, const std::vector<double>&, int,
                                  std::span<double>, const std::vector<std::pair<Index, int>>*);
template void NavierStokes<2>::set_properties(Properties);
template void NavierStokes<3>::set_properties(Properties);
template void NavierStokes<2>::update_properties();
template void NavierStokes<3>::update_properties();
template void NavierStokes<2>::stabilise_band(double);
template void NavierStokes<3>::stabilise_band(double);
template void NavierStokes<2>::embedded_density();
template void NavierStokes<3>::embedded_density();
template MultigridStats NavierStokes<2>::variable_viscous_solve(int, double, double);
template MultigridStats NavierStokes<3>::variable_viscous_solve(int, double, double);

}  // namespace capsflow::fluid
