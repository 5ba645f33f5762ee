#pragma once
// A capsule upstream of an embedded post in the seed channel (Stokes, square-duct inflow at
// x = -4, outflow at x = 4, dx = 1/16 at the finest): a spherical post of radius 0.3 at the
// origin and a 642-node capsule of radius 0.4 on the axis at x = capsule_x. Its kernels reach
// 0.49 from its nodes at this resolution.
#include <string>

#include <fmt/format.h>

namespace capsflow::test_cases {

inline std::string post_channel(double capsule_x) {
  return fmt::format(R"(dimension = 3
[domain]
roots = [4, 1, 1]
root_size = 2.0
origin = [-4.0, -1.0, -1.0]
[fluid]
stokes = true
[fluid.boundary]
x_lo = {{ type = "inflow", profile = "square_duct", mean_velocity = 1.0 }}
x_hi = {{ type = "outflow" }}
y_lo = {{ type = "wall" }}
y_hi = {{ type = "wall" }}
z_lo = {{ type = "wall" }}
z_hi = {{ type = "wall" }}
[adapt]
max_level = 5
wall_level = 5
interval = 5
[[solid]]
shape = "sphere"
centre = [0.0, 0.0, 0.0]
radius = 0.3
[[capsule]]
nodes = 642
radius = 0.4
centre = [{}, 0.0, 0.0]
[time]
dt = 0.002
t_end = 0.4
[output]
vtu = false
)",
                     capsule_x);
}

}  // namespace capsflow::test_cases
