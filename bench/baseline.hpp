#pragma once
// The in-run baseline every capsflow benchmark reports against (DESIGN.md, Benchmarks):
// one 7-point Jacobi sweep over a dense 3D array holding the same number of cells.
// Machines here are noisy, so a figure is only meaningful as a ratio to this, measured
// in the same process with the same number of OpenMP threads.
#include <cstdint>

namespace capsflow::bench {

// Median wall time in seconds of one dense 7-point Jacobi sweep over about `cells` cells
// (a cube, or the nearest box, of that size), using the current OpenMP thread count.
double dense_jacobi_sweep_seconds(std::int64_t cells);

}  // namespace capsflow::bench
