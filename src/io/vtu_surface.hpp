#pragma once
// Snapshots of a membrane surface as a VTK unstructured grid (.vtu, for ParaView).
//
// Elements are linear triangles (VTK_TRIANGLE, nodes 0 1 2) or quadratic triangles
// (VTK_QUADRATIC_TRIANGLE, 6 nodes: the vertices 0 1 2, then the mid-edge nodes of the
// edges 0-1, 1-2 and 2-0), the node order of the membrane module's P1 and P2 elements, so
// element connectivity is written as it is. ParaView draws quadratic triangles curved.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace capsflow::io {

enum class SurfaceOrder : int { linear = 1, quadratic = 2 };

// Named data, interleaved: `components` values per node (point data) or element (cell
// data); 1 is a scalar, 3 a vector, any other count up to 9 a generic tuple (e.g. 2
// principal tensions).
struct SurfaceArray {
  std::string name;
  std::span<const double> values;
  int components = 1;
};

struct SurfaceSnapshot {
  std::span<const double> positions;       // 3 per node, x y z (Eigen::Matrix3Xd::data())
  std::span<const std::int32_t> elements;  // 3 (linear) or 6 (quadratic) node indices each
  SurfaceOrder order = SurfaceOrder::linear;
  std::vector<SurfaceArray> point_data;
  std::vector<SurfaceArray> cell_data;
};

// Throws std::invalid_argument for sizes that do not divide, a node index out of range, or
// an array of the wrong length; std::runtime_error if the file cannot be written.
void write_surface_vtu(const std::filesystem::path& path, const SurfaceSnapshot& surface);

}  // namespace capsflow::io
