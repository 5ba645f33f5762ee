#pragma once
// Work that only rank 0 of a distributed run does (the output folder, diagnostics, snapshots,
// checkpoints), made collective in its outcome: if it throws on rank 0, rank 0 rethrows and
// every other rank throws OtherRankFailed with the same exit status, so all stop together
// and the error is said once. On one rank it is a plain call.
#include <functional>

#include "parallel/comm.hpp"

namespace capsflow::app {

void on_root(const parallel::Comm& comm, const std::function<void()>& work);

}  // namespace capsflow::app
