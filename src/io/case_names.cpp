#include "io/case_names.hpp"

namespace capsflow::io {

std::string_view to_string(BoundaryType v) { return detail::name_of(detail::kBoundaryTypes, v); }
std::string_view to_string(InflowProfile v) { return detail::name_of(detail::kInflowProfiles, v); }
std::string_view to_string(MembraneLaw v) { return detail::name_of(detail::kMembraneLaws, v); }
std::string_view to_string(InitialShape v) { return detail::name_of(detail::kInitialShapes, v); }
std::string_view to_string(KernelType v) { return detail::name_of(detail::kKernelTypes, v); }
std::string_view to_string(NodeScheme v) { return detail::name_of(detail::kNodeSchemes, v); }
std::string_view to_string(Coupling v) { return detail::name_of(detail::kCouplings, v); }
std::string_view to_string(SolidShape v) { return detail::name_of(detail::kSolidShapes, v); }
std::string_view to_string(SolidCombine v) { return detail::name_of(detail::kSolidCombines, v); }
std::string_view to_string(SolidFill v) { return detail::name_of(detail::kSolidFills, v); }

}  // namespace capsflow::io
