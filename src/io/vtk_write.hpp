#pragma once
// The one place that turns a vtkUnstructuredGrid into a file (internal; includes VTK).
// Format: VTK XML (.vtu), appended raw binary data compressed with zlib, 64-bit headers,
// written through atomic_write; on N ranks one piece per rank and a .pvtu (VTK's parallel
// XML writer).
#include <vtkDoubleArray.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>

#include <filesystem>
#include <span>
#include <string>

namespace capsflow::io::detail {

void write_vtu(const std::filesystem::path& path, vtkUnstructuredGrid* grid);

// One rank's piece of a grid split over `pieces` ranks: the piece goes to
// <stem>/<stem>_<piece>.vtu next to `path` (a .pvtu), in the same format; piece 0 also
// writes the .pvtu that lists every piece (ParaView reads it as one grid). Every rank calls
// it with its own piece (possibly empty); the arrays must be the same on all.
void write_pvtu_piece(const std::filesystem::path& path, vtkUnstructuredGrid* grid, int piece, int pieces);

// A double array of `tuples` x `components` from interleaved values.
vtkSmartPointer<vtkDoubleArray> double_array(const std::string& name, std::span<const double> values,
                                             int components);

}  // namespace capsflow::io::detail
