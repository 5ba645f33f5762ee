#pragma once
// A capsule upstream of an embedded obstacle in the seed channel (Stokes, square-duct inflow
// at x = -4, outflow at x = 4, dx = 1/16 at the finest): a 642-node capsule of radius 0.4 on
// the axis at x = capsule_x, and
//   post_channel: a spherical post of radius 0.3 at the origin;
//   throat_channel: a tube of radius 0.9 narrowing to a throat of radius 0.2 at the origin,
//   which pulls the capsule in until its membrane touches the wall (t = 0.16 from -1.1).
#include <string>

#include <fmt/format.h>

namespace capsflow::test_cases {

inline std::string obstacle_channel(const std::string& solid, double capsule_x) {
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
{}
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
                     solid, capsule_x);
}

inline std::string post_channel(double capsule_x) {
  return obstacle_channel("[[solid]]\nshape = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 0.3", capsule_x);
}

inline std::string throat_channel(double capsule_x) {
  return obstacle_channel(
      "[[solid]]\nshape = \"tube\"\ncentre = [0.0, 0.0, 0.0]\naxis = [1.0, 0.0, 0.0]\nfar_radius = 0.9\n"
      "throat_radius = 0.2\nhalf_length = 0.6",
      capsule_x);
}

}  // namespace capsflow::test_cases
