// Coefficients weighted by the fluid fractions (why: embedded_coefficients.hpp).
#include "fluid/multigrid/embedded_coefficients.hpp"

#include <algorithm>

namespace capsflow::fluid {

template <int D>
void embedded_face_coefficients(const tree::Tree<D>& t, const EmbeddedGeometry<D>& g, double alpha,
                                std::vector<double>& out) {
  // Every slot (the levels' active, halo and boundary cells: tree.hpp) is written below, the
  // halo and boundary cells' with 0, instead of a fill first (a serial pass over them all).
  out.resize(static_cast<std::size_t>(t.num_cells()) * 2 * D);
  const FaceField<D>& f = g.faces();
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const Index n = lv.n_active, base = lv.base, size = lv.size();
#pragma omp parallel for schedule(static) if (size > tree::kParallelMin)
    for (Index i = 0; i < size; ++i) {
      const Index c = base + i;
      double* o = out.data() + static_cast<std::size_t>(c) * 2 * D;
      if (i >= n) {
        std::fill_n(o, 2 * D, 0.0);
        continue;
      }
      const Index* row = lv.face_row(c);
      for (int d = 0; d < D; ++d) {
        o[2 * d] = alpha * f[d][static_cast<std::size_t>(c)];
        o[2 * d + 1] = alpha * f[d][static_cast<std::size_t>(row[2 * d + 1])];
      }
    }
  }
}

template <int D>
void embedded_cell_coefficients(const tree::Tree<D>& t, const EmbeddedGeometry<D>& g, double lambda,
                                std::vector<double>& out, std::span<const double> scale) {
  out.resize(static_cast<std::size_t>(t.num_cells()));  // every slot written below, as above
  const std::span<const double> volume = g.volume();
  const FaceField<D>& f = g.faces();
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double pinned = -1.0 / (t.cell_size(l) * t.cell_size(l));
    const Index begin = lv.active_begin(), end = lv.active_end();
    std::fill(out.begin() + end, out.begin() + lv.base + lv.size(), 0.0);  // halo and boundary cells
#pragma omp parallel for schedule(static) if (end - begin > tree::kParallelMin)
    for (Index c = begin; c < end; ++c) {
      // A coarse cell may hold fluid behind faces that are all closed at its level (a pocket
      // inside it): no flux reaches it there, so it is pinned like a cell without fluid.
      const Index* row = lv.face_row(c);
      double open = 0.0;
      for (int d = 0; d < D; ++d) open += f[d][static_cast<std::size_t>(c)] + f[d][static_cast<std::size_t>(row[2 * d + 1])];
      const double v = volume[static_cast<std::size_t>(c)];
      const double s = scale.empty() ? 1.0 : scale[static_cast<std::size_t>(c)];
      out[static_cast<std::size_t>(c)] = v > 0.0 && open > 0.0 ? lambda * s * v : pinned;
    }
  }
}

template void embedded_face_coefficients<2>(const tree::Tree<2>&, const EmbeddedGeometry<2>&, double, std::vector<double>&);
template void embedded_face_coefficients<3>(const tree::Tree<3>&, const EmbeddedGeometry<3>&, double, std::vector<double>&);
template void embedded_cell_coefficients<2>(const tree::Tree<2>&, const EmbeddedGeometry<2>&, double, std::vector<double>&, std::span<const double>);
template void embedded_cell_coefficients<3>(const tree::Tree<3>&, const EmbeddedGeometry<3>&, double, std::vector<double>&, std::span<const double>);

}  // namespace capsflow::fluid
