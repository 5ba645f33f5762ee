#include "io/vtu_tree.hpp"

#include <fmt/format.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkIdTypeArray.h>
#include <vtkIntArray.h>
#include <vtkPoints.h>
#include <vtkUnsignedCharArray.h>

#include <stdexcept>

#include "io/vtk_write.hpp"

namespace capsflow::io {

namespace {

template <int D>
void check_fields(const tree::Tree<D>& tree, std::span<const CellField> fields) {
  for (const CellField& f : fields) {
    if (f.name == "level")
      throw std::invalid_argument("write_tree_vtu: \"level\" is written already; rename the field");
    if (f.components.empty() || f.components.size() > 3)
      throw std::invalid_argument(fmt::format("write_tree_vtu: field {} has {} components (1 to 3)",
                                              f.name, f.components.size()));
    for (const auto& c : f.components)
      if (static_cast<tree::Index>(c.size()) != tree.num_cells())
        throw std::invalid_argument(fmt::format("write_tree_vtu: field {} has {} values for {} cells",
                                                f.name, c.size(), tree.num_cells()));
  }
}

// The owned leaves as a grid with their level and the fields as cell data.
template <int D>
vtkSmartPointer<vtkUnstructuredGrid> leaves_grid(const tree::Tree<D>& tree, std::span<const CellField> fields) {
  check_fields(tree, fields);
  constexpr int kCorners = 1 << D;
  // VTK's corner order from the bits (x, y, z) of each corner: counter-clockwise per face.
  constexpr int kBits[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                               {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const std::span<const tree::Index> leaves = tree.owned_leaves();
  const vtkIdType n = static_cast<vtkIdType>(leaves.size());

  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(n * kCorners);
  auto level = vtkSmartPointer<vtkIntArray>::New();
  level->SetName("level");
  level->SetNumberOfTuples(n);
  for (vtkIdType i = 0; i < n; ++i) {
    const tree::Index c = leaves[static_cast<std::size_t>(i)];
    const tree::Box<D> b = tree.box(c);
    for (int k = 0; k < kCorners; ++k) {
      double x[3] = {0.0, 0.0, 0.0};
      for (int d = 0; d < D; ++d) x[d] = kBits[k][d] ? b.hi[d] : b.lo[d];
      points->SetPoint(i * kCorners + k, x);
    }
    level->SetValue(i, tree.level_of(c));
  }

  auto offsets = vtkSmartPointer<vtkIdTypeArray>::New();
  auto connectivity = vtkSmartPointer<vtkIdTypeArray>::New();
  offsets->SetNumberOfTuples(n + 1);
  connectivity->SetNumberOfTuples(n * kCorners);
  for (vtkIdType i = 0; i <= n; ++i) offsets->SetValue(i, i * kCorners);
  for (vtkIdType p = 0; p < n * kCorners; ++p) connectivity->SetValue(p, p);
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  cells->SetData(offsets, connectivity);

  auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
  grid->SetPoints(points);
  grid->SetCells(D == 2 ? VTK_QUAD : VTK_HEXAHEDRON, cells);
  grid->GetCellData()->AddArray(level);

  std::vector<double> buffer;
  for (const CellField& f : fields) {
    const int nc = f.components.size() == 1 ? 1 : 3;
    buffer.assign(static_cast<std::size_t>(n * nc), 0.0);
    for (vtkIdType i = 0; i < n; ++i)
      for (std::size_t k = 0; k < f.components.size(); ++k)
        buffer[static_cast<std::size_t>(i * nc) + k] = f.components[k][leaves[static_cast<std::size_t>(i)]];
    grid->GetCellData()->AddArray(detail::double_array(f.name, buffer, nc));
  }
  return grid;
}

}  // namespace

template <int D>
void write_tree_vtu(const std::filesystem::path& path, const tree::Tree<D>& tree,
                    std::span<const CellField> fields) {
  detail::write_vtu(path, leaves_grid(tree, fields));
}

template <int D>
void write_tree_pvtu_piece(const std::filesystem::path& path, const tree::Tree<D>& tree,
                           std::span<const CellField> fields, int piece, int pieces) {
  detail::write_pvtu_piece(path, leaves_grid(tree, fields), piece, pieces);
}

template void write_tree_pvtu_piece<2>(const std::filesystem::path&, const tree::Tree<2>&,
                                       std::span<const CellField>, int, int);
template void write_tree_pvtu_piece<3>(const std::filesystem::path&, const tree::Tree<3>&,
                                       std::span<const CellField>, int, int);
template void write_tree_vtu<2>(const std::filesystem::path&, const tree::Tree<2>&,
                                std::span<const CellField>);
template void write_tree_vtu<3>(const std::filesystem::path&, const tree::Tree<3>&,
                                std::span<const CellField>);

}  // namespace capsflow::io
