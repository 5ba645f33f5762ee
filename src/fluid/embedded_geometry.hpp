#pragma once
// Embedded walls on the tree (issue "Walls of any shape"): the one description of where the
// solids are that the operators, the coupling, the adaptation and the output ask. Made from a
// geometry::Solid, for every cell slot of every level of the local tree:
//   - volume(c): the fluid fraction of c's volume;
//   - faces()[d][c]: the fluid fraction of c's lower face along d (the slot convention of
//     faces.hpp: the upper face of a leaf is its upper neighbour's slot);
//   - for each cut active cell, its wall: area vector (the integral of the normal into the
//     solid), area and centroid, absolute.
// Leaves, halo and boundary cells get the cut of their own box (geometry::cut_cell, from the
// signed distance at the corners). Coarse values are then made consistent with the fine ones,
// as the flux-matching operators need: a parent's volume and faces are the means of its
// children's, and a leaf's face against a parent (a coarse face) the mean of the fine faces
// covering it, as restrict_faces does for velocities. The wall's area vector comes from the
// faces a cell ends up with, wall = h^(D-1) (face_lo - face_hi), so the discrete divergence
// theorem holds on every cell of every level.
//
// The brick's own walls are not embedded walls: a case without solids builds none of this.
// Evaluation is hierarchical: a cell whose centre is farther from the wall than its half
// diagonal (|phi| is a lower bound of the distance, geometry/solid.hpp) is wholly fluid or
// solid, and so are its descendants, so the solid is evaluated only near the wall and at the
// centres of the coarse cells around it. Along a periodic direction the corners are wrapped
// into the brick, so the cells on both sides of the seam see the same wall.
//
// N ranks: every rank evaluates its local tree (the same numbers for the same cell), then the
// ghosts take their owners' values, so a cell that is a parent on its owner but a leaf in
// another rank's local tree reads the same fractions everywhere.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "fluid/faces.hpp"
#include "geometry/solid.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

template <int D>
class EmbeddedGeometry {
 public:
  // Evaluates `solid` on t. Collective on N ranks.
  EmbeddedGeometry(const tree::Tree<D>& t, geometry::SolidPtr solid);

  // Evaluates again after the tree changed (an adaptation, a migration). Collective. A cell
  // whose box the last evaluation cut (the same level and key) takes that cut again instead
  // of evaluating the solid at its corners: the same numbers, since a cut depends on the box
  // and the solid only.
  void rebuild();
  // How many cut slots the last rebuild took from the one before it, and how many it cut.
  std::int64_t reused_cuts() const { return reused_cuts_; }
  std::int64_t evaluated_cuts() const { return evaluated_cuts_; }

  const geometry::Solid& solid() const { return *solid_; }
  const tree::Tree<D>& tree() const { return tree_; }
  // phi at the 2^D corners of cell c of level l (corner b: coordinate d = bit d of b), wrapped
  // along periodic directions: what the cut of c is made from.
  std::array<double, (1 << D)> corner_values(Index c, int l) const;
  // phi at corner k (integer coordinates on level l's lattice), wrapped along periodic
  // directions: the one place corners are made, so that every reader sees the same value.
  double corner_phi(std::array<std::int64_t, D> k, int l) const;
  // phi at a point of the brick (2D cases: the section z = 0 of the solid); > 0 in the fluid.
  double signed_distance(const tree::Point<D>& x) const;
  // Whether the box b, grown by `margin`, may reach the wall (false when it is surely all
  // fluid or all solid): for refinement along the walls.
  bool near_wall(const tree::Box<D>& b, double margin) const;
  // Whether the box b is surely all solid (no fluid, no wall): the brick's sides buried in a
  // solid are no walls of the flow.
  bool surely_solid(const tree::Box<D>& b) const;
  // Whether refining the box b (a cell of the tree, of level >= l - 1) down to level l would
  // make only cells without fluid: phi <= 0 at every corner of the cells of level l inside
  // it, the cut's own convention (geometry/cut_cell.hpp), so this is exact, not a bound.
  // The solid side of a wall then stays as coarse as the 2:1 balance allows.
  bool solid_at_level(const tree::Box<D>& b, int l) const;

  std::span<const double> volume() const { return volume_; }
  const FaceField<D>& faces() const { return faces_; }
  // The wall in active cell c: zero area outside cut cells.
  double wall_area(Index c) const { return wall_area_[static_cast<std::size_t>(c)]; }
  std::array<double, D> wall_normal_area(Index c) const;  // integral of n (into the solid)
  tree::Point<D> wall_centroid(Index c) const;
  // Per cell slot, kStencilUniform for the active cells away from the walls (all fluid, every
  // face open, no wall: the operators take their stencils as the brick's), kStencilEmpty for
  // those without fluid (every face closed, no wall: only their cell term), kStencilClosedFace
  // + k for the full cells with every face open but k (a wall on that face), kStencilArrays
  // for the rest (multigrid/coefficients.hpp, EmbeddedFaces).
  std::span<const std::uint8_t> uniform() const { return uniform_; }
  // The active cells of level l that the wall cuts (wall_area > 0), in index order.
  std::span<const Index> cut_cells(int l) const { return cut_cells_[static_cast<std::size_t>(l)]; }

 private:
  // A cut slot's own values (before the coarse levels are made consistent).
  struct CutValues {
    double volume = 0.0, wall_area = 0.0;
    std::array<double, 2 * D> face{};  // lower and upper along each direction
    std::array<double, D> wall_centroid{};
  };
  void store(Index c, const CutValues& v);
  CutValues values_at(Index c) const;
  // The corner values of cell c (wrapped along periodic directions), and its cut.
  void cut_cell_at(Index c, int l);
  // Slot c of level l gets the last evaluation's cut of the same key, if it made one.
  bool take_known_cut(int l, tree::Key key, Index c);
  // Keeps the cut slots' values (before the coarse levels are made consistent) by key.
  void remember_cuts();
  void evaluate_level(int l);
  // Level l's coarse faces and parents from the next level (final and exchanged).
  void make_coarse_consistent(int l);
  void collect_walls();

  const tree::Tree<D>& tree_;
  geometry::SolidPtr solid_;
  std::vector<double> volume_;
  FaceField<D> faces_;
  std::vector<double> wall_area_;
  std::array<std::vector<double>, D> wall_centroid_;  // absolute positions
  // Each active cell's upper face along d, kept with the cell (exchanged with it) for the
  // faces on the brick's upper sides, whose slots are boundary cells.
  std::array<std::vector<double>, D> upper_;
  std::vector<std::int8_t> side_;
  std::vector<std::uint8_t> uniform_;  // kStencil* (multigrid/coefficients.hpp)
  std::vector<std::vector<Index>> cut_cells_;
  // The last evaluation's cuts, per level sorted by key.
  struct KnownCut {
    tree::Key key = 0;
    CutValues values;
  };
  std::vector<std::vector<KnownCut>> known_cuts_;
  std::int64_t reused_cuts_ = 0, evaluated_cuts_ = 0;
};

extern template class EmbeddedGeometry<2>;
extern template class EmbeddedGeometry<3>;

}  // namespace capsflow::fluid
