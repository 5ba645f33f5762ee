#include "baseline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace capsflow::bench {

namespace {

// Jacobi sweep for the 7-point Laplacian: out = (sum of 6 neighbours + h^2 f) / 6 on the
// interior of an n0 x n1 x n2 box (boundary layer held fixed).
void jacobi_sweep(const std::vector<double>& in, const std::vector<double>& rhs,
                  std::vector<double>& out, std::int64_t n0, std::int64_t n1, std::int64_t n2) {
  const std::int64_t s1 = n0;
  const std::int64_t s2 = n0 * n1;
#pragma omp parallel for collapse(2) schedule(static)
  for (std::int64_t k = 1; k < n2 - 1; ++k)
    for (std::int64_t j = 1; j < n1 - 1; ++j) {
      const std::int64_t row = k * s2 + j * s1;
#pragma omp simd
      for (std::int64_t i = 1; i < n0 - 1; ++i) {
        const std::int64_t c = row + i;
        out[c] = (in[c - 1] + in[c + 1] + in[c - s1] + in[c + s1] + in[c - s2] + in[c + s2] -
                  rhs[c]) * (1.0 / 6.0);
      }
    }
}

}  // namespace

double dense_jacobi_sweep_seconds(std::int64_t cells) {
  // Box n x n x n2 with n2 chosen so that the total matches `cells` to within one plane.
  const auto n = std::max<std::int64_t>(4, static_cast<std::int64_t>(std::cbrt(static_cast<double>(cells))));
  const std::int64_t n2 = std::max<std::int64_t>(3, (cells + n * n - 1) / (n * n));
  const std::int64_t total = n * n * n2;
  std::vector<double> a(total, 1.0), b(total, 0.0), rhs(total, 1e-3);
  // Enough repetitions for about 50 ms of work, at least 5, then take the median.
  jacobi_sweep(a, rhs, b, n, n, n2);
  std::vector<double> samples;
  double spent = 0.0;
  while (samples.size() < 5 || (spent < 0.05 && samples.size() < 2000)) {
    const auto t0 = std::chrono::steady_clock::now();
    jacobi_sweep(a, rhs, b, n, n, n2);
    const auto t1 = std::chrono::steady_clock::now();
    std::swap(a, b);
    const double s = std::chrono::duration<double>(t1 - t0).count();
    samples.push_back(s);
    spent += s;
  }
  std::nth_element(samples.begin(), samples.begin() + samples.size() / 2, samples.end());
  return samples[samples.size() / 2] * static_cast<double>(cells) / static_cast<double>(total);
}

}  // namespace capsflow::bench
