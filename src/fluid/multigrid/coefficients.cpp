#include "fluid/multigrid/coefficients.hpp"

namespace capsflow::fluid {

template <int D>
void face_coefficients(const tree::Tree<D>& t,
                       const std::function<double(const tree::Point<D>&, int)>& alpha,
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
  for (int l = t.depth() - 1; l >= 0; --l) {
    const tree::Level<D>& lv = t.level(l);
    for (Index i = 0; i < lv.n_active; ++i) {
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
  // A leaf facing a parent takes the parent's (fine-averaged) value on their common face,
  // so both sides of every face of a level see the same coefficient (a symmetric level
  // operator).
  for (int l = 0; l < t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    for (Index i = 0; i < lv.n_active; ++i) {
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

template void face_coefficients<2>(const tree::Tree<2>&,
                                   const std::function<double(const tree::Point<2>&, int)>&,
                                   std::vector<double>&);
template void face_coefficients<3>(const tree::Tree<3>&,
                                   const std::function<double(const tree::Point<3>&, int)>&,
                                   std::vector<double>&);

}  // namespace capsflow::fluid
