#pragma once
// The values of a checkpoint checked against the run that restarts from it (internal to
// the reader): scalars within the case's time span, finite numbers, the case's capsules.
// Each failure goes through H5Io::fail (CheckpointError naming the file).
#include <span>
#include <string>
#include <vector>

#include "io/checkpoint.hpp"
#include "io/h5_file.hpp"

namespace capsflow::io::detail {

void check_scalars(const H5Io& io, const CheckpointScalars& s, const CheckpointExpectations& expect);

// Every value finite; `path` names the dataset ("/fields/u.x").
void check_finite(const H5Io& io, const std::string& path, std::span<const double> values);

// capsule_<i>_positions: as many as the case has capsules, each N_i x 3 with the case's
// node count (when expect.capsule_nodes is set).
void check_capsules(const H5Io& io, const std::vector<ExtraArray>& extras, const CheckpointExpectations& expect);

}  // namespace capsflow::io::detail
