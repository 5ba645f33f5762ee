#pragma once
// The operator L(a) = div(alpha grad a) + lambda a, cell-centred finite volumes on the tree.
//
// On a leaf c of size h with face neighbours n_k:
//   L(a)_c = sum_k F_k / h + lambda_c a_c,   F_k = alpha_k (a_{n_k} - a_c) / h
// where F_k is the flux per unit area out of c through face k. Neighbours are same-level
// cells (halo cells across a jump to a coarser region, boundary cells across a wall), except when
// the neighbour is a parent: then F_k is the mean of the 2^(D-1) fine fluxes through that
// face, each computed by the fine leaf against c's halo child. What leaves one side enters
// the other, so sum_c h^D L(a)_c telescopes to the boundary fluxes exactly (conservation).
//
// Relaxation (smoothing of L(da) = r on the active cells of one level, the multigrid's
// level operator) uses the plain same-level stencil:
//   da_c <- (sum_k alpha_k da_{n_k} - h^2 r_c) / (sum_k alpha_k - h^2 lambda_c)
// by red-black Gauss-Seidel (colour = parity of i+j+k) or weighted Jacobi.
//
// Embedded walls (Walls = WallTerms, multigrid/wall_flux.hpp) add each cut cell's flux through
// its wall, a fixed stencil over its 3^D block; the relaxation takes the cell's own weight
// into the diagonal and the others' at their values when the colour's pass starts where a
// cell of the same colour is in the stencil (read before the pass, every thread and rank sees
// the same numbers), as the pass goes where not (WallFlux::lagged). The layer of full cells
// along a wall on grid faces (kStencilClosedFace) takes the constant stencil without that
// face, and its wall's column from WallFlux::face_column_self() in the relaxation. Without walls
// (NoWalls) nothing of it is compiled in.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "common/assert.hpp"
#include "fluid/multigrid/coefficients.hpp"
#include "fluid/multigrid/multigrid_options.hpp"
#include "fluid/multigrid/wall_flux.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

// Levels relaxed by several threads: in-place Gauss-Seidel makes each thread read, in
// every colour pass, cache lines the other has just written along the boundary between
// their ranges, and those transfers cost more than half the work of a small level (seed
// shell, 2 threads: a level of 21 568 cells relaxed in 38 us alone, 45 us split; 84 288
// cells 199 -> 134 us).
inline constexpr Index kRelaxParallelMin = 32768;

// Sweeps over sibling groups request, 16 groups ahead, the groups across the high side
// of each direction: in Morton order those are the neighbours not touched recently (the
// low ones were), and on a large level they come from memory. Measured (medians of
// interleaved runs, 1 thread): 128^3 relaxation -12%, residual -11%; 64^3 -9%, 0%.
inline constexpr Index kPrefetchGroups = 16;

// The cut cells' and the band's loops go parallel from this many cells: each costs a wall
// stencil (up to 27 weights) or a full update, several times a level's plain cell.
inline constexpr Index kWallListParallelMin = 512;

template <int D, class Alpha = ConstantFaces, class Lambda = ZeroCells, class Walls = NoWalls>
class EllipticOperator {
 public:
  static constexpr int kDimension = D;
  static constexpr int F = 2 * D;
  static constexpr int C = tree::kChildren<D>;

  EllipticOperator(const tree::Tree<D>& t, Alpha alpha, Lambda lambda, tree::BoundaryConditions<D> bc, Walls walls = {})
      : tree_(t), alpha_(alpha), lambda_(lambda), walls_(walls), bc_(std::move(bc)), correction_bc_(bc_.homogeneous()) {}

  const tree::Tree<D>& tree() const { return tree_; }
  const tree::BoundaryConditions<D>& bc() const { return bc_; }
  const tree::BoundaryConditions<D>& correction_bc() const { return correction_bc_; }
  // The halo groups this operator reads with weight 0 only, which its syncs may inject
  // (tree::Tree::injected_halos), or nullptr.
  const tree::InjectedHalos* injected_halos() const {
    if constexpr (requires { alpha_.injected; }) return alpha_.injected;
    else return nullptr;
  }

  // No Dirichlet side on a non-periodic direction and no lambda: a is defined up to a
  // constant and b must be compatible with the boundary fluxes.
  bool singular() const {
    if constexpr (std::is_same_v<Lambda, ZeroCells> || std::is_same_v<Lambda, PinnedCells>) {
      for (int s = 0; s < F; ++s)
        if (!tree_.options().periodic[s / 2] && bc_.side[s].kind == tree::BcKind::dirichlet) return false;
      return true;
    } else {
      return false;
    }
  }

  // Whether c is pinned out of the null space (PinnedCells: a cell without fluid).
  bool pinned(Index c) const
    requires std::is_same_v<Lambda, PinnedCells>
  {
    return lambda_.at(c) != 0.0;
  }

  // L(a) at leaf c of level l; a must be synced (tree::Tree::sync with bc()).
  double apply(const tree::Level<D>& lv, Index c, double h, std::span<const double> a) const {
    const Index* row = lv.face_row(c);
    if (lv.leaf[c - lv.base] != tree::Level<D>::kLeafNextToFiner)
      return plain(c, 1.0 / (h * h), a, [row](int k) { return row[k]; });
    const double ac = a[c];
    // A cell without fluid next to a finer region (the solid side of a wall kept coarse):
    // the fine faces covering its closed faces are closed too (EmbeddedGeometry makes a
    // coarse face their mean), so plain()'s short path gives the same numbers.
    if constexpr (kUniformCells)
      if (alpha_.empty(c)) return 0.0 + lambda_term(c, ac);
    // Fluxes times h, so that the sum is scaled once (no division per face).
    double sum = 0.0;
#pragma GCC unroll 6
    for (int k = 0; k < F; ++k) {
      const Index n = row[k];
      if (n < lv.active_end() && !lv.leaf[n - lv.base]) sum += fine_flux_times_h(lv, c, k, n, a);
      else sum += alpha_.at(c, k) * (a[n] - ac);
    }
    if constexpr (Walls::kActive) return sum * (1.0 / (h * h)) + lambda_term(c, ac) + wall_term(c, a);
    else return sum * (1.0 / (h * h)) + lambda_term(c, ac);
  }

  // res = b - L(a) on the leaves, and on every parent the volume mean of its children's
  // (the restriction a V-cycle starts from, done here while the group is in cache);
  // returns max |res| over the leaves this rank owns (a synced).
  double residual(std::span<const double> a, std::span<const double> b, std::span<double> res) const {
    CAPSFLOW_ASSERT(spans_cells(a) && spans_cells(b) && spans_cells(res),
                    "EllipticOperator::residual: a field does not have the tree's num_cells entries");
    double worst = 0.0;
    // Spans captured by value: through references the loop reloads their data pointers
    // after every store.
    auto residual_of = [res, b](Index c, double la) {
      res[c] = b[c] - la;
      return abs_or_infinity(res[c]);
    };
    // Distributed, the parents whose children straddle the end of this rank's range are
    // restricted again once those children came from their owner (Tree::exchange_restricted).
    for_each_leaf_value<true>(a, residual_of, worst, res);
    return worst;
  }

  // out = L(a) on the leaves (a synced).
  void apply_leaves(std::span<const double> a, std::span<double> out) const {
    CAPSFLOW_ASSERT(spans_cells(a) && spans_cells(out),
                    "EllipticOperator::apply_leaves: a field does not have the tree's num_cells entries");
    double unused = 0.0;
    for_each_leaf_value<false>(a, [out](Index c, double la) {
      out[c] = la;
      return 0.0;
    }, unused, out);
  }

  // `sweeps` smoothing sweeps of L(da) = res on the active cells of level l. The halo of
  // level l must hold the coarse correction; boundary cells are refilled here. With `corrected`
  // not empty, its leaves of level l get += da once da is final there: fused into the last
  // pass, which saves a pass over the finest level per cycle.
  void relax(int l, std::span<double> da, std::span<const double> res, int sweeps,
             const MultigridOptions& opt, std::span<double> scratch, std::span<double> corrected = {}) const {
    CAPSFLOW_ASSERT(spans_cells(da) && spans_cells(res) && (corrected.empty() || spans_cells(corrected)) &&
                        (opt.smoother != Smoother::jacobi || spans_cells(scratch)),
                    "EllipticOperator::relax: a field does not have the tree's num_cells entries");
    const tree::Level<D>& lv = tree_.level(l);
    CAPSFLOW_ASSERT(!Walls::kActive || opt.smoother == Smoother::red_black,
                    "EllipticOperator::relax: embedded walls are relaxed by red-black Gauss-Seidel only");
    Diagonal diag{tree_.cell_size(l) * tree_.cell_size(l), *this};
    if constexpr (Walls::kActive) diag.wall_others = scratch.data();
    // Level 0 (a few roots, not sibling groups) and a call without sweeps correct apart.
    const bool fuse = !corrected.empty() && l > 0 && sweeps > 0;
    for (int s = 0; s < sweeps; ++s) {
      const bool last = s + 1 == sweeps;
      if (opt.smoother == Smoother::red_black) {
        // No boundary refill between the colours: a boundary cell's source across a face is
        // the cell it touches, so black cells never read the boundary cell of a red one.
        // Distributed: each colour reads only the other one, so an exchange after each
        // gives every rank the numbers of one rank (a replicated level: every rank relaxes
        // every cell, with no exchange). A half-sweep changes its colour only: the ghosts
        // of the other one already hold their owners' values, and only half are sent.
        const bool exchange = !tree_.replicated_level(l);
        relax_wall_band(l, lv, diag, da, res, scratch, exchange, opt.wall_band_passes);
        lag_wall_terms(l, 0, da, scratch);
        relax_colour<0>(l, lv, diag, da, res, {});
        if (exchange) tree_.update_ghosts(l, da, 0);
        lag_wall_terms(l, 1, da, scratch);
        relax_colour<1>(l, lv, diag, da, res, fuse && last ? corrected : std::span<double>{});
        if (exchange) tree_.update_ghosts(l, da, 1);
      } else {
        const Index n = lv.n_active, base = lv.base;
        const double w = opt.jacobi_weight;
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
        for (Index i = 0; i < n; ++i) scratch[base + i] = (1.0 - w) * da[base + i] + w * updated(lv, base + i, diag, da, res);
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
        for (Index i = 0; i < n; ++i) {
          da[base + i] = scratch[base + i];
          if (fuse && last && lv.leaf[i]) corrected[base + i] += da[base + i];
        }
        if (!tree_.replicated_level(l)) tree_.update_ghosts(l, da);
      }
      tree_.fill_boundary_cells(l, da, correction_bc_);
    }
    if (!corrected.empty() && !fuse)
      for (Index i = 0; i < lv.n_active; ++i)
        if (lv.leaf[i]) corrected[lv.base + i] += da[lv.base + i];
  }

 private:
  static constexpr bool kConstantDiagonal = Alpha::kConstant && Lambda::kConstant;
  // Embedded walls: cells whose stencil is the fluid's constant one, or none (EmbeddedFaces).
  static constexpr bool kUniformCells = requires(const Alpha& alpha) { alpha.uniform(Index{}); };
  static_assert(!Walls::kActive || !Alpha::kConstant, "embedded walls need the face fractions in the face coefficients");

  bool spans_cells(std::span<const double> v) const { return v.size() == static_cast<std::size_t>(tree_.num_cells()); }

  // A closed-face cell's weights of its face neighbours (per closed face k: 0 for k, alpha
  // for the others).
  using ClosedFaces = std::array<std::array<double, F>, F>;

  // The relaxation's h^2 and, with constant coefficients, the inverse of its diagonal
  // (the same on every cell of a level): a multiplication per update instead of a
  // division, which was the critical path of a sweep. The constants are copied in (alpha
  // too) and the sweeps take a local copy: a store to da could otherwise alias them, and
  // the compiler reloaded them after every update.
  struct Diagonal {
    double h2 = 0.0, inverse = 0.0, alpha = 0.0;
    ClosedFaces closed;                   // closed-face cells' weights
    double closed_diagonal = 0.0;         // their diagonal without their wall,
    double column_diagonal = 0.0;         // and with it (WallFlux::face_column_self())
    const double* wall_others = nullptr;  // with walls: each cut cell's lagged stencil sum
    Diagonal(double h2_, const EllipticOperator& op) : h2(h2_) {
      if constexpr (Alpha::kConstant) alpha = op.alpha_.value;
      if constexpr (kConstantDiagonal) inverse = 1.0 / (F * alpha - h2 * op.lambda_.at(0));
      if constexpr (kUniformCells) {
        alpha = op.alpha_.value;
        inverse = 1.0 / (F * alpha - h2 * op.lambda_.uniform_value());
        closed_diagonal = (F - 1) * alpha - h2 * op.lambda_.uniform_value();
        for (int k = 0; k < F; ++k)
          for (int j = 0; j < F; ++j) closed[k][j] = j == k ? 0.0 : alpha;
        column_diagonal = closed_diagonal;
        // The smoother takes the walls' constant coefficient (a cell's own, at(c), is the
        // residual's): these cells have the fluid's constant one on every face.
        if constexpr (Walls::kActive) column_diagonal -= op.walls_.alpha * WallFlux<D>::face_column_self();
      }
    }
  };

  // The walls' part of L(a)_c (only compiled in with walls: x + 0.0 is not folded away).
  double wall_term(Index c, std::span<const double> a) const { return walls_.cut(c) ? walls_.term(c, a) : 0.0; }
  // In a smoother's pass, cut cell c's wall sum over the rest of its stencil: lagged, or read
  // now where it reads the other colour only (the same numbers: that colour is not changing).
  double wall_others(Index c, const Diagonal& dg, std::span<const double> da) const {
    return walls_.flux->lagged(c) ? dg.wall_others[c] : walls_.others(c, da);
  }

  // Before a colour's pass: each lagged cut cell of level l and that colour (WallFlux::lagged)
  // gets the walls' sum over the rest of its stencil, at the values da holds now, in scratch
  // (unused by red-black otherwise).
  void lag_wall_terms(int l, int colour, std::span<const double> da, std::span<double> scratch) const {
    if constexpr (Walls::kActive) {
      const std::span<const Index> cut = walls_.flux->lagged_cells(l, colour);
      const auto n = static_cast<Index>(cut.size());
#pragma omp parallel for schedule(static) if (n > kWallListParallelMin)
      for (Index i = 0; i < n; ++i) scratch[cut[i]] = walls_.others(cut[i], da);
    }
  }

  // Extra red-black passes over the cells near the walls (WallFlux::band;
  // MultigridOptions::wall_band_passes).
  void relax_wall_band(int l, const tree::Level<D>& lv, const Diagonal& dg, std::span<double> da, std::span<const double> res,
                       std::span<double> scratch, bool exchange, int passes) const {
    if constexpr (Walls::kActive) {
      if (passes > 0 && !walls_.flux->has_band())
        throw std::invalid_argument("EllipticOperator::relax: wall_band_passes > 0 with a WallFlux built without its band");
      for (int pass = 0; pass < passes; ++pass)
        for (int colour = 0; colour < 2; ++colour) {
          lag_wall_terms(l, colour, da, scratch);
          // A colour's cells read the other colour only (and the lagged sums): in any order.
          const std::span<const Index> band = walls_.flux->band(l, colour);
          const auto n = static_cast<Index>(band.size());
#pragma omp parallel for schedule(static) if (n > kWallListParallelMin)
          for (Index i = 0; i < n; ++i) da[band[i]] = updated(lv, band[i], dg, da, res);
          if (exchange) tree_.update_ghosts(l, da, colour);
        }
    }
  }

  // lambda_c a_c, left out for lambda = 0 (0 * a is not folded away by the compiler).
  double lambda_term(Index c, double ac) const {
    if constexpr (std::is_same_v<Lambda, ZeroCells>) return 0.0;
    else return lambda_.at(c) * ac;
  }

  // L(a)_c with the same-level stencil; nb(k) is c's neighbour across face k.
  template <class Neighbor>
  double plain(Index c, double inv_h2, std::span<const double> a, Neighbor nb) const {
    const double ac = a[c];
    double sum = 0.0;
    if constexpr (kUniformCells) {
      if (alpha_.uniform(c)) return uniform_plain(c, inv_h2, a, nb);
      if (const int closed = alpha_.closed_face(c); closed >= 0) {
#pragma GCC unroll 6
        for (int k = 0; k < F; ++k) sum += (k == closed ? 0.0 : a[nb(k)]);
        const double la = alpha_.value * (sum - (F - 1) * ac) * inv_h2 + lambda_.uniform_value() * ac;
        if constexpr (Walls::kActive) return la + wall_term(c, a);
        else return la;
      }
      // The array path's own numbers (closed faces add +0), without reading them.
      if (alpha_.empty(c)) return 0.0 + lambda_term(c, ac);
    }
    if constexpr (Alpha::kConstant) {
#pragma GCC unroll 6
      for (int k = 0; k < F; ++k) sum += a[nb(k)];
      sum = alpha_.value * (sum - F * ac);
    } else {
#pragma GCC unroll 6
      for (int k = 0; k < F; ++k) sum += alpha_.at(c, k) * (a[nb(k)] - ac);
    }
    if constexpr (Walls::kActive) return sum * inv_h2 + lambda_term(c, ac) + wall_term(c, a);
    else return sum * inv_h2 + lambda_term(c, ac);
  }

  // plain() and updated() on a uniform cell (EmbeddedFaces: the constant stencil; other
  // coefficients have no such cells).
  template <class Neighbor>
  double uniform_plain(Index c, double inv_h2, std::span<const double> a, Neighbor nb) const {
    if constexpr (kUniformCells) {
      const double ac = a[c];
      double sum = 0.0;
#pragma GCC unroll 6
      for (int k = 0; k < F; ++k) sum += a[nb(k)];
      return alpha_.value * (sum - F * ac) * inv_h2 + lambda_.uniform_value() * ac;
    } else {
      return plain(c, inv_h2, a, nb);
    }
  }
  template <class Neighbor>
  static double uniform_updated(Index c, const Diagonal& dg, std::span<const double> da, std::span<const double> res,
                                Neighbor nb) {
    double off = 0.0;
#pragma GCC unroll 6
    for (int k = 0; k < F; ++k) off += da[nb(k)];
    return (dg.alpha * off - dg.h2 * res[c]) * dg.inverse;
  }

  // One byte per cell of a sibling group, `byte` in those of a red-black colour (all for
  // colour -1).
  static constexpr std::uint64_t group_bytes(int colour, std::uint64_t byte) {
    std::uint64_t out = 0;
    for (int b = 0; b < C; ++b)
      if (colour < 0 || (std::popcount(static_cast<unsigned>(b)) & 1) == colour) out |= byte << (8 * b);
    return out;
  }
  // Whether the cells of the group at `first` of a colour (all for -1) are uniform cells:
  // one load of the group's flags, so that a group away from the walls takes the constant
  // stencil without a branch per cell.
  bool uniform_group(Index first, int colour) const {
    if constexpr (kUniformCells) {
      static_assert(C <= 8);
      std::uint64_t flags = 0;
      std::memcpy(&flags, alpha_.full + first, C);
      return (flags & group_bytes(colour, 0xff)) == group_bytes(colour, kStencilUniform);
    } else {
      return false;
    }
  }

  static void prefetch_high_neighbors(const tree::Level<D>& lv, Index group, const double* v) {
    const Index* gf = lv.group_face_row(group);
#pragma GCC unroll 3
    for (int k = 1; k < F; k += 2) __builtin_prefetch(v + gf[k]);
  }

  // Whether the 2^D cells of a group are all leaves without a finer neighbour.
  static bool all_plain_leaves(const std::uint8_t* leaf) {
    bool all = true;
    for (int b = 0; b < C; ++b) all &= leaf[b] == tree::Level<D>::kLeaf;
    return all;
  }

  template <int N>
  static double max_of(const double* v) {
    if constexpr (N == 1) return v[0];
    else return std::max(max_of<N / 2>(v), max_of<N / 2>(v + N / 2));
  }

  // f(c, L(a)_c) on every leaf, returning a value whose maximum lands in `worst`. Levels
  // >= 1 are walked by sibling groups (2D neighbour indices per group, not per cell);
  // leaves next to a finer region take the flux-matching path through their rows. With
  // kRestrict, each group's parent then gets the mean of out over the group (f has
  // written the leaves; the deepest level goes first, so parents below are done), as
  // Tree::restrict_level would.
  template <bool kRestrict, class Fn>
  void for_each_leaf_value(std::span<const double> a, Fn f, double& worst, std::span<double> out) const {
    double w = 0.0;
    for (int l = tree_.depth(); l >= 0; --l) {
      const tree::Level<D>& lv = tree_.level(l);
      const double h = tree_.cell_size(l);
      const Index base = lv.base;
      if (l == 0) {
        for (Index c = base; c < lv.active_end(); ++c)
          if (lv.leaf[c - base]) {
            const double value = f(c, apply(lv, c, h, a));
            if (tree_.owns(c)) w = std::max(w, value);
          }
        continue;
      }
      // Distributed: only the groups holding owned cells (the ghosts' values come from
      // their owners: the residual is restricted and exchanged afterwards).
      const auto range = tree_.owned_groups(l);
      const Index g_begin = range.first, g_end = range.second;
      const double inv_h2 = 1.0 / (h * h);
      const Index* parent = lv.group_parent.data();
      // f on the group's leaves, the parent restricted; returns their maximum. Masked: the
      // cells of other ranks stay out of it (their stencils may reach cells this rank does
      // not have).
      auto group_max = [&, f, a, out, parent, inv_h2, base, h](Index g, auto masked) {
        const Index first = base + g * C;
        const Index* gf = lv.group_face_row(g);
        if (g + kPrefetchGroups < g_end) prefetch_high_neighbors(lv, g + kPrefetchGroups, a.data());
        const std::uint8_t* leaf = lv.leaf.data() + (first - base);
        double value[C];
        if (all_plain_leaves(leaf) && uniform_group(first, -1)) {  // away from walls and jumps
#pragma GCC unroll 8
          for (int b = 0; b < C; ++b)
            value[b] =
                f(first + b, uniform_plain(first + b, inv_h2, a, [=](int k) { return tree::group_neighbor(first, gf, b, k); }));
        } else if (all_plain_leaves(leaf)) {  // the common case, without a branch per leaf kind
#pragma GCC unroll 8
          for (int b = 0; b < C; ++b)
            value[b] = f(first + b, plain(first + b, inv_h2, a, [=](int k) { return tree::group_neighbor(first, gf, b, k); }));
        } else {
#pragma GCC unroll 8
          for (int b = 0; b < C; ++b) {
            value[b] = 0.0;
            if (!leaf[b]) continue;
            const Index c = first + b;
            const double la = leaf[b] == tree::Level<D>::kLeafNextToFiner
                                  ? apply(lv, c, h, a)
                                  : plain(c, inv_h2, a, [=](int k) { return tree::group_neighbor(first, gf, b, k); });
            value[b] = f(c, la);
          }
        }
        if constexpr (decltype(masked)::value)
          for (int b = 0; b < C; ++b)
            if (!tree_.owns(first + b)) value[b] = 0.0;
        if constexpr (kRestrict) {
          double sum = 0.0;
          for (int b = 0; b < C; ++b) sum += out[first + b];
          out[parent[g]] = sum * (1.0 / C);
        }
        // A pairwise maximum: one running max per cell was a chain of dependent
        // instructions as long as the sweep, the residual's critical path.
        return max_of<C>(value);
      };
      // Distributed, the first and last groups may hold other ranks' cells (every group
      // of a replicated level may): those are masked, the others run unmasked.
      Index lo = g_begin, hi = g_end;
      if (tree_.distributed()) {
        if (tree_.replicated_level(l)) {
          for (Index g = lo; g < hi; ++g) w = std::max(w, group_max(g, std::true_type{}));
          continue;
        }
        if (lo < hi) w = std::max(w, group_max(lo++, std::true_type{}));
        if (lo < hi) w = std::max(w, group_max(--hi, std::true_type{}));
      }
#pragma omp parallel for schedule(static) reduction(max : w) firstprivate(group_max) if (lv.n_active > tree::kParallelMin)
      for (Index g = lo; g < hi; ++g) w = std::max(w, group_max(g, std::false_type{}));
    }
    worst = w;
  }

  // The relaxed value of da at c from its neighbours' current values; nb(k) as in plain().
  template <class Neighbor>
  double updated(Index c, const Diagonal& dg, std::span<const double> da, std::span<const double> res, Neighbor nb) const {
    const double h2 = dg.h2;
    double off = 0.0, diag = 0.0;
    if constexpr (kUniformCells) {
      if (alpha_.uniform(c)) return uniform_updated(c, dg, da, res, nb);
      if (const int closed = alpha_.closed_face(c); closed >= 0) {
        bool column = false;
        if constexpr (Walls::kActive) column = walls_.flux->face_column(c);
        const std::array<double, F>& weight = dg.closed[static_cast<std::size_t>(closed)];
#pragma GCC unroll 6
        for (int k = 0; k < F; ++k) off += weight[k] * da[nb(k)];
        diag = column ? dg.column_diagonal : dg.closed_diagonal;
        if constexpr (Walls::kActive) {
          if (!column && walls_.cut(c)) {
            off += h2 * wall_others(c, dg, da);
            diag -= h2 * walls_.self(c);
          }
        }
        return (off - h2 * res[c]) / diag;
      }
      if (alpha_.empty(c)) return (0.0 - h2 * res[c]) / (0.0 - h2 * lambda_.at(c));  // as below, off = diag = +0
    }
    if constexpr (Alpha::kConstant) {
      off = da[nb(0)];
#pragma GCC unroll 6
      for (int k = 1; k < F; ++k) off += da[nb(k)];
      off *= dg.alpha;
      if constexpr (kConstantDiagonal) return (off - h2 * res[c]) * dg.inverse;
      diag = F * dg.alpha;
    } else {
#pragma GCC unroll 6
      for (int k = 0; k < F; ++k) {
        const double a = alpha_.at(c, k);
        off += a * da[nb(k)];
        diag += a;
      }
    }
    if constexpr (Walls::kActive) {
      if (walls_.cut(c)) {
        off += h2 * wall_others(c, dg, da);
        diag -= h2 * walls_.self(c);
      }
    }
    return (off - h2 * res[c]) / (diag - h2 * lambda_.at(c));
  }
  double updated(const tree::Level<D>& lv, Index c, const Diagonal& dg, std::span<const double> da,
                 std::span<const double> res) const {
    const Index* row = lv.face_row(c);
    return updated(c, dg, da, res, [row](int k) { return row[k]; });
  }

  // Gauss-Seidel on one colour. Active cells of levels >= 1 come in sibling groups of 2^D
  // in child order, and the parity of i+j+k is the parity of the child number's bits; the
  // neighbours come from the group's row (tree::group_neighbor), folded to constants.
  // A non-empty `corrected` (levels >= 1) gets += da on the leaves after the update.
  template <int Colour>
  void relax_colour(int l, const tree::Level<D>& lv, const Diagonal& dg, std::span<double> da, std::span<const double> res,
                    std::span<double> corrected) const {
    const Index base = lv.base;
    if (base == 0) {  // level 0: roots are not sibling groups
      for (Index i = 0; i < lv.n_active; ++i)
        if ((std::popcount(lv.keys[i] & (C - 1)) & 1) == Colour) da[i] = updated(lv, i, dg, da, res);
      return;
    }
    if (!corrected.empty()) {
      relax_groups<Colour, true>(l, lv, dg, da, res, corrected);
      return;
    }
    relax_groups<Colour, false>(l, lv, dg, da, res, corrected);
  }

  template <int Colour, bool kCorrect>
  void relax_groups(int l, const tree::Level<D>& lv, const Diagonal dg, std::span<double> da, std::span<const double> res,
                    std::span<double> corrected) const {
    const Index base = lv.base;
    static constexpr auto kOfColour = [] {
      std::array<int, C / 2> of{};
      int next = 0;
      for (int b = 0; b < C; ++b)
        if ((std::popcount(static_cast<unsigned>(b)) & 1) == Colour) of[next++] = b;
      return of;
    }();
    // Distributed: the ghosts get their owners' values by the exchange after each colour.
    const auto range = tree_.owned_groups(l);
    const Index g_begin = range.first, g_end = range.second;
#pragma omp parallel for schedule(static) if (lv.n_active > kRelaxParallelMin)
    for (Index g = g_begin; g < g_end; ++g) {
      const Index first = base + g * C;
      const Index* gf = lv.group_face_row(g);
      if (g + kPrefetchGroups < g_end) prefetch_high_neighbors(lv, g + kPrefetchGroups, da.data());
      if (uniform_group(first, Colour)) {
#pragma GCC unroll 8
        for (int j = 0; j < C / 2; ++j) {
          const int b = kOfColour[j];
          da[first + b] = uniform_updated(first + b, dg, da, res, [=](int k) { return tree::group_neighbor(first, gf, b, k); });
        }
      } else {
#pragma GCC unroll 8
        for (int j = 0; j < C / 2; ++j) {
          const int b = kOfColour[j];
          da[first + b] = updated(first + b, dg, da, res, [=](int k) { return tree::group_neighbor(first, gf, b, k); });
        }
      }
      if constexpr (kCorrect) {
        const std::uint8_t* leaf = lv.leaf.data() + (first - base);
#pragma GCC unroll 8
        for (int b = 0; b < C; ++b)
          if (leaf[b]) corrected[first + b] += da[first + b];
      }
    }
  }

  // Flux per unit area out of leaf c through face k into the parent n, times c's size h:
  // the mean of the fine fluxes (gradients over h/2) between n's children and c's halo
  // children on that face.
  double fine_flux_times_h(const tree::Level<D>& lv, Index c, int k, Index n, std::span<const double> a) const {
    const int d = k / 2, side = k & 1;
    const Index halo = lv.first_child[c - lv.base];
    const Index fine = lv.first_child[n - lv.base];
    double sum = 0.0;
#pragma GCC unroll 8
    for (int b = 0; b < C; ++b) {
      if (tree::child_bit(b, d) != side) continue;
      const Index hc = halo + b, nc = fine + (b ^ (1 << d));
      sum += alpha_.at(nc, k ^ 1) * (a[nc] - a[hc]);
    }
    return sum * (2.0 / (C / 2));
  }

  const tree::Tree<D>& tree_;
  Alpha alpha_;
  Lambda lambda_;
  Walls walls_;
  tree::BoundaryConditions<D> bc_;
  tree::BoundaryConditions<D> correction_bc_;
};

}  // namespace capsflow::fluid
