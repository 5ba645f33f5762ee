#include "fluid/multigrid/coefficients.hpp"

#include <array>
#include <span>
#include <vector>

#include "common/assert.hpp"

namespace capsflow::fluid {

namespace {

// N ranks, level by level: every ghost cell of level l gets its owner's values (the faces of
// a ghost leaf at the edge of this rank's part reach cells it does not have, so only the
// owner computes them right).
template <int D>
class OwnersValues {
 public:
  OwnersValues(const tree::Tree<D>& t, std::vector<double>& out) : t_(t), out_(out) {
    if (!t.distributed()) return;
    const auto n = static_cast<std::size_t>(t.num_cells());
    for (int k = 0; k < F; ++k) {
      parts_[k].resize(n);
      spans_[k] = parts_[k];
    }
  }
  // Level l's ghosts take their owners' values (collective: every rank, every level).
  void take(int l) {
    if (!t_.distributed()) return;
    // A rank whose tree is shallower than the forest still joins the exchange, with nothing.
    const bool held = l <= t_.depth();
    const Index begin = held ? t_.level(l).base : 0, end = held ? t_.level(l).active_end() : 0;
    for (int k = 0; k < F; ++k)
      for (Index c = begin; c < end; ++c) parts_[k][c] = out_[static_cast<std::size_t>(c) * F + k];
    t_.update_ghosts(l, tree::Distribution::Fields(spans_.data(), spans_.size()));
    for (int k = 0; k < F; ++k)
      for (Index c = begin; c < end; ++c) out_[static_cast<std::size_t>(c) * F + k] = parts_[k][c];
  }

 private:
  static constexpr int F = 2 * D;
  const tree::Tree<D>& t_;
  std::vector<double>& out_;
  std::array<std::vector<double>, F> parts_;
  std::array<std::span<double>, F> spans_;
};

// Parents get the mean of their children's values on the same side, bottom-up; then a leaf
// facing a parent takes the parent's (fine-averaged) value on their common face, so both
// sides of every face of a level see the same coefficient (a symmetric level operator).
// `out` holds the leaves' values on entry. N ranks: each level's ghosts take their owners'
// values before the level above reads them, as Tree::restrict_and_exchange does.
template <int D>
void average_onto_parents(const tree::Tree<D>& t, std::vector<double>& out) {
  constexpr int F = 2 * D;
  OwnersValues<D> owners(t, out);
  const int top = t.distributed() ? t.global_depth() : t.depth();
  for (int l = top; l >= 0; --l) {
    if (l < t.depth()) {
      const tree::Level<D>& lv = t.level(l);
      const Index n_active = lv.n_active;
#pragma omp parallel for schedule(static) if (n_active > tree::kParallelMin)
      for (Index i = 0; i < n_active; ++i) {
        if (lv.leaf[i]) continue;
        const Index c = lv.base + i, fc = lv.first_child[i];
        for (int k = 0; k < F; ++k) {
          double sum = 0.0;
          for (int b = 0; b < tree::kChildren<D>; ++b)
            if (tree::child_bit(b, k / 2) == (k & 1)) sum += out[static_cast<std::size_t>(fc + b) * F + k];
          out[static_cast<std::size_t>(c) * F + k] = sum / (tree::kChildren<D> / 2);
        }
      }
    }
    owners.take(l);
  }
  for (int l = 0; l < t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const Index n_active = lv.n_active;
#pragma omp parallel for schedule(static) if (n_active > tree::kParallelMin)
    for (Index i = 0; i < n_active; ++i) {
      if (lv.leaf[i] != tree::Level<D>::kLeafNextToFiner) continue;
      const Index c = lv.base + i;
      for (int k = 0; k < F; ++k) {
        const Index n = lv.face_row(c)[k];
        if (n < lv.active_end() && !lv.is_leaf(n))
          out[static_cast<std::size_t>(c) * F + k] = out[static_cast<std::size_t>(n) * F + (k ^ 1)];
      }
    }
  }
}

}  // namespace

double face_mean(FaceMean mean, double a, double b) {
  // Equal values give that value exactly, so constant fields give constant coefficients.
  if (a == b) return mean == FaceMean::inverse_arithmetic ? 1.0 / a : a;
  switch (mean) {
    case FaceMean::harmonic:
      return 2.0 * a * b / (a + b);
    case FaceMean::inverse_arithmetic:
      break;
  }
  return 2.0 / (a + b);
}

template <int D>
void face_coefficients(const tree::Tree<D>& t, const std::function<double(const tree::Point<D>&, int)>& alpha,
                       std::vector<double>& out) {
  constexpr int F = 2 * D;
  out.assign(static_cast<std::size_t>(t.num_cells()) * F, 0.0);
  for (const Index c : t.leaves()) {
    const tree::Point<D> x = t.center(c);
    const double h = t.cell_size(t.level_of(c));
    for (int k = 0; k < F; ++k) {
      tree::Point<D> xf = x;
      xf[k / 2] += (k & 1) ? 0.5 * h : -0.5 * h;
      out[static_cast<std::size_t>(c) * F + k] = alpha(xf, k / 2);
    }
  }
  average_onto_parents<D>(t, out);
}

template <int D>
void face_coefficients(const tree::Tree<D>& t, std::span<const double> cells, FaceMean mean,
                       std::vector<double>& out) {
  constexpr int F = 2 * D;
  constexpr int C = tree::kChildren<D>;
  CAPSFLOW_ASSERT(cells.size() == static_cast<std::size_t>(t.num_cells()),
                  "face_coefficients: the cell values do not have the tree's num_cells entries");
  // Every leaf's and parent's faces are written below; the other slots (halos, boundary
  // cells) hold zeros from the first call on a tree of this size (not read: refilled each
  // step, the array is not cleared again, which cost a pass over 2D values per cell).
  if (out.size() != static_cast<std::size_t>(t.num_cells()) * F) out.assign(static_cast<std::size_t>(t.num_cells()) * F, 0.0);
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const Index n_active = lv.n_active, base = lv.base;
#pragma omp parallel for schedule(static) if (n_active > tree::kParallelMin)
    for (Index i = 0; i < n_active; ++i) {
      if (!lv.leaf[i]) continue;
      const Index c = base + i;
      const Index* row = lv.face_row(c);
      for (int k = 0; k < F; ++k) {
        Index n = row[k];
        // A parent neighbour's face is set by the fix-up below: its own value is not read.
        if (n >= lv.boundary_begin() || (n < lv.active_end() && !lv.is_leaf(n)))
          n = c;
        else if (n >= lv.halo_begin())
          n = lv.halo_parent[(n - lv.halo_begin()) / C];
        out[static_cast<std::size_t>(c) * F + k] = face_mean(mean, cells[c], cells[n]);
      }
    }
  }
  average_onto_parents<D>(t, out);
}

template void face_coefficients<2>(const tree::Tree<2>&,
                                   const std::function<double(const tree::Point<2>&, int)>&,
                                   std::vector<double>&);
template void face_coefficients<3>(const tree::Tree<3>&,
                                   const std::function<double(const tree::Point<3>&, int)>&,
                                   std::vector<double>&);
template void face_coefficients<2>(const tree::Tree<2>&, std::span<const double>, FaceMean,
                                   std::vector<double>&);
template void face_coefficients<3>(const tree::Tree<3>&, std::span<const double>, FaceMean,
                                   std::vector<double>&);

}  // namespace capsflow::fluid
