#pragma once
// Where the lines of a grid along one axis pierce a closed triangulated surface: for each line,
// the crossings sorted along the axis, each with the component of the crossed triangle's unit
// normal along the axis. The inside of a membrane on the tree (ibm/indicator.hpp) reads
// from them which cell centres lie inside (the winding number below a point) and how far a
// cell centre lies from the surface (the distance to the crossed triangle's plane).
//
// Axis a's lines run through the points with coordinates (b, c) = (a + 1, a + 2) mod 3 at
//   origin_b + (j + 1/2) h,  origin_c + (k + 1/2) h:
// the centres of a grid's cells of size h. A line through an edge or a vertex of the
// projected surface is counted once: each triangle's projection holds its inside and, of
// its edges, only those whose outward direction points into one half-plane (the "top-left"
// rule of rasterisers), and an edge's side test is computed from its lower endpoint for both
// triangles sharing it, so that their two values are exact negatives. A closed surface then
// gives every line the winding number of the surface at each point between its crossings.
#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace capsflow::geometry {

struct AxisCrossing {
  double s = 0.0;       // coordinate along the axis
  double normal = 0.0;  // the crossed triangle's unit normal along the axis (< 0: the line enters)
};

struct LineGrid {
  int axis = 0;
  std::array<double, 2> origin{};  // along (b, c)
  double h = 1.0;
  std::array<long, 2> lo{}, hi{};  // lines j in [lo[0], hi[0]], k in [lo[1], hi[1]]
};

class AxisCrossings {
 public:
  AxisCrossings() = default;
  // The crossings of the lines of `grid` with the triangles (vertex indices, counter-clockwise
  // seen from outside) of `vertices`.
  AxisCrossings(const Eigen::Matrix3Xd& vertices, std::span<const std::array<int, 3>> triangles, const LineGrid& grid);

  // Line (j, k)'s crossings in increasing s (empty outside the grid's range).
  [[nodiscard]] std::span<const AxisCrossing> line(long j, long k) const;
  // The surface's winding number at the point of line (j, k) at coordinate s: the lines come
  // from outside, entering adds 1 and leaving takes 1 (1 inside a closed outward surface).
  [[nodiscard]] int winding_below(long j, long k, double s) const;
  [[nodiscard]] const LineGrid& grid() const { return grid_; }

 private:
  [[nodiscard]] long index(long j, long k) const {
    return (j - grid_.lo[0]) * (grid_.hi[1] - grid_.lo[1] + 1) + (k - grid_.lo[1]);
  }
  LineGrid grid_;
  std::vector<long> start_;  // per line, its first crossing in crossings_ (CSR)
  std::vector<AxisCrossing> crossings_;
};

}  // namespace capsflow::geometry
