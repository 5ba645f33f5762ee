// The fractions of a cut cell from its corner values (why a Freudenthal triangulation:
// cut_cell.hpp).
#include "geometry/cut_cell.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace capsflow::geometry {

namespace {

// Where the linear function crosses zero on the edge from a (f_a <= 0) to b (f_b > 0), as the
// fraction of the edge from a: in [0, 1), never a division by zero.
double crossing(double fa, double fb) { return fa / (fa - fb); }

// The fluid fraction of an N-simplex (N + 1 vertices) with linear values f: the simplex's
// measure times this is the measure of {f >= 0}. Closed forms by the number of solid
// vertices; only the tetrahedron split two-two needs positions, taken in the reference
// simplex (vertex i at e_i, vertex 0 at the origin), where a volume fraction is |det|.
template <int N>
double simplex_fluid_fraction(const std::array<double, N + 1>& f) {
  std::array<int, N + 1> solid{}, fluid{};
  int ns = 0, nf = 0;
  for (int i = 0; i <= N; ++i) (f[i] <= 0.0 ? solid[ns++] : fluid[nf++]) = i;
  if (ns == 0) return 1.0;
  if (nf == 0) return 0.0;
  if (ns == 1) {  // the solid is the small simplex at the solid vertex
    double s = 1.0;
    for (int j = 0; j < nf; ++j) s *= crossing(f[solid[0]], f[fluid[j]]);
    return 1.0 - s;
  }
  if (nf == 1) {  // the fluid is the small simplex at the fluid vertex
    double s = 1.0;
    for (int j = 0; j < ns; ++j) s *= 1.0 - crossing(f[solid[j]], f[fluid[0]]);
    return s;
  }
  if constexpr (N == 3) {
    // Two fluid vertices p, q and two solid ones a, b: the fluid is the prism with ends
    // (p, Ppa, Ppb) and (q, Pqa, Pqb), P the crossings, split into three tetrahedra.
    using V = Eigen::Vector3d;
    auto vertex = [](int i) { return i == 0 ? V(V::Zero()) : V(V::Unit(i - 1)); };
    auto point = [&](int from_solid, int to_fluid) {
      const double t = crossing(f[from_solid], f[to_fluid]);
      return V(vertex(from_solid) + t * (vertex(to_fluid) - vertex(from_solid)));
    };
    const int p = fluid[0], q = fluid[1], a = solid[0], b = solid[1];
    const V A0 = vertex(p), A1 = point(a, p), A2 = point(b, p);
    const V B0 = vertex(q), B1 = point(a, q), B2 = point(b, q);
    auto tet = [](const V& x0, const V& x1, const V& x2, const V& x3) {
      return std::abs((x1 - x0).cross(x2 - x0).dot(x3 - x0));
    };
    return std::clamp(tet(A0, A1, A2, B2) + tet(A0, A1, B1, B2) + tet(A0, B0, B1, B2), 0.0, 1.0);
  }
  return 0.0;  // unreachable: a triangle or a segment has one solid or one fluid vertex
}

// Appends triangle (a, b, c) as 9 coordinates (only triangles of positive area are kept: a
// wall through corners leaves degenerate pieces).
template <class V>
void add_triangle(std::vector<std::array<double, 9>>& out, const V& a, const V& b, const V& c) {
  out.push_back({a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]});
}

// The wall piece inside one simplex of the cell (positions in cell units): its area vector
// (into the solid), area and first moment (area times centroid), added to `cut`.
// triangles (3D): the piece's triangles are appended, each oriented out of the solid.
template <int D>
void add_wall_piece(const std::array<Eigen::Matrix<double, D, 1>, D + 1>& x, const std::array<double, D + 1>& f,
                    CellCut<D>& cut, Eigen::Matrix<double, D, 1>& moment,
                    std::vector<std::array<double, 9>>* triangles = nullptr) {
  using V = Eigen::Matrix<double, D, 1>;
  std::array<int, D + 1> solid{}, fluid{};
  int ns = 0, nf = 0;
  for (int i = 0; i <= D; ++i) (f[i] <= 0.0 ? solid[ns++] : fluid[nf++]) = i;
  if (ns == 0 || nf == 0) return;
  auto point = [&](int s, int fl) { return V(x[s] + crossing(f[s], f[fl]) * (x[fl] - x[s])); };
  // A fluid vertex lies strictly on the fluid side of the piece's plane (a solid one may
  // lie on it, at phi = 0), so it orients the normal.
  const V from_fluid = x[fluid[0]];
  V area_vector, centroid;
  double area = 0.0;
  if constexpr (D == 2) {
    const V q0 = point(solid[0], fluid[0]);
    const V q1 = ns == 1 ? point(solid[0], fluid[1]) : point(solid[1], fluid[0]);
    const V e = q1 - q0;
    area_vector = V(-e[1], e[0]);
    if (area_vector.dot(from_fluid - q0) > 0.0) area_vector = -area_vector;
    area = e.norm();
    centroid = 0.5 * (q0 + q1);
  } else {
    auto triangle = [](const V& a, const V& b, const V& c, V& vec, double& ar, V& mid) {
      vec = 0.5 * (b - a).cross(c - a);
      ar = vec.norm();
      mid = (a + b + c) / 3.0;
    };
    if (ns == 1 || nf == 1) {
      const int apex = ns == 1 ? solid[0] : fluid[0];
      const auto& others = ns == 1 ? fluid : solid;
      V q[3];
      for (int j = 0; j < 3; ++j) q[j] = ns == 1 ? point(apex, others[j]) : point(others[j], apex);
      triangle(q[0], q[1], q[2], area_vector, area, centroid);
      const bool flip = area_vector.dot(from_fluid - q[0]) > 0.0;
      if (flip) area_vector = -area_vector;
      if (triangles && area > 0.0) add_triangle(*triangles, q[0], flip ? q[1] : q[2], flip ? q[2] : q[1]);
    } else {  // the planar quadrilateral Ppa, Ppb, Pqb, Pqa (cyclic)
      const int a = solid[0], b = solid[1], p = fluid[0], q = fluid[1];
      const V pa = point(a, p), pb = point(b, p), qb = point(b, q), qa = point(a, q);
      V v1, v2, m1, m2;
      double a1 = 0.0, a2 = 0.0;
      triangle(pa, pb, qb, v1, a1, m1);
      triangle(pa, qb, qa, v2, a2, m2);
      area_vector = v1 + v2;  // the two halves are coplanar and equally oriented
      const bool flip = area_vector.dot(from_fluid - pa) > 0.0;
      if (flip) area_vector = -area_vector;
      if (triangles && a1 > 0.0) add_triangle(*triangles, pa, flip ? pb : qb, flip ? qb : pb);
      if (triangles && a2 > 0.0) add_triangle(*triangles, pa, flip ? qb : qa, flip ? qa : qb);
      area = a1 + a2;
      centroid = area > 0.0 ? V((a1 * m1 + a2 * m2) / area) : pa;
    }
  }
  for (int d = 0; d < D; ++d) cut.wall[d] += area_vector[d];
  cut.wall_area += area;
  moment += area * centroid;
}

// The cube's D! simplices: the volume is their fractions' sum over D!, which is exactly 1
// for a full cell (a sum of terms 1/6 is not: a cell touching a wall by a face would not be
// full, and would miss the operators' constant stencils).
constexpr double kSimplices[] = {1.0, 1.0, 2.0, 6.0};

}  // namespace

template <int D>
double face_fraction(const std::array<double, (1 << (D - 1))>& phi) {
  if constexpr (D == 2) {
    return simplex_fluid_fraction<1>({phi[0], phi[1]});
  } else {  // the two triangles of the diagonal from the lowest to the highest corner
    return 0.5 * (simplex_fluid_fraction<2>({phi[0], phi[1], phi[3]}) + simplex_fluid_fraction<2>({phi[0], phi[2], phi[3]}));
  }
}

namespace {
template <int D>
CellCut<D> cut_with_triangles(const std::array<double, (1 << D)>& phi, std::vector<std::array<double, 9>>* triangles) {
  constexpr int C = 1 << D;
  CellCut<D> cut;
  const bool all_fluid = std::ranges::all_of(phi, [](double v) { return v > 0.0; });
  const bool all_solid = std::ranges::all_of(phi, [](double v) { return v <= 0.0; });
  if (all_fluid || all_solid) {
    cut.volume = all_fluid ? 1.0 : 0.0;
    cut.face.fill(cut.volume);
    return cut;
  }
  // Faces: the corners with bit d = side, in the order of the other axes' bits.
  for (int d = 0; d < D; ++d)
    for (int side = 0; side < 2; ++side) {
      std::array<double, (1 << (D - 1))> on_face{};
      for (int j = 0; j < (1 << (D - 1)); ++j) {
        const int low = j & ((1 << d) - 1), high = (j >> d) << (d + 1);  // insert bit d
        on_face[static_cast<std::size_t>(j)] = phi[static_cast<std::size_t>(low | (side << d) | high)];
      }
      cut.face[static_cast<std::size_t>(2 * d + side)] = face_fraction<D>(on_face);
    }
  // Volume and wall: the D! simplices 0 -> e_p1 -> e_p1 + e_p2 -> ... -> (1, ..., 1).
  using V = Eigen::Matrix<double, D, 1>;
  std::array<int, D> order{};
  std::iota(order.begin(), order.end(), 0);
  double volume = 0.0;
  V moment = V::Zero();
  do {
    std::array<V, D + 1> x;
    std::array<double, D + 1> f{};
    int corner = 0;
    x[0] = V::Zero();
    f[0] = phi[0];
    for (int k = 0; k < D; ++k) {
      corner |= 1 << order[static_cast<std::size_t>(k)];
      for (int d = 0; d < D; ++d) x[static_cast<std::size_t>(k + 1)][d] = (corner >> d) & 1;
      f[static_cast<std::size_t>(k + 1)] = phi[static_cast<std::size_t>(corner)];
    }
    volume += simplex_fluid_fraction<D>(f);
    add_wall_piece<D>(x, f, cut, moment, triangles);
  } while (std::next_permutation(order.begin(), order.end()));
  static_assert(C == (1 << D));
  cut.volume = std::clamp(volume / kSimplices[D], 0.0, 1.0);
  if (cut.wall_area > 0.0)
    for (int d = 0; d < D; ++d) cut.wall_centroid[static_cast<std::size_t>(d)] = moment[d] / cut.wall_area;
  return cut;
}
}  // namespace

template <int D>
CellCut<D> cut_cell(const std::array<double, (1 << D)>& phi) {
  return cut_with_triangles<D>(phi, nullptr);
}

std::vector<std::array<double, 9>> wall_triangles(const std::array<double, 8>& phi) {
  std::vector<std::array<double, 9>> out;
  (void)cut_with_triangles<3>(phi, &out);
  return out;
}

template CellCut<2> cut_cell<2>(const std::array<double, 4>&);
template CellCut<3> cut_cell<3>(const std::array<double, 8>&);
template double face_fraction<2>(const std::array<double, 2>&);
template double face_fraction<3>(const std::array<double, 4>&);

}  // namespace capsflow::geometry
