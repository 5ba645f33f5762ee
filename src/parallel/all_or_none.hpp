#pragma once
// A failure found on one rank stops every rank (DESIGN.md, "Failure decided collectively"):
// the work runs on each rank; if it threw on any, every rank throws std::runtime_error with
// the message of the lowest rank that failed, after one reduction (and a broadcast of that
// message). No rank is left waiting in a later collective for one that stopped, and whether
// a failure is collective is decided by the reduction, not by the exception's type. On one
// rank without a communicator the work's own exception passes through unchanged.
#include <functional>

#include "parallel/comm.hpp"

namespace capsflow::parallel {

void all_or_none(const Comm& comm, const std::function<void()>& work);

}  // namespace capsflow::parallel
