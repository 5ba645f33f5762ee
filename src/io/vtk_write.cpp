#include "io/vtk_write.hpp"

#include <fmt/format.h>
#include <vtkMPIController.h>
#include <vtkXMLPUnstructuredGridWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <algorithm>
#include <stdexcept>

#include "io/atomic_write.hpp"

namespace capsflow::io::detail {

namespace {

// Appended raw binary: the smallest files and the fastest to read in ParaView.
void set_format(vtkXMLWriter* writer) {
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToZLib();
  writer->SetHeaderTypeToUInt64();  // arrays above 4 GiB stay readable
}

}  // namespace

void write_vtu(const std::filesystem::path& path, vtkUnstructuredGrid* grid) {
  atomic_write(path, [&](const std::filesystem::path& tmp) {
    auto writer = vtkSmartPointer<vtkXMLUnstructuredGridWriter>::New();
    writer->SetFileName(tmp.c_str());
    writer->SetInputData(grid);
    set_format(writer);
    if (writer->Write() != 1 || writer->GetErrorCode() != 0)
      throw std::runtime_error(fmt::format("{}: VTK could not write the file", path.string()));
  });
}

void write_pvtu_piece(const std::filesystem::path& path, vtkUnstructuredGrid* grid, int piece, int pieces) {
  // VTK names the pieces after the .pvtu's stem, in a folder of that name; piece 0's writer
  // makes the folder. The others may reach it first: make it here too.
  std::filesystem::path folder = path;
  folder.replace_extension();
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  // The writer learns every rank's piece through a controller on MPI_COMM_WORLD (capsflow
  // runs on it; MPI is initialised already, so VTK does not initialise or finalise it).
  static vtkSmartPointer<vtkMPIController> controller = [] {
    auto c = vtkSmartPointer<vtkMPIController>::New();
    c->Initialize(nullptr, nullptr, 1);
    return c;
  }();
  auto writer = vtkSmartPointer<vtkXMLPUnstructuredGridWriter>::New();
  writer->SetController(controller);
  writer->SetFileName(path.c_str());
  writer->SetInputData(grid);
  set_format(writer);
  writer->SetNumberOfPieces(pieces);
  writer->SetStartPiece(piece);
  writer->SetEndPiece(piece);
  writer->SetUseSubdirectory(true);
  writer->SetWriteSummaryFile(1);  // a collective: every rank takes part, the controller's rank 0 writes it
  if (writer->Write() != 1 || writer->GetErrorCode() != 0)
    throw std::runtime_error(fmt::format("{}: VTK could not write piece {} of {}", path.string(), piece, pieces));
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
