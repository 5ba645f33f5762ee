#pragma once
// Value checks of a case (internal): ranges and the rules that tie keys together.
#include "io/case_config.hpp"
#include "io/case_source.hpp"

namespace capsflow::io::detail {

void validate_case(const CaseConfig& config, const CaseSource& source);

}  // namespace capsflow::io::detail
