#pragma once
// --set key=value overrides applied to a parsed case table (internal).
#include <toml++/toml.h>

#include <span>
#include <string>

#include "io/case_source.hpp"

namespace capsflow::io::detail {

// Sets each dotted key ("fluid.Re", "capsule[0].centre", "fluid.boundary.x_lo") to its value,
// parsed as TOML (a bare word that is not TOML becomes a string), creating missing tables.
// Unknown keys are not rejected here: the strict reader that follows reports them, marked
// "(from --set)" because the keys are recorded in source.overridden.
void apply_overrides(toml::table& root, std::span<const std::string> overrides, CaseSource& source);

}  // namespace capsflow::io::detail
