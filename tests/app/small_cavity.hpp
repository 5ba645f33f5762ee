#pragma once
// The smallest case the tests run through the binary: a 2D lid-driven cavity on levels 3-4,
// two steps. Tests that need more append tables (an [output] table, a bad line).
#include <string>

namespace capsflow::test_cases {

inline std::string small_cavity(const std::string& extra = "") {
  return std::string(R"(name = "c"
dimension = 2
[domain]
roots = [1, 1]
[fluid.boundary]
x_lo = { type = "wall" }
x_hi = { type = "wall" }
y_lo = { type = "wall" }
y_hi = { type = "moving_wall", velocity = [1.0, 0.0] }
[adapt]
min_level = 3
max_level = 4
[time]
dt = 0.01
t_end = 0.02
)") + extra;
}

}  // namespace capsflow::test_cases
