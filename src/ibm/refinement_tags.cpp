// Tags around membrane nodes (what and why: refinement_tags.hpp).
#include "ibm/refinement_tags.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

namespace capsflow::ibm {

namespace {

// Dilation by b cells along one axis: out = OR of the copies of `in` shifted by -b..b cells
// along the axis (clipped at the grid's ends). Every inner loop ORs contiguous bytes (a
// row segment, a row, or a plane), which vectorises.
void dilate_axis(const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out,
                 const std::array<std::int64_t, 3>& n, int axis, int b) {
  out.assign(in.size(), 0);
  const std::int64_t nx = n[0], ny = n[1], nz = n[2];
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j) {
      std::uint8_t* o = out.data() + (k * ny + j) * nx;
      for (int s = -b; s <= b; ++s) {
        if (axis == 0) {  // shift within the row
          const std::uint8_t* src = in.data() + (k * ny + j) * nx;
          const std::int64_t lo = std::max<std::int64_t>(0, -s), hi = std::min<std::int64_t>(nx, nx - s);
          for (std::int64_t i = lo; i < hi; ++i) o[i] |= src[i + s];
        } else {
          const std::int64_t jj = axis == 1 ? j + s : j, kk = axis == 2 ? k + s : k;
          if (jj < 0 || jj >= ny || kk < 0 || kk >= nz) continue;
          const std::uint8_t* src = in.data() + (kk * ny + jj) * nx;
          for (std::int64_t i = 0; i < nx; ++i) o[i] |= src[i];
        }
      }
    }
}

}  // namespace

bool MembraneTags::Grid::get(const tree::Coords<3>& ijk) const {
  std::int64_t idx = 0;
  for (int d = 2; d >= 0; --d) {
    const std::int64_t i = static_cast<std::int64_t>(ijk[d]) - lo[d];
    if (i < 0 || i >= n[d]) return false;
    idx = idx * n[d] + i;
  }
  return on[static_cast<std::size_t>(idx)] != 0;
}

void MembraneTags::build(const tree::TreeOptions<3>& domain, int level, int band, const Eigen::Matrix3Xd& x) {
  if (band < 0) throw std::invalid_argument(fmt::format("ibm: refinement band {} must be >= 0 cells", band));
  if (level < 0 || level > domain.max_level)
    throw std::invalid_argument(
        fmt::format("ibm: refinement level {} is outside [0, max_level {}]", level, domain.max_level));
  domain_ = domain;
  level_ = level;
  band_ = band;
  grids_.clear();
  if (x.cols() == 0) return;
  const double h = domain.root_size / static_cast<double>(std::int64_t{1} << level);

  // Finest grid: the nodes' cells, widened by the band.
  std::vector<tree::Coords<3>> node_cell(static_cast<std::size_t>(x.cols()));
  tree::Coords<3> lo{}, hi{};
  lo.fill(std::numeric_limits<std::int32_t>::max());
  hi.fill(std::numeric_limits<std::int32_t>::min());
  for (Eigen::Index i = 0; i < x.cols(); ++i)
    for (int d = 0; d < 3; ++d) {
      const double u = std::floor((x(d, i) - domain.origin[d]) / h);
      if (!std::isfinite(u) || std::abs(u) > 1e9)
        throw std::invalid_argument(fmt::format("ibm: refinement tags: node {} has coordinate {} = {}", i,
                                                "xyz"[d], x(d, i)));
      const auto c = static_cast<std::int32_t>(u);
      node_cell[i][d] = c;
      lo[d] = std::min(lo[d], c);
      hi[d] = std::max(hi[d], c);
    }
  grids_.resize(static_cast<std::size_t>(level) + 1);
  Grid& fine = grids_[level];
  for (int d = 0; d < 3; ++d) {
    fine.lo[d] = lo[d] - band;
    fine.n[d] = static_cast<std::int64_t>(hi[d]) - lo[d] + 1 + 2 * band;
  }
  fine.on.assign(static_cast<std::size_t>(fine.n[0] * fine.n[1] * fine.n[2]), 0);
  for (const auto& c : node_cell)
    fine.on[static_cast<std::size_t>(((c[2] - fine.lo[2]) * fine.n[1] + (c[1] - fine.lo[1])) * fine.n[0] +
                                     (c[0] - fine.lo[0]))] = 1;
  std::vector<std::uint8_t> scratch;
  for (int d = 0; d < 3; ++d) {
    dilate_axis(fine.on, scratch, fine.n, d, band);
    fine.on.swap(scratch);
  }

  // Coarser grids: a cell is on if any of its children is.
  for (int l = level - 1; l >= 0; --l) {
    const Grid& f = grids_[l + 1];
    Grid& g = grids_[l];
    for (int d = 0; d < 3; ++d) {
      g.lo[d] = f.lo[d] >> 1;
      g.n[d] = ((f.lo[d] + f.n[d] - 1) >> 1) - g.lo[d] + 1;
    }
    g.on.assign(static_cast<std::size_t>(g.n[0] * g.n[1] * g.n[2]), 0);
    for (std::int64_t k = 0; k < f.n[2]; ++k)
      for (std::int64_t j = 0; j < f.n[1]; ++j)
        for (std::int64_t i = 0; i < f.n[0]; ++i) {
          if (!f.on[static_cast<std::size_t>((k * f.n[1] + j) * f.n[0] + i)]) continue;
          const std::int64_t ci = ((f.lo[0] + i) >> 1) - g.lo[0], cj = ((f.lo[1] + j) >> 1) - g.lo[1],
                             ck = ((f.lo[2] + k) >> 1) - g.lo[2];
          g.on[static_cast<std::size_t>((ck * g.n[1] + cj) * g.n[0] + ci)] = 1;
        }
  }
}

bool MembraneTags::tagged(int l, const tree::Coords<3>& ijk) const {
  if (l < 0 || l > level_ || grids_.empty()) return false;
  const Grid& g = grids_[l];
  if (g.get(ijk)) return true;
  // Periodic images (unwrapped node coordinates may lie outside the brick).
  if (!domain_.periodic[0] && !domain_.periodic[1] && !domain_.periodic[2]) return false;
  for (int sz = -1; sz <= 1; ++sz)
    for (int sy = -1; sy <= 1; ++sy)
      for (int sx = -1; sx <= 1; ++sx) {
        const std::array<int, 3> s{sx, sy, sz};
        tree::Coords<3> image = ijk;
        bool valid = sx != 0 || sy != 0 || sz != 0;
        for (int d = 0; d < 3 && valid; ++d) {
          if (s[d] == 0) continue;
          valid = domain_.periodic[d];
          image[d] += s[d] * (domain_.roots[d] << l);
        }
        if (valid && g.get(image)) return true;
      }
  return false;
}

int MembraneTags::operator()(const tree::Box<3>& b) const {
  if (grids_.empty()) return 0;
  // The box's level: its size is root_size / 2^l (compared with a margin, not equality).
  const double size = b.hi[0] - b.lo[0];
  double hl = domain_.root_size / static_cast<double>(std::int64_t{1} << level_);
  int l = level_;
  while (l >= 0 && size > 1.5 * hl) {
    hl *= 2.0;
    --l;
  }
  if (l < 0 || size < 0.75 * hl) return 0;  // coarser than a root or finer than the tags
  tree::Coords<3> ijk{};
  for (int d = 0; d < 3; ++d)
    ijk[d] = static_cast<std::int32_t>(std::floor((0.5 * (b.lo[d] + b.hi[d]) - domain_.origin[d]) / hl));
  return tagged(l, ijk) ? level_ : 0;
}

std::int64_t MembraneTags::tagged_cells() const {
  if (grids_.empty()) return 0;
  const auto& on = grids_[level_].on;
  return std::count(on.begin(), on.end(), std::uint8_t{1});
}

}  // namespace capsflow::ibm
