#pragma once
// The [[solid]] tables of a case (issue "Walls of any shape"): their value rules, and the one
// geometry::Solid they make together (STL files read here). docs/case-file.md, "Solids".
#include <string_view>

#include "geometry/solid.hpp"
#include "io/case_config.hpp"

namespace capsflow::io {

// The solid of the case's [[solid]] tables combined in order (nullptr without any): each
// table's shape, complemented for fill = "outside", then united with, subtracted from or
// intersected with the solid of the tables above it. Reads the STL files; a missing,
// unreadable or defective surface (open, inconsistently oriented, normals inwards) is a
// CaseError naming `source`, the table's file key and the defect.
[[nodiscard]] geometry::SolidPtr make_solid(const CaseConfig& config, std::string_view source);

namespace detail {
struct CaseSource;
// The value rules of solid[i] (validate_case calls it for each table).
void check_solid(const CaseConfig& config, std::size_t i, const CaseSource& source);
}  // namespace detail

}  // namespace capsflow::io
