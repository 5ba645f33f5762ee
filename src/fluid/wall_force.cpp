// The force of the flow on the embedded walls (wall_force.hpp).
#include "fluid/wall_force.hpp"

#include <cmath>

#include "fluid/multigrid/multigrid.hpp"

namespace capsflow::fluid {

template <int D>
std::array<double, D> wall_force(NavierStokes<D>& ns) {
  std::array<double, D> force{};
  const EmbeddedGeometry<D>* g = ns.embedded();
  const WallFlux<D>* walls = ns.wall_flux();
  if (!g || !walls) return force;
  tree::Tree<D>& t = ns.tree();
  std::array<tree::FieldId, D> ids;
  for (int d = 0; d < D; ++d) ids[d] = ns.velocity(d);
  t.sync(std::span<const tree::FieldId>(ids));
  const std::span<const double> p = t.values(ns.pressure());
  const double mu = ns.face_viscosity(0, 0, 0, t.level(0));
  for (int k = 0; k < D; ++k) {
    const std::span<const double> u = t.values(ids[k]);
    // Per unit volume (leaf_integral multiplies by the leaf's h^D).
    force[k] = detail::leaf_integral<D>(t, [&](Index c) {
                 if (!walls->cut(c)) return 0.0;
                 const double volume = std::pow(t.cell_size(t.level_of(c)), D);
                 return p[c] * g->wall_normal_area(c)[static_cast<std::size_t>(k)] / volume -
                        mu * walls->flux(c, u, ns.wall_velocity(k, c));
               }).first;
  }
  return force;
}

template std::array<double, 2> wall_force<2>(NavierStokes<2>&);
template std::array<double, 3> wall_force<3>(NavierStokes<3>&);

}  // namespace capsflow::fluid
