#pragma once
// The one place that turns a vtkUnstructuredGrid into a file (internal; includes VTK).
// Format: VTK XML (.vtu), appended raw binary data compressed with zlib, 64-bit headers,
// written through atomic_write.
#include <vtkDoubleArray.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>

#include <filesystem>
#include <span>
#include <string>

namespace capsflow::io::detail {

void write_vtu(const std::filesystem::path& path, vtkUnstructuredGrid* grid);

// A double array of `tuples` x `components` from interleaved values.
vtkSmartPointer<vtkDoubleArray> double_array(const std::string& name, std::span<const double> values,
                                             int components);

}  // namespace capsflow::io::detail
