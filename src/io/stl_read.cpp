#include "io/stl_read.hpp"

#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>
#include <vtkCellArray.h>
#include <vtkErrorCode.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSTLReader.h>

#include "io/errors.hpp"

namespace capsflow::io {

geometry::TriangleMesh read_stl(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw CaseError(fmt::format("{}: no such STL file", path));
  vtkNew<vtkSTLReader> reader;
  reader->SetFileName(path.c_str());
  reader->MergingOn();
  // VTK prints its own errors; the one line below says what went wrong instead.
  const int display = vtkObject::GetGlobalWarningDisplay();
  vtkObject::SetGlobalWarningDisplay(0);
  reader->Update();
  vtkObject::SetGlobalWarningDisplay(display);
  vtkPolyData* surface = reader->GetOutput();
  if (reader->GetErrorCode() != vtkErrorCode::NoError || surface == nullptr || surface->GetNumberOfPolys() == 0)
    throw CaseError(fmt::format("{}: not a readable STL file (no triangles read)", path));
  geometry::TriangleMesh mesh;
  vtkPoints* points = surface->GetPoints();
  mesh.vertices.resize(3, points->GetNumberOfPoints());
  for (vtkIdType i = 0; i < points->GetNumberOfPoints(); ++i) {
    double x[3];
    points->GetPoint(i, x);
    mesh.vertices.col(static_cast<Eigen::Index>(i)) = Eigen::Vector3d(x[0], x[1], x[2]);
  }
  vtkCellArray* polys = surface->GetPolys();
  vtkNew<vtkIdList> ids;
  for (polys->InitTraversal(); polys->GetNextCell(ids);) {
    if (ids->GetNumberOfIds() != 3) throw CaseError(fmt::format("{}: a facet with {} corners", path, ids->GetNumberOfIds()));
    mesh.triangles.push_back(
        {static_cast<int>(ids->GetId(0)), static_cast<int>(ids->GetId(1)), static_cast<int>(ids->GetId(2))});
  }
  return mesh;
}

geometry::SolidPtr read_stl_solid(const std::string& path) {
  geometry::TriangleMesh mesh = read_stl(path);
  try {
    return geometry::triangle_surface(std::move(mesh));
  } catch (const std::invalid_argument& e) {
    throw CaseError(fmt::format("{}: {}", path, e.what()));
  }
}

}  // namespace capsflow::io
