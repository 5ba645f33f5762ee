#pragma once
// A forest of 2^D-trees (quadtrees, octrees) on a brick of root cubes, stored as linear,
// multilevel, Morton-ordered arrays (DESIGN.md, "The tree").
//
// Cells and their index. Every cell that exists at level L has a slot in level L's block of
// the global index space; the blocks follow each other by level, and a block is
//   [ active cells | halo cells | boundary cells ]
// - active cells are the leaves and their ancestors (parents), in Morton order;
// - halo cells are the children of a leaf that touches a parent of its own level: they give
//   every leaf of level L a full 3^D neighbourhood of level-L cells, holding values
//   prolonged from the coarse leaf (Basilisk's multilevel trees do the same);
// - boundary cells lie outside a non-periodic side and hold boundary-condition values.
// Words: a *boundary cell* is outside the brick (and, with embedded walls, will be outside the
// fluid); a *ghost* is a cell another rank owns that this rank holds a copy of (N ranks).
// A field is one flat array over all these slots (size num_cells()).
//
// Topology is rebuilt top-down after every change, in O(cells): the neighbours of the
// children of a parent P are children of P's own neighbours, so each level's neighbour
// tables come from the previous level's with no search and no hashing. Only active cells
// have neighbour rows (halo and boundary cells are filled from their parent or source), which
// keeps the topology near 120 bytes per active cell in 3D.
//
// Invariants kept by every change: the forest is 2:1 balanced across faces, edges and
// corners; every active cell has all 3^D - 1 neighbours at its own level (active, halo or
// boundary); siblings are contiguous; children appear in their parent's order.
//
// Partitioning (docs/parallel.md): leaves are ordered along the Morton curve of each level
// and a rebuild starts from a per-cell "refined" decision, so a rank builds the same
// structure from its own leaves plus a ghost layer without changing the rebuild.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "common/assert.hpp"
#include "parallel/exact_sum.hpp"
#include "tree/boundary.hpp"
#include "tree/geometry.hpp"
#include "tree/morton.hpp"
#include "tree/stencil.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::tree {

using Index = std::int32_t;
inline constexpr Index kNone = -1;
// Loops over fewer cells than this run on one thread: a parallel region costs more than
// the work on the coarse levels of a multigrid cycle.
inline constexpr Index kParallelMin = 4096;

// How a field's values reach new fine cells (refinement, halo filling); see
// prolongation.hpp. Restriction is always the volume average. `quadratic` is for halo
// values only (refinement uses linear then: it must conserve). `none` marks scratch
// fields: adapt() only resizes them.
enum class Prolongation : unsigned char { linear, limited, quadratic, none };

// Per level, one flag per halo group (no flags on a level without any): the groups a fill
// gives their coarse leaf's value (injection) instead of a prolongation, because no stencil
// that reads them weighs them (Tree::injected_halos).
using InjectedHalos = std::vector<std::vector<std::uint8_t>>;

template <int D>
struct FieldSpec {
  std::string name;
  Prolongation prolongation = Prolongation::linear;
  BoundaryConditions<D> bc = BoundaryConditions<D>::all(BcKind::neumann);
  // false: state of a stage that no checkpoint keeps (it is rebuilt when needed): the
  // checkpoint writer and reader leave it out.
  bool saved = true;
};

using FieldId = int;

// Position of child b's row within its group: children of even parity first.
template <int D>
inline constexpr auto kRowInGroup = [] {
  std::array<Index, kChildren<D>> pos{};
  Index next = 0;
  for (int parity = 0; parity < 2; ++parity)
    for (int b = 0; b < kChildren<D>; ++b)
      if ((__builtin_popcount(static_cast<unsigned>(b)) & 1) == parity) pos[b] = next++;
  return pos;
}();

// Face neighbour k = 2d + side of child b of the sibling group starting at `first`, whose
// Level::group_face row is `gf`: a sibling when bit d of b differs from side, else the
// mirror child of the adjacent group. With b and k constants it folds to one add.
constexpr Index group_neighbor(Index first, const Index* gf, int b, int k) {
  const int d = k >> 1;
  return (child_bit(b, d) == (k & 1) ? gf[k] : first) + (b ^ (1 << d));
}

// The cells of one level and their topology. Indices stored here are global.
template <int D>
struct Level {
  Index base = 0;  // global index of the first cell of the level
  Index n_active = 0, n_halo = 0, n_boundary = 0;
  std::vector<Key> keys;                 // active then halo cells
  std::vector<Index> face;               // n_active rows of kFaces<D> neighbours
  std::vector<Index> diag;               // n_active rows of kDiagonals<D> neighbours
  // Levels >= 1, one row of kFaces<D> per sibling group (active cells come in groups of
  // 2^D, the children of one parent): the first slot of the group across each face of the
  // parent. Child b's neighbour across face (d, side) is then a sibling, g + (b ^ 2^d), when
  // bit d of b differs from side, else group_face[side] + (b ^ 2^d): stencil sweeps read
  // 2D indices per group instead of 2D per cell (see group_neighbor).
  std::vector<Index> group_face;
  std::vector<Index> group_parent;       // levels >= 1, one per sibling group: the parent (level l-1)
  std::vector<Index> first_child;        // every slot: first of 2^D contiguous children, or kNone
  // Active cells: 0 for a parent, 1 for a leaf, 2 for a leaf with a parent among its face
  // neighbours (a resolution jump to a finer region: fluxes there need the fine side).
  std::vector<std::uint8_t> leaf;
  std::vector<Index> halo_parent;        // one per group of 2^D halo cells: the coarse leaf
  // The halo groups (0-based within the level's halo) that a face stencil of an active cell
  // reads, directly or through a boundary cell, or that the quadratic prolongation of a read halo
  // group of the next level reads (its coarse leaf's 3^D block). Around a thin refined
  // shell about half the groups: the others touch the fine region by an edge or a corner.
  std::vector<Index> halo_read;
  std::vector<Index> boundary_source;    // the cell a boundary cell takes its value from, or kNone
  std::vector<std::int8_t> boundary_side;  // the side (2d or 2d+1) it is filled across
  std::vector<Coords<D>> boundary_coords;  // integer coordinates (outside the brick)
  std::vector<Index> boundary_fill;      // those with a source, faces before edges before corners
  Index boundary_fill_faces = 0;         // how many of them are across a face (sources inside)
  // Scratch of the rebuild, kept to avoid allocation.
  std::vector<Index> old_index;          // active cells: the same cell in the previous tree
  std::vector<std::uint8_t> mark;

  Index size() const { return n_active + n_halo + n_boundary; }
  Index active_begin() const { return base; }
  Index active_end() const { return base + n_active; }
  Index halo_begin() const { return base + n_active; }
  Index halo_end() const { return base + n_active + n_halo; }
  Index boundary_begin() const { return halo_end(); }
  Index boundary_end() const { return base + size(); }
  // Row of the active cell c in the neighbour tables. Within each group of 2^D siblings
  // the rows are stored by colour (parity of i+j+k) first, so a red-black sweep reads half
  // of each group's rows per colour (kRowInGroup; the row arrays are padded to whole groups).
  static std::size_t row_of(Index local) {
    return static_cast<std::size_t>(local & ~Index{kChildren<D> - 1}) | kRowInGroup<D>[local & (kChildren<D> - 1)];
  }
  // Neighbour `slot` (see stencil.hpp) of the active cell c of this level. c must be an
  // active cell of this level: a global index of another level (or a halo cell) would
  // read some other cell's row without any memory error to show it.
  Index neighbor(Index c, int slot) const {
    CAPSFLOW_ASSERT(c >= active_begin() && c < active_end(), "Level::neighbor: not an active cell of this level");
    CAPSFLOW_ASSERT(slot >= 0 && slot < kStencil<D>, "Level::neighbor: slot outside [0, 3^D - 1)");
    const std::size_t r = row_of(c - base);
    return slot < kFaces<D> ? face[r * kFaces<D> + slot] : diag[r * kDiagonals<D> + slot - kFaces<D>];
  }
  const Index* face_row(Index c) const {
    CAPSFLOW_ASSERT(c >= active_begin() && c < active_end(), "Level::face_row: not an active cell of this level");
    return face.data() + row_of(c - base) * kFaces<D>;
  }
  const Index* group_face_row(Index group) const {
    CAPSFLOW_ASSERT(group >= 0 && group < n_active / kChildren<D>, "Level::group_face_row: no such sibling group");
    return group_face.data() + static_cast<std::size_t>(group) * kFaces<D>;
  }
  bool is_leaf(Index c) const {
    CAPSFLOW_ASSERT(c >= active_begin() && c < active_end(), "Level::is_leaf: not an active cell of this level");
    return leaf[c - base] != 0;
  }
  static constexpr std::uint8_t kLeaf = 1, kLeafNextToFiner = 2;
};

struct AdaptCounts {
  Index refined = 0;    // leaves split
  Index coarsened = 0;  // parents merged into a leaf
  Index leaves = 0;     // after the change
  Index cells = 0;      // all slots after the change
};

struct WaveletTolerance {
  FieldId field = 0;
  double tolerance = 1e-3;
};

template <int D>
struct AdaptOptions {
  std::vector<WaveletTolerance> criteria;  // refine where a wavelet exceeds its tolerance
  int min_level = 0;
  int max_level = -1;  // -1: the tree's max level
  // Forced refinement: the level a leaf must reach at least, given its box (0: none).
  std::function<int(const Box<D>&)> required_level;
  bool allow_coarsening = true;
  // Per cell slot, 0 where the criteria do not apply (empty: everywhere): the cells wholly
  // inside embedded solids, whose values are no flow (a wavelet across the wall would refine
  // the solid along it).
  std::span<const std::uint8_t> criteria_mask;
};

// A partitioned run's link between its local tree and the other ranks
// (tree/distributed_forest.hpp implements it; docs/parallel.md). The tree calls it inside
// sync() and the multigrid inside its cycle; a tree without one is the whole forest and
// makes no call. Every rank must call exchange() for the same levels in the same order:
// loops that exchange run over [0, global_depth()] on every rank.
class Distribution {
 public:
  virtual ~Distribution() = default;
  using Fields = std::span<const std::span<double>>;
  // Every ghost cell of level l (a cell of another rank that a stencil of this rank reads)
  // gets its owner's value of each field (one message per neighbour rank for all of them).
  virtual void exchange(int level, Fields fields) const = 0;
  // The same for every level at once: one message per neighbour rank (and one gather of the
  // replicated levels) for all levels and fields, where exchange() sends one per level.
  virtual void exchange_all(Fields fields) const = 0;
  // The same for the ghosts of one red-black colour only (the parity of the cell's
  // coordinate sum, Level::keys: popcount(key & (2^D - 1)) & 1): after a half-sweep that
  // changed that colour alone, half the values.
  virtual void exchange_colour(int level, std::span<double> v, int colour) const = 0;
  // One local value per rank combined over the ranks (parallel/reduce.hpp); sums exact.
  virtual double sum(const parallel::ExactSum& local) const = 0;
  virtual double max(double local) const = 0;  // NaN from any rank wins
  virtual std::int64_t sum(std::int64_t local) const = 0;
  virtual std::int64_t max(std::int64_t local) const = 0;
  // Whether every rank holds every cell of level l (ghosts of all the others): a rank then
  // computes on the whole level exactly as the others do, and a sweep needs no exchange.
  virtual bool replicated(int level) const = 0;
};

template <int D>
class Tree;

// The adaptation of a distributed tree (distributed_forest.hpp): given the local tree with
// its own refinement flags on the leaves it owns, agree with the other ranks on the global
// decision, repartition, and replace the tree by the new local one. Collective.
template <int D>
class DistributedAdaptation {
 public:
  virtual ~DistributedAdaptation() = default;
  virtual AdaptCounts adapt(Tree<D>& t, int min_level) = 0;
};

template <int D>
class DistributedForest;

template <int D>
class Tree {
 public:
  explicit Tree(const TreeOptions<D>& options);

  const TreeOptions<D>& options() const { return options_; }
  int max_level() const { return options_.max_level; }
  int depth() const { return depth_; }  // deepest level holding cells
  Index num_cells() const { return num_cells_; }
  Index num_leaves() const { return static_cast<Index>(leaves_.size()); }
  const Level<D>& level(int l) const {
    CAPSFLOW_ASSERT(l >= 0 && l <= options_.max_level, "Tree::level: level outside [0, max_level]");
    return levels_[l];
  }
  std::span<const Index> leaves() const { return leaves_; }

  // --- distribution (one rank: no distribution, every cell owned)
  // What a cell of a local tree is to this rank (only active cells are read).
  enum CellRole : std::uint8_t { kPlaceholder = 0, kOwnedCell = 1, kGhostCell = 2 };
  // Makes this tree the local tree of a partitioned run: `roles` has one CellRole per cell.
  // Collective (the global depth).
  void set_distribution(const Distribution* d, std::vector<std::uint8_t> roles,
                        DistributedAdaptation<D>* adaptation = nullptr);
  const Distribution* distribution() const { return dist_; }
  bool distributed() const { return dist_ != nullptr; }
  bool owns(Index c) const { return dist_ == nullptr || roles_[static_cast<std::size_t>(c)] == kOwnedCell; }
  // Whether c holds a real value after an exchange (owned, or a ghost of another rank's
  // cell), not a placeholder: loops whose values are read by owned cells' stencils but not
  // exchanged (the face loops) skip the placeholders.
  bool holds(Index c) const { return dist_ == nullptr || roles_[static_cast<std::size_t>(c)] != kPlaceholder; }
  // Distributed: the ghost leaves of level l outside owned_range(l) whose faces an owned
  // cell's stencil reads: the face neighbours of owned cells (an owned leaf reads its upper
  // neighbour's lower face, the advection the upwind neighbour's boundary and halo faces,
  // and an owned parent's face is restricted from its lower neighbour leaf), the children of
  // owned parents and of parents next to an owned leaf (the fine faces a coarse face is the
  // mean of). The face loops visit the owned groups and these only: the other ghosts' faces
  // are read by other ghosts only, whose values come from their owners.
  std::span<const Index> face_ghosts(int l) const { return face_ghosts_[static_cast<std::size_t>(l)]; }
  // The leaves this rank computes and reduces over: every leaf on one rank.
  std::span<const Index> owned_leaves() const { return dist_ ? std::span<const Index>(owned_leaves_) : leaves_; }
  // The sibling groups [first, second) of level l >= 1 that hold every cell this rank owns
  // there (owned cells of a level are one run of the curve, so one range): loops whose
  // results are exchanged afterwards need not compute the ghosts and placeholders outside
  // it (the whole level on one rank, and on a replicated level).
  std::pair<Index, Index> owned_groups(int l) const {
    // A replicated level is relaxed whole by every rank, with no exchange.
    if (dist_ == nullptr || static_cast<std::size_t>(l) >= owned_groups_.size() || dist_->replicated(l))
      return {0, levels_[l].n_active / kChildren<D>};
    return owned_groups_[static_cast<std::size_t>(l)];
  }
  // The level-local indices [begin, end) of the cells of owned_groups(l) (level 0, roots
  // and not sibling groups: the whole level).
  std::pair<Index, Index> owned_range(int l) const {
    if (l == 0) return {0, levels_[0].n_active};
    const auto [first, last] = owned_groups(l);
    return {first * kChildren<D>, last * kChildren<D>};
  }
  // The deepest level on any rank: the range of every loop that exchanges.
  int global_depth() const { return global_depth_; }
  bool replicated_level(int l) const { return dist_ != nullptr && dist_->replicated(l); }
  // The one verb of the distributed layer the solvers see: update the ghosts (each ghost
  // cell takes its owner's value; nothing on one rank). Scopes: every level (of one field or
  // of several at once: one message per neighbour rank for all), one level, one red-black
  // colour of a level (the relaxation's). Its reverse, "add what ghosts hold into their
  // owners", is not needed: sums over cells of several ranks (the capsules' spread forces)
  // are made where the cells are owned, in one rank's order (docs/parallel.md, "Capsules").
  void update_ghosts(std::span<double> v) const {
    if (dist_) dist_->exchange_all({&v, 1});
  }
  void update_ghosts(Distribution::Fields fields) const {
    if (dist_) dist_->exchange_all(fields);
  }
  void update_ghosts(int l, std::span<double> v) const {
    if (dist_) dist_->exchange(l, {&v, 1});
  }
  void update_ghosts(int l, Distribution::Fields fields) const {
    if (dist_) dist_->exchange(l, fields);
  }
  void update_ghosts(int l, std::span<double> v, int colour) const {
    if (dist_) dist_->exchange_colour(l, v, colour);
  }
  double global_sum(const parallel::ExactSum& local) const { return dist_ ? dist_->sum(local) : local.value(); }
  double global_max(double local) const { return dist_ ? dist_->max(local) : local; }
  std::int64_t global_sum(std::int64_t local) const { return dist_ ? dist_->sum(local) : local; }
  std::int64_t global_max(std::int64_t local) const { return dist_ ? dist_->max(local) : local; }
  // Leaves over all ranks.
  std::int64_t global_leaves() const { return global_sum(static_cast<std::int64_t>(owned_leaves().size())); }

  // --- cells
  int level_of(Index c) const;
  double cell_size(int l) const {
    CAPSFLOW_ASSERT(l >= 0 && l <= options_.max_level, "Tree::cell_size: level outside [0, max_level]");
    return cell_size_[l];
  }
  Coords<D> coords(Index c) const;  // integer coordinates on the uniform grid of its level
  Point<D> center(Index c) const;
  Box<D> box(Index c) const;
  Point<D> center_at(int l, const Coords<D>& ijk) const;

  // --- point location
  // Whether cell c's box holds x (to a few ulps of its faces).
  bool contains(Index c, const Point<D>& x) const;
  // The leaf containing x; throws std::out_of_range naming the point if x is outside.
  Index locate(const Point<D>& x) const;
  // The active or halo cell of level l at integer coordinates ijk (wrapped across periodic
  // sides), or kNone if no such cell exists or it lies outside the brick.
  Index find(int l, Coords<D> ijk) const;
  // The width^D cells of level l whose centres are nearest x (width even: the cells whose
  // centres lie within width/2 cells of x along each axis), lowest corner first, x fastest.
  // Entries are kNone where that cell does not exist.
  void cells_around(const Point<D>& x, int l, int width, std::vector<Index>& out) const;

  // --- loops (OpenMP-parallel; f(Index) must be safe to run concurrently)
  template <class F>
  void for_each_leaf(F&& f) const {
    const Index n = num_leaves();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
    for (Index i = 0; i < n; ++i) f(leaves_[i]);
  }
  // The leaves this rank owns (every leaf on one rank): for loops whose results on the
  // ghosts are overwritten by an exchange before anything reads them.
  template <class F>
  void for_each_owned_leaf(F&& f) const {
    const std::span<const Index> owned = owned_leaves();
    const auto n = static_cast<Index>(owned.size());
#pragma omp parallel for schedule(static) if (n > kParallelMin)
    for (Index i = 0; i < n; ++i) f(owned[i]);
  }
  template <class F>
  void for_each_cell_at_level(int l, F&& f) const {
    const Level<D>& lv = levels_[l];
    const Index b = lv.active_begin(), e = lv.active_end();
#pragma omp parallel for schedule(static) if (e - b > kParallelMin)
    for (Index c = b; c < e; ++c) f(c);
  }

  // --- fields: registered fields are carried through every adapt()
  FieldId add_field(FieldSpec<D> spec);
  int num_fields() const { return static_cast<int>(fields_.size()); }
  const FieldSpec<D>& field_spec(FieldId f) const { return fields_.at(f); }
  std::span<double> values(FieldId f) { return data_.at(f); }
  std::span<const double> values(FieldId f) const { return data_.at(f); }

  // --- one mechanism for every value outside the leaves
  // Parents of level l get the volume average of their children.
  void restrict_level(int l, std::span<double> v) const;
  // Halo cells of level l get values prolonged from their coarse leaf (level l-1): all of
  // them, or only the groups in Level::halo_read (enough for face stencils).
  // With `injected`, the flagged groups of face_read take their coarse leaf's value.
  enum class HaloCells : unsigned char { all, face_read };
  void fill_halo(int l, std::span<double> v, Prolongation p, HaloCells which = HaloCells::all,
                 const InjectedHalos* injected = nullptr) const;
  // Active cells of level l get values prolonged from their parents (level l-1), whose
  // face neighbours must hold valid values (the multigrid's coarse-to-fine step).
  void prolong_level(int l, std::span<double> v, Prolongation p) const;
  // Boundary cells of level l get the boundary-condition values (distributed: those whose
  // source holds a real value, Tree::collect_held_boundary_fill).
  void fill_boundary_cells(int l, std::span<double> v, const BoundaryConditions<D>& bc) const;
  // All of the above, in dependency order: restriction bottom-up, then level by level halo
  // and boundary cells top-down. After it every active cell reads valid values at all neighbours.
  void sync(std::span<double> v, const BoundaryConditions<D>& bc,
            Prolongation p = Prolongation::linear) const;
  void sync(FieldId f);
  // The same for several fields at once (distributed: one message per level and neighbour
  // rank for all of them): with one boundary condition per field, or the registered ones.
  void sync(Distribution::Fields fields, std::span<const BoundaryConditions<D>> bcs,
            Prolongation p = Prolongation::linear) const;
  void sync(std::span<const FieldId> fields);
  // Parents of levels [coarsest, depth) restricted bottom-up; distributed, the ghosts of
  // the leaves are first brought from their owners and each level's after its restriction,
  // so every cell a stencil of this rank reads holds the owner's value.
  void restrict_and_exchange(std::span<double> v, int coarsest = 0) const;
  void restrict_and_exchange(Distribution::Fields fields, int coarsest = 0) const;
  // v restricted on every group of owned_groups() (as the multigrid residual leaves it):
  // level by level from the deepest, the parents whose children straddle the end of this
  // rank's range are restricted again from their owners' values, then the level is
  // exchanged. Nothing on one rank.
  void exchange_restricted(std::span<double> v) const;
  // sync for readers of the leaves and their face neighbours only (the multigrid's
  // residual): parents are restricted only on the levels a halo prolongation reads (none
  // on a uniform tree) and only the halo groups in Level::halo_read are filled; the other
  // parents and halo cells keep stale values.
  void sync_leaf_neighbors(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p,
                           const InjectedHalos* injected = nullptr) const;
  // The halo groups of the coarse leaves flagged in `closed` (per cell slot) that no
  // prolongation to the next level reads (the 3^D block around a parent of its active or
  // halo groups). For an operator whose face coefficients vanish on every face of those
  // leaves (the solid side of an embedded wall), their halo values are read with weight 0:
  // a sync for it may inject them (the quadratic prolongation is most of a sync's cost).
  // Valid until the tree is rebuilt.
  InjectedHalos injected_halos(std::span<const std::uint8_t> closed) const;
  // After sync_leaf_neighbors with `injected`: those groups prolonged by p and the boundary
  // cells refilled, so that v holds what sync_leaf_neighbors without them gives.
  void refill_injected_halos(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p,
                             const InjectedHalos& injected) const;

  // --- adaptation
  // Normalised wavelet error max_f |v_f - prolongation from the parent| / tol_f for every
  // active cell of level >= 1 (0 at level 0). The fields must be synced.
  void wavelet_error(std::span<const WaveletTolerance> criteria, std::vector<float>& error) const;
  // Basilisk's adapt_wavelet plus forced refinement: refine leaves whose error exceeds 1 or
  // that lie below their required level, coarsen parents whose children are all leaves with
  // error <= 1/1.5 (one level per call), keep the 2:1 balance, carry every field.
  AdaptCounts adapt(const AdaptOptions<D>& options);
  // Refine and coarsen from per-cell flags (indexed by cell; only leaves are read): +1
  // refine, -1 coarsening candidate (a parent merges when all its children are candidates
  // and the balance allows), 0 keep. Balance is enforced; fields are carried.
  AdaptCounts apply_flags(std::span<const std::int8_t> flags, int min_level = 0);
  // Repeats adapt() with only forced refinement until nothing changes (initial meshes).
  AdaptCounts refine_to(const std::function<int(const Box<D>&)>& required_level,
                        int max_passes = 64);
  // A tree without fields of depth 0 becomes, in one rebuild, the tree whose level-l parents
  // are the cells with the keys split[l] (sorted, each a child of a level-(l-1) parent; the
  // caller balances them: tree_refined_to).
  void split_cells(std::span<const std::vector<Key>> split);

  // Bytes held by the topology (keys, neighbour tables, children, halo and boundary data,
  // leaf list), without fields and without rebuild scratch.
  std::size_t topology_bytes() const;

 private:
  void build_level0(Level<D>& lv, bool has_previous);
  // Builds the next tree into scratch_ from the current one and the decision, per current
  // cell, whether it has children in the next tree; carries fields; swaps.
  void rebuild(const std::vector<std::uint8_t>& refined_next);
  // rebuild() with the decision refined(level, the next tree's level, i) for the next tree's
  // active cell i (in_parallel: over threads).
  template <class Refined>
  void rebuild_deciding(Refined refined, bool in_parallel);
  void build_children(int l, std::vector<Level<D>>& next) const;
  void finish_boundary_cells(Level<D>& lv, int l) const;
  void transfer_fields(const std::vector<Level<D>>& next, int new_depth, Index cells);
  void collect_leaves();
  void collect_face_ghosts();  // face_ghosts_ for this distribution
  void collect_held_halos();   // held_halo_ for this distribution
  void collect_held_boundary_fill();  // held_boundary_fill_ for this distribution (after held_halo_)
  // Checked builds, N ranks: the boundary cells of level l that one rank would fill and this
  // rank's held_boundary_fill_ drops get NaN (as poison_dropped_halos).
  void poison_dropped_boundary_cells(int l, std::span<double> v) const;
  // sync's second half: halos (prolongation p, linear for none) and boundary cells, level by level.
  void fill_outside_leaves(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p) const;
  // Checked builds, N ranks: the halo groups of level l that one rank's fill would fill and
  // this rank's held_halo_ drops get NaN, so that a stencil reading one shows in the tests.
  void poison_dropped_halos(int l, std::span<double> v, HaloCells which) const;
  // fill_halo's loop: with `refill`, only the injected groups, prolonged.
  void fill_halo_groups(int l, std::span<double> v, Prolongation p, HaloCells which, const InjectedHalos* injected,
                        bool refill) const;
  // Level::halo_read of every level, from the deepest up (a level's list depends on the
  // next one's).
  void collect_halo_read();
  // Balances flags_ (per cell: +1 split, -1 merge candidate), decides, rebuilds; on a
  // distributed tree the distribution decides with the other ranks.
  AdaptCounts decide_and_rebuild(int min_level);
  // The decision alone: flags_ balanced, refined_next_ per cell (counts of this tree).
  AdaptCounts decide(int min_level);
  // The values a leaf's children get when it is refined (as adapt() gives them): C values.
  void child_values(Index leaf, FieldId f, double* out) const;
  friend class DistributedForest<D>;

  TreeOptions<D> options_;
  std::vector<double> cell_size_;
  std::vector<Index> root_index_;  // dense over the brick, x fastest
  std::vector<Level<D>> levels_;   // max_level + 1 entries; those deeper than depth_ are empty
  std::vector<Level<D>> scratch_;  // the next tree during a rebuild
  std::vector<Index> leaves_;
  int depth_ = 0;
  int global_depth_ = 0;  // depth_ on one rank
  // Distributed: the coarsest level any rank's owned cells read through a halo (parents
  // restricted down to it by sync_leaf_neighbors), and the coarsest level it must exchange
  // (that one, or the coarsest owned leaf on any rank).
  int leaf_sync_restrict_from_ = 0, leaf_sync_exchange_from_ = 0;
  const Distribution* dist_ = nullptr;
  DistributedAdaptation<D>* dist_adapt_ = nullptr;
  std::vector<std::uint8_t> roles_;  // per cell, distributed only: its CellRole
  std::vector<Index> owned_leaves_;
  std::vector<std::pair<Index, Index>> owned_groups_;  // per level, distributed only
  // Per level, distributed only: the halo groups (all, and those of Level::halo_read) whose
  // coarse leaf holds a real value (owned or ghost). The halos of placeholders are never
  // read by a stencil whose result reaches an owned cell (the ghost layer holds the coarse
  // block of every halo an owned or ghost stencil reads: distributed_forest.hpp), so
  // fill_halo skips them.
  std::array<std::vector<std::vector<Index>>, 2> held_halo_;  // [HaloCells], then level
  std::vector<std::vector<Index>> face_ghosts_;  // per level, distributed only
  // Per level, distributed only: Level::boundary_fill without the boundary cells whose source
  // is a placeholder, a halo group held_halo_ drops, or such a boundary cell (an edge or corner
  // filled from a dropped face one), in the same order; and how many are across a face.
  // Their values come from values no owned stencil reads, so fill_boundary_cells skips them (seed
  // shell, 2 ranks, 3 steps: fill_boundary_cells 8.60 M -> 6.82 M instructions a rank, against 9.37 M
  // on one rank).
  std::vector<std::vector<Index>> held_boundary_fill_;
  std::vector<Index> held_boundary_fill_faces_;
  Index num_cells_ = 0;

  std::vector<FieldSpec<D>> fields_;
  std::vector<std::vector<double>> data_;
  std::vector<std::vector<double>> data_scratch_;

  // adapt() scratch
  std::vector<float> error_;
  std::vector<std::int8_t> flags_;
  std::vector<std::uint8_t> refined_next_;
  std::vector<std::pair<Index, int>> balance_stack_;
};

extern template class Tree<2>;
extern template class Tree<3>;

}  // namespace capsflow::tree
