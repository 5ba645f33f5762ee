#pragma once
// The inside of a closed membrane on the tree (issue 29): I at a leaf's centre is
//   I = C(-d / h),
// with d the signed distance of the centre to the membrane (> 0 outside), h the cell size of
// the level the forces are spread at and C the cumulative integral of a kernel's 1D weight
// (kernels.hpp; the capsules' inner fluid takes the hat's, CapsuleCoupling::kInsideProfile):
// exactly 0 or 1 beyond the kernel's half support (h for the hat, 2h for the cosine kernel)
// from the membrane, and across it the profile that the kernel smoothing the sharp inside
// would give at a plane wall; the inside's integral then converges to the enclosed volume at
// second order in h.
//
// The membrane is cut as its flat triangles (membrane::flat_triangles). Whether a centre lies
// inside is the winding number along the grid line through it (geometry/axis_crossings.hpp:
// a line through an edge or a vertex is counted once, so a node on a cell face or a line
// along a node changes nothing). Its distance is the distance to the plane of a triangle the
// grid lines through it cross: of the three lines, the one most normal to the surface where
// it crosses nearest, so that the plane's error is O(d^2 / R) (R the radius of curvature); a
// distance whose side disagrees with the winding number takes the winding number's side.
// The cost is the crossings of the lines (a few per line) and one search per line for each
// cell near the membrane; a winding number or a nearest-triangle search per cell would
// visit the whole surface, or a tree of it, per cell.
//
// Basilisk's capsule module instead solves a Poisson problem for I from the spread surface
// normals: its I is exactly 0 and 1 only to the solver's tolerance, and it costs a Poisson
// solve each step.
#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "ibm/kernels.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm {

struct InsideCell {
  tree::Index cell = tree::kNone;
  double value = 0.0;  // I in (0, 1]
};

// I at the centre of every leaf this rank owns where I > 0, in the order of the space-filling
// curve (for each periodic image of the membrane that reaches the brick).
// vertices: the membrane's node positions (unwrapped across periodic sides: the nearest
// periodic image of the membrane counts); triangles: counter-clockwise seen from outside.
// level: where the forces are spread (the transition's h is that level's cell size).
[[nodiscard]] std::vector<InsideCell> inside_cells(const tree::Tree<3>& t, const Eigen::Matrix3Xd& vertices,
                                                   std::span<const std::array<int, 3>> triangles, KernelKind kernel,
                                                   int level);

}  // namespace capsflow::ibm
