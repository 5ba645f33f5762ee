#include "io/vtu_surface.hpp"

#include <fmt/format.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkIdTypeArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>

#include <stdexcept>

#include "io/vtk_write.hpp"

namespace capsflow::io {

namespace {

void check_array(const SurfaceArray& a, std::size_t count, std::string_view kind) {
  if (a.components < 1 || a.components > 9)
    throw std::invalid_argument(
        fmt::format("write_surface_vtu: {} array {} has {} components (1 to 9)", kind, a.name, a.components));
  if (a.values.size() != count * static_cast<std::size_t>(a.components))
    throw std::invalid_argument(fmt::format("write_surface_vtu: {} array {} has {} values, expected {} x {}",
                                            kind, a.name, a.values.size(), count, a.components));
}

}  // namespace

void write_surface_vtu(const std::filesystem::path& path, const SurfaceSnapshot& s) {
  const std::size_t npe = s.order == SurfaceOrder::linear ? 3 : 6;
  if (s.positions.size() % 3 != 0)
    throw std::invalid_argument(fmt::format("write_surface_vtu: {} coordinates is not 3 per node", s.positions.size()));
  if (s.elements.size() % npe != 0)
    throw std::invalid_argument(fmt::format("write_surface_vtu: {} element indices is not {} per element",
                                            s.elements.size(), npe));
  const std::size_t nodes = s.positions.size() / 3;
  const std::size_t elements = s.elements.size() / npe;
  for (const std::int32_t i : s.elements)
    if (i < 0 || static_cast<std::size_t>(i) >= nodes)
      throw std::invalid_argument(fmt::format("write_surface_vtu: node index {} out of range [0, {})", i, nodes));
  for (const SurfaceArray& a : s.point_data) check_array(a, nodes, "point");
  for (const SurfaceArray& a : s.cell_data) check_array(a, elements, "cell");

  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(detail::double_array("positions", s.positions, 3));

  auto offsets = vtkSmartPointer<vtkIdTypeArray>::New();
  auto connectivity = vtkSmartPointer<vtkIdTypeArray>::New();
  offsets->SetNumberOfTuples(static_cast<vtkIdType>(elements + 1));
  connectivity->SetNumberOfTuples(static_cast<vtkIdType>(s.elements.size()));
  for (std::size_t e = 0; e <= elements; ++e)
    offsets->SetValue(static_cast<vtkIdType>(e), static_cast<vtkIdType>(e * npe));
  for (std::size_t k = 0; k < s.elements.size(); ++k)
    connectivity->SetValue(static_cast<vtkIdType>(k), s.elements[k]);
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  cells->SetData(offsets, connectivity);

  auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
  grid->SetPoints(points);
  grid->SetCells(s.order == SurfaceOrder::linear ? VTK_TRIANGLE : VTK_QUADRATIC_TRIANGLE, cells);
  for (const SurfaceArray& a : s.point_data)
    grid->GetPointData()->AddArray(detail::double_array(a.name, a.values, a.components));
  for (const SurfaceArray& a : s.cell_data)
    grid->GetCellData()->AddArray(detail::double_array(a.name, a.values, a.components));
  detail::write_vtu(path, grid);
}

}  // namespace capsflow::io
