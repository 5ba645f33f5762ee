// Embedded walls on the tree: cut cells evaluated near the wall, coarse values made
// consistent with the fine ones (why and how: embedded_geometry.hpp).
#include "fluid/embedded_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "fluid/multigrid/coefficients.hpp"
#include "geometry/cut_cell.hpp"
#include "tree/morton.hpp"

namespace capsflow::fluid {

namespace {

// The integer coordinates of any slot of level l (active, halo or boundary).
template <int D>
tree::Coords<D> slot_coords(const tree::Level<D>& lv, Index c) {
  const Index local = c - lv.base;
  if (local < lv.n_active + lv.n_halo) return tree::morton_decode<D>(lv.keys[static_cast<std::size_t>(local)]);
  return lv.boundary_coords[static_cast<std::size_t>(local - lv.n_active - lv.n_halo)];
}

// A box's centre and half diagonal: every point of the box lies within it of the centre.
template <int D>
std::pair<tree::Point<D>, double> centre_and_half_diagonal(const tree::Box<D>& b) {
  tree::Point<D> centre{};
  double squared = 0.0;
  for (int d = 0; d < D; ++d) {
    centre[d] = 0.5 * (b.lo[d] + b.hi[d]);
    squared += 0.25 * (b.hi[d] - b.lo[d]) * (b.hi[d] - b.lo[d]);
  }
  return {centre, std::sqrt(squared)};
}

}  // namespace

template <int D>
EmbeddedGeometry<D>::EmbeddedGeometry(const tree::Tree<D>& t, geometry::SolidPtr solid)
    : tree_(t), solid_(std::move(solid)) {
  if (!solid_) throw std::invalid_argument("EmbeddedGeometry: no solid");
  rebuild();
}

template <int D>
double EmbeddedGeometry<D>::signed_distance(const tree::Point<D>& x) const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int d = 0; d < D; ++d) p[d] = x[d];
  return solid_->signed_distance(p);
}

template <int D>
bool EmbeddedGeometry<D>::near_wall(const tree::Box<D>& b, double margin) const {
  const auto [centre, half_diagonal] = centre_and_half_diagonal<D>(b);
  // |phi| is a lower bound of the distance to the wall on both sides (geometry/solid.hpp).
  return !(std::abs(signed_distance(centre)) > half_diagonal + margin);
}

template <int D>
bool EmbeddedGeometry<D>::surely_solid(const tree::Box<D>& b) const {
  const auto [centre, half_diagonal] = centre_and_half_diagonal<D>(b);
  return signed_distance(centre) < -half_diagonal;
}

template <int D>
bool EmbeddedGeometry<D>::solid_at_level(const tree::Box<D>& b, int l) const {
  const tree::TreeOptions<D>& o = tree_.options();
  const double h = tree_.cell_size(l);
  // The lattice of level l's corners in integers (corner_phi, as the cuts read them), so
  // that a point reads the same phi here as in the cut of the cells that share it.
  std::array<std::int64_t, D> first{}, count{};
  std::int64_t points = 1;
  for (int d = 0; d < D; ++d) {
    first[d] = std::llround((b.lo[d] - o.origin[d]) / h);
    count[d] = std::llround((b.hi[d] - b.lo[d]) / h) + 1;
    if (count[d] > 3) throw std::logic_error("EmbeddedGeometry::solid_at_level: a box more than two cells of the level wide");
    points *= count[d];
  }
  for (std::int64_t i = 0; i < points; ++i) {
    std::array<std::int64_t, D> k{};
    std::int64_t rest = i;
    for (int d = 0; d < D; ++d) {
      k[d] = first[d] + rest % count[d];
      rest /= count[d];
    }
    if (corner_phi(k, l) > 0.0) return false;
  }
  return true;
}

template <int D>
std::array<double, D> EmbeddedGeometry<D>::wall_normal_area(Index c) const {
  const int l = tree_.level_of(c);
  const double area = std::pow(tree_.cell_size(l), D - 1);
  const Index* row = tree_.level(l).face_row(c);
  std::array<double, D> n{};
  for (int d = 0; d < D; ++d) n[d] = area * (faces_[d][c] - faces_[d][row[2 * d + 1]]);
  return n;
}

template <int D>
tree::Point<D> EmbeddedGeometry<D>::wall_centroid(Index c) const {
  tree::Point<D> x{};
  for (int d = 0; d < D; ++d) x[d] = wall_centroid_[d][static_cast<std::size_t>(c)];
  return x;
}

template <int D>
void EmbeddedGeometry<D>::rebuild() {
  // evaluate_level writes every slot of every level (the levels' active, halo and boundary
  // cells are all the slots: tree.hpp), so the arrays are not filled first (serial passes
  // over every slot).
  const auto n = static_cast<std::size_t>(tree_.num_cells());
  volume_.resize(n);
  wall_area_.resize(n);
  side_.resize(n);
  for (int d = 0; d < D; ++d) {
    faces_[d].resize(n);
    wall_centroid_[d].resize(n);
    upper_[d].resize(n);
  }
  reused_cuts_ = evaluated_cuts_ = 0;
  for (int l = 0; l <= tree_.depth(); ++l) evaluate_level(l);
  remember_cuts();
  // From the deepest level up, as Tree::restrict_and_exchange: a level's coarse values come
  // from the next level's, exchanged before, so that a parent whose children lie on several
  // ranks gets its owner's means (its own local subtree may stop at placeholder leaves).
  std::vector<std::span<double>> fields{volume_, wall_area_};
  for (int d = 0; d < D; ++d) {
    fields.emplace_back(faces_[d]);
    fields.emplace_back(wall_centroid_[d]);
    fields.emplace_back(upper_[d]);
  }
  const int deepest = tree_.distributed() ? tree_.global_depth() : tree_.depth();
  for (int l = deepest; l >= 0; --l) {
    if (l <= tree_.depth()) make_coarse_consistent(l);
    if (tree_.distributed()) tree_.update_ghosts(l, fields);
  }
  // A face on an upper side of the brick is the slot of the boundary cell beyond it, which
  // no exchange reaches: it takes the cell's own upper face (its owner's, for a ghost).
  for (int l = 0; l <= tree_.depth(); ++l) {
    const tree::Level<D>& lv = tree_.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      const Index* row = lv.face_row(c);
      for (int d = 0; d < D; ++d)
        if (row[2 * d + 1] >= lv.boundary_begin())
          faces_[d][static_cast<std::size_t>(row[2 * d + 1])] = upper_[d][static_cast<std::size_t>(c)];
    }
  }
  collect_walls();
}

template <int D>
std::array<double, (1 << D)> EmbeddedGeometry<D>::corner_values(Index c, int l) const {
  const tree::Coords<D> ijk = slot_coords<D>(tree_.level(l), c);
  std::array<double, (1 << D)> phi{};
  for (int b = 0; b < (1 << D); ++b) {
    std::array<std::int64_t, D> k{};
    for (int d = 0; d < D; ++d) k[d] = static_cast<std::int64_t>(ijk[d]) + ((b >> d) & 1);
    phi[static_cast<std::size_t>(b)] = corner_phi(k, l);
  }
  return phi;
}

template <int D>
double EmbeddedGeometry<D>::corner_phi(std::array<std::int64_t, D> k, int l) const {
  const tree::TreeOptions<D>& o = tree_.options();
  const double h = tree_.cell_size(l);
  tree::Point<D> x{};
  for (int d = 0; d < D; ++d) {
    if (o.periodic[d]) {  // wrapped in integers: both sides of the seam get the same point
      const std::int64_t cells = static_cast<std::int64_t>(o.roots[d]) << l;
      k[d] = ((k[d] % cells) + cells) % cells;
    }
    x[d] = o.origin[d] + static_cast<double>(k[d]) * h;
  }
  return signed_distance(x);
}

template <int D>
void EmbeddedGeometry<D>::store(Index c, const CutValues& v) {
  const auto s = static_cast<std::size_t>(c);
  volume_[s] = v.volume;
  wall_area_[s] = v.wall_area;
  for (int d = 0; d < D; ++d) {
    faces_[d][s] = v.face[static_cast<std::size_t>(2 * d)];
    upper_[d][s] = v.face[static_cast<std::size_t>(2 * d + 1)];
    wall_centroid_[d][s] = v.wall_centroid[static_cast<std::size_t>(d)];
  }
}

template <int D>
typename EmbeddedGeometry<D>::CutValues EmbeddedGeometry<D>::values_at(Index c) const {
  const auto s = static_cast<std::size_t>(c);
  CutValues v;
  v.volume = volume_[s];
  v.wall_area = wall_area_[s];
  for (int d = 0; d < D; ++d) {
    v.face[static_cast<std::size_t>(2 * d)] = faces_[d][s];
    v.face[static_cast<std::size_t>(2 * d + 1)] = upper_[d][s];
    v.wall_centroid[static_cast<std::size_t>(d)] = wall_centroid_[d][s];
  }
  return v;
}

template <int D>
void EmbeddedGeometry<D>::cut_cell_at(Index c, int l) {
  const tree::TreeOptions<D>& o = tree_.options();
  const double h = tree_.cell_size(l);
  const tree::Coords<D> ijk = slot_coords<D>(tree_.level(l), c);
  const geometry::CellCut<D> cut = geometry::cut_cell<D>(corner_values(c, l));
  CutValues v;
  v.volume = cut.volume;
  v.face = cut.face;
  v.wall_area = cut.wall_area * std::pow(h, D - 1);
  for (int d = 0; d < D; ++d)
    v.wall_centroid[static_cast<std::size_t>(d)] = o.origin[d] + (ijk[d] + cut.wall_centroid[static_cast<std::size_t>(d)]) * h;
  store(c, v);
}

template <int D>
bool EmbeddedGeometry<D>::take_known_cut(int l, tree::Key key, Index c) {
  if (static_cast<std::size_t>(l) >= known_cuts_.size()) return false;
  const std::vector<KnownCut>& known = known_cuts_[static_cast<std::size_t>(l)];
  const auto it = std::lower_bound(known.begin(), known.end(), key,
                                   [](const KnownCut& k, tree::Key x) { return k.key < x; });
  if (it == known.end() || it->key != key) return false;
  store(c, it->values);
  return true;
}

template <int D>
void EmbeddedGeometry<D>::remember_cuts() {
  known_cuts_.assign(static_cast<std::size_t>(tree_.depth() + 1), {});
  for (int l = 0; l <= tree_.depth(); ++l) {
    const tree::Level<D>& lv = tree_.level(l);
    std::vector<KnownCut>& known = known_cuts_[static_cast<std::size_t>(l)];
    auto keep = [&](Index begin, Index end) {
      for (Index i = begin; i < end; ++i) {
        const auto s = static_cast<std::size_t>(lv.base + i);
        if (side_[s] != 0) continue;  // inherited or beyond the reach: no cut was made
        known.push_back({lv.keys[static_cast<std::size_t>(i)], values_at(lv.base + i)});
      }
    };
    keep(0, lv.n_active);
    const std::size_t active_cuts = known.size();
    keep(lv.n_active, lv.n_active + lv.n_halo);
    // Active cells come in key order, and so do the halo cells after them: then a merge.
    auto by_key = [](const KnownCut& a, const KnownCut& b) { return a.key < b.key; };
    const auto halo = known.begin() + static_cast<std::ptrdiff_t>(active_cuts);
    if (std::is_sorted(known.begin(), halo, by_key) && std::is_sorted(halo, known.end(), by_key))
      std::inplace_merge(known.begin(), halo, known.end(), by_key);
    else
      std::sort(known.begin(), known.end(), by_key);
  }
}

template <int D>
void EmbeddedGeometry<D>::evaluate_level(int l) {
  constexpr int C = tree::kChildren<D>;
  const tree::Level<D>& lv = tree_.level(l);
  const tree::TreeOptions<D>& o = tree_.options();
  const double h = tree_.cell_size(l);
  // A little over the half diagonal: a centre farther than this from the wall has its whole
  // box, corners included, strictly on one side.
  const double reach = 0.5 * h * std::sqrt(double(D)) * (1.0 + 1e-9);
  const Index base = lv.base, n_active = lv.n_active, n_halo = lv.n_halo, size = lv.size();
  std::int64_t reused = 0, evaluated = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : reused, evaluated) if (size > tree::kParallelMin)
  for (Index i = 0; i < size; ++i) {
    const Index c = base + i;
    const auto s = static_cast<std::size_t>(c);
    // The side of the coarse cell that holds this one, when it is wholly on one side.
    std::int8_t inherited = 0;
    if (l > 0 && i < n_active) inherited = side_[static_cast<std::size_t>(lv.group_parent[static_cast<std::size_t>(i / C)])];
    else if (l > 0 && i < n_active + n_halo)
      inherited = side_[static_cast<std::size_t>(lv.halo_parent[static_cast<std::size_t>((i - n_active) / C)])];
    if (inherited == 0) {
      const tree::Coords<D> ijk = slot_coords<D>(lv, c);
      tree::Point<D> centre{};
      for (int d = 0; d < D; ++d) {
        std::int64_t k = ijk[d];
        if (o.periodic[d]) {
          const std::int64_t cells = static_cast<std::int64_t>(o.roots[d]) << l;
          k = ((k % cells) + cells) % cells;
        }
        centre[d] = o.origin[d] + (static_cast<double>(k) + 0.5) * h;
      }
      const double phi = signed_distance(centre);
      if (phi > reach) inherited = 1;
      else if (phi < -reach) inherited = -1;
    }
    side_[s] = inherited;
    if (inherited == 0) {
      if (i < n_active + n_halo && take_known_cut(l, lv.keys[static_cast<std::size_t>(i)], c)) {
        ++reused;
        continue;
      }
      cut_cell_at(c, l);
      ++evaluated;
      continue;
    }
    const double full = inherited > 0 ? 1.0 : 0.0;
    volume_[s] = full;
    wall_area_[s] = 0.0;
    for (int d = 0; d < D; ++d) {
      faces_[d][s] = upper_[d][s] = full;
      wall_centroid_[d][s] = 0.0;
    }
  }
  reused_cuts_ += reused;
  evaluated_cuts_ += evaluated;
}

template <int D>
void EmbeddedGeometry<D>::make_coarse_consistent(int l) {
  constexpr int C = tree::kChildren<D>;
  // The mean of the lower faces along d of the 2^D cells from `first`.
  auto lower_faces_mean = [this](int d, Index first) {
    double sum = 0.0;
    for (int b = 0; b < C; ++b)
      if (!tree::child_bit(b, d)) sum += faces_[d][static_cast<std::size_t>(first + b)];
    return sum / (C / 2);
  };
  const tree::Level<D>& lv = tree_.level(l);
  const Index base = lv.base, n = lv.n_active;
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
  for (Index i = 0; i < n; ++i) {
    const Index c = base + i;
    const auto s = static_cast<std::size_t>(c);
    const Index first = lv.first_child[static_cast<std::size_t>(i)];
    if (lv.leaf[static_cast<std::size_t>(i)] == tree::Level<D>::kLeafNextToFiner) {
      // A coarse face (against a finer parent): the mean of the fine faces covering it,
      // which are the lower faces of c's halo children.
      const Index* row = lv.face_row(c);
      for (int d = 0; d < D; ++d) {
        const Index lo = row[2 * d];
        if (lo < lv.active_end() && !lv.is_leaf(lo)) faces_[d][s] = lower_faces_mean(d, first);
      }
      continue;
    }
    if (lv.leaf[static_cast<std::size_t>(i)]) continue;
    // A parent: the means of its children (the next level, already final).
    double volume = 0.0, area = 0.0;
    std::array<double, D> moment{};
    for (int b = 0; b < C; ++b) {
      const auto k = static_cast<std::size_t>(first + b);
      volume += volume_[k];
      area += wall_area_[k];
      for (int d = 0; d < D; ++d) moment[d] += wall_area_[k] * wall_centroid_[d][k];
    }
    volume_[s] = volume / C;
    wall_area_[s] = area;
    for (int d = 0; d < D; ++d) {
      faces_[d][s] = lower_faces_mean(d, first);
      wall_centroid_[d][s] = area > 0.0 ? moment[d] / area : 0.0;
      // The upper face: the mean of the children's (their upper faces are the cell's).
      double sum = 0.0;
      for (int b = 0; b < C; ++b)
        if (tree::child_bit(b, d)) sum += upper_[d][static_cast<std::size_t>(first + b)];
      upper_[d][s] = sum / (C / 2);
    }
  }
}

template <int D>
void EmbeddedGeometry<D>::collect_walls() {
  cut_cells_.assign(static_cast<std::size_t>(tree_.depth() + 1), {});
  uniform_.assign(static_cast<std::size_t>(tree_.num_cells()), 0);
  for (int l = 0; l <= tree_.depth(); ++l) {
    const tree::Level<D>& lv = tree_.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
      if (wall_area_[static_cast<std::size_t>(c)] > 0.0) cut_cells_[static_cast<std::size_t>(l)].push_back(c);
#pragma omp parallel for schedule(static) if (lv.n_active > tree::kParallelMin)
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      const auto s = static_cast<std::size_t>(c);
      bool open = volume_[s] == 1.0 && wall_area_[s] == 0.0;
      bool closed = volume_[s] == 0.0 && wall_area_[s] == 0.0;
      // A full cell with every face open but one: its wall lies on that face.
      int open_faces = 0, closed_face = -1;
      const Index* row = lv.face_row(c);
      for (int d = 0; d < D; ++d) {
        const double lower = faces_[d][s], upper = faces_[d][static_cast<std::size_t>(row[2 * d + 1])];
        open = open && lower == 1.0 && upper == 1.0;
        closed = closed && lower == 0.0 && upper == 0.0;
        open_faces += (lower == 1.0) + (upper == 1.0);
        if (lower == 0.0) closed_face = 2 * d;
        if (upper == 0.0) closed_face = 2 * d + 1;
      }
      const bool one_closed = volume_[s] == 1.0 && open_faces == 2 * D - 1 && closed_face >= 0;
      uniform_[s] = open         ? kStencilUniform
                    : closed     ? kStencilEmpty
                    : one_closed ? static_cast<std::uint8_t>(kStencilClosedFace + closed_face)
                                 : kStencilArrays;
    }
  }
}

template class EmbeddedGeometry<2>;
template class EmbeddedGeometry<3>;

}  // namespace capsflow::fluid
