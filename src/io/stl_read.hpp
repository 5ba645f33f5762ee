#pragma once
// STL files (ASCII or binary) as closed triangulated surfaces (issue "Walls of any shape"):
// VTK's reader, with coincident points merged into shared vertices, then the checks of
// geometry::triangle_surface (closed, consistently oriented, outward normals). Errors are
// one CaseError line naming the file and the defect.
#include <string>

#include "geometry/triangle_surface.hpp"

namespace capsflow::io {

[[nodiscard]] geometry::TriangleMesh read_stl(const std::string& path);
// read_stl, checked and made a solid (inside the surface is the solid).
[[nodiscard]] geometry::SolidPtr read_stl_solid(const std::string& path);

}  // namespace capsflow::io
