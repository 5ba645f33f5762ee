#include "io/vtk_write.hpp"

#include <fmt/format.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <algorithm>
#include <stdexcept>

#include "io/atomic_write.hpp"

namespace capsflow::io::detail {

void write_vtu(const std::filesystem::path& path, vtkUnstructuredGrid* grid) {
  atomic_write(path, [&](const std::filesystem::path& tmp) {
    auto writer = vtkSmartPointer<vtkXMLUnstructuredGridWriter>::New();
    writer->SetFileName(tmp.c_str());
    writer->SetInputData(grid);
    // Appended raw binary: the smallest files and the fastest to read in ParaView.
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();
    writer->SetCompressorTypeToZLib();
    writer->SetHeaderTypeToUInt64();  // arrays above 4 GiB stay readable
    if (writer->Write() != 1 || writer->GetErrorCode() != 0)
      throw std::runtime_error(fmt::format("{}: VTK could not write the file", path.string()));
  });
}

vtkSmartPointer<vtkDoubleArray> double_array(const std::string& name, std::span<const double> values,
                                             int components) {
  auto a = vtkSmartPointer<vtkDoubleArray>::New();
  a->SetName(name.c_str());
  a->SetNumberOfComponents(components);
  a->SetNumberOfTuples(static_cast<vtkIdType>(values.size()) / components);
  std::copy(values.begin(), values.end(), a->GetPointer(0));
  return a;
}

}  // namespace capsflow::io::detail
