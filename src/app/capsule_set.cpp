#include "app/capsule_set.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <fmt/format.h>

#include "io/diagnostics_csv.hpp"
#include "io/vtu_surface.hpp"
#include "membrane/diagnostics.hpp"
#include "membrane/shapes.hpp"
#include "parallel/all_or_none.hpp"
#include "parallel/sparse_exchange.hpp"

namespace capsflow::app {

namespace {

ibm::KernelKind kernel(io::KernelType k) {
  switch (k) {
    case io::KernelType::cosine: return ibm::KernelKind::cosine;
    case io::KernelType::hat: return ibm::KernelKind::hat;
    case io::KernelType::peskin4: return ibm::KernelKind::peskin4;
  }
  throw std::logic_error("capsule: unhandled kernel type");  // unreachable: the switch is exhaustive
}

// Switches without default (here and below): -Wswitch flags a case-file value left out,
// where a ternary would silently map it to another law or order.
membrane::LawKind law_kind(io::MembraneLaw law) {
  switch (law) {
    case io::MembraneLaw::skalak: return membrane::LawKind::skalak;
    case io::MembraneLaw::neo_hookean: return membrane::LawKind::neo_hookean;
  }
  throw std::logic_error("capsule: unhandled membrane law");
}

// element_order is an integer in the case file; validation allows 1 and 2 only.
membrane::Order element_order(int order, int index) {
  switch (order) {
    case 1: return membrane::Order::p1;
    case 2: return membrane::Order::p2;
    default: break;  // an integer, not an enum: every other value is refused
  }
  throw std::invalid_argument(fmt::format("capsule[{}].element_order = {}: must be 1 (P1) or 2 (P2)", index, order));
}

io::SurfaceOrder surface_order(membrane::Order order) {
  switch (order) {
    case membrane::Order::p1: return io::SurfaceOrder::linear;
    case membrane::Order::p2: return io::SurfaceOrder::quadratic;
  }
  throw std::logic_error("capsule: unhandled element order");
}

int icosphere_level(int nodes, int index) {
  for (int level = 0; level <= membrane::max_icosphere_level; ++level)
    if (membrane::icosphere_node_count(level) == nodes) return level;
  throw std::invalid_argument(fmt::format("capsule[{}].nodes = {}: not an icosphere size (642, 2562, 10242, 40962)", index, nodes));
}

std::string numbered(const char* stem, long step, int capsule) {
  return capsule == 0 ? fmt::format("{}_{:06d}.vtu", stem, step) : fmt::format("{}_{}_{:06d}.vtu", stem, capsule, step);
}

}  // namespace

// Capsule i's reference membrane (mesh and law) from its [[capsule]] table.
membrane::MembraneModel reference_model(const io::CaseConfig& c, int i) {
  const io::CapsuleConfig& k = c.capsules[static_cast<std::size_t>(i)];
  const Eigen::Vector3d centre(k.centre[0], k.centre[1], k.centre[2]);
  membrane::Mesh mesh = membrane::make_icosphere(
      {.order = element_order(k.element_order, i), .level = icosphere_level(k.nodes, i), .radius = k.radius,
       .centre = centre});
  const membrane::LawParameters law{.kind = law_kind(k.law), .gs = ibm::shear_modulus(k.Ca, c.fluid.Re), .c = k.C};
  return membrane::MembraneModel(std::move(mesh), law);
}

CapsuleSet::CapsuleSet(const io::CaseConfig& c, fluid::NavierStokes<3>& ns) : case_(c), comm_(parallel::Comm::world()) {
  // membrane_band counts the cells beyond the node's cell; the coupling's margin those beyond
  // the kernels' half support (2 cells for the widest kernels).
  coupling_ = std::make_unique<ibm::CapsuleCoupling>(ns, std::max(0, c.adapt.membrane_band - 2));
  switch (c.time.node_scheme) {
    case io::NodeScheme::euler: coupling_->set_node_scheme(ibm::NodeScheme::euler); break;
    case io::NodeScheme::ab2: coupling_->set_node_scheme(ibm::NodeScheme::ab2); break;
    case io::NodeScheme::midpoint: coupling_->set_node_scheme(ibm::NodeScheme::midpoint); break;
    case io::NodeScheme::bdf2: coupling_->set_node_scheme(ibm::NodeScheme::bdf2); break;
  }
  coupling_->set_implicit({.enabled = c.time.coupling != io::Coupling::explicit_forces,
                           .tolerance = c.time.implicit_tolerance,
                           .max_iterations = c.time.implicit_max_iterations});
  for (std::size_t i = 0; i < c.capsules.size(); ++i) {
    const io::CapsuleConfig& k = c.capsules[i];
    const int index = static_cast<int>(i);
    const Eigen::Vector3d centre(k.centre[0], k.centre[1], k.centre[2]);
    membrane::MembraneModel model = reference_model(c, index);
    const membrane::Mesh& mesh = model.mesh();
    Eigen::Matrix3Xd x = mesh.nodes;
    switch (k.shape) {
      case io::InitialShape::sphere: break;
      case io::InitialShape::ellipsoid: {
        const Eigen::Matrix3d axes = Eigen::Vector3d(k.axes_factors[0], k.axes_factors[1], k.axes_factors[2]).asDiagonal();
        x = membrane::map_linear(mesh.nodes, axes, centre);
        break;
      }
      case io::InitialShape::inflated: x = membrane::inflate(mesh.nodes, k.inflation, centre); break;
    }
    reference_area_.push_back(membrane::surface_area(mesh, mesh.nodes));
    reference_volume_.push_back(membrane::enclosed_volume(mesh, mesh.nodes));
    coupling_->add_capsule(std::move(model), std::move(x),
                           {.spread = kernel(k.spread_kernel), .interpolate = kernel(k.interp_kernel), .staggered = k.staggered,
                            .divergence_free = k.divergence_free});
    coupling_->set_inner_fluid(index, {.viscosity_ratio = k.viscosity_ratio, .density_ratio = k.density_ratio});
  }
  if (c.time.coupling == io::Coupling::automatic) {
    // "auto": the steps its explicit scheme (BDF2's) takes safely stay explicit, one flow
    // step each.
    ibm::CapsuleCoupling::ImplicitOptions o = coupling_->implicit_options();
    o.explicit_below = coupling_->auto_explicit_limit();
    coupling_->set_implicit(o);
  }
  if (coupling_->any_inner_fluid()) {
    // The flow's density and viscosity from the capsules' insides, at the start of each step.
    const fluid::FlowOptions<3>& o = ns.options();
    const double rho_out = o.density, mu_out = o.viscosity > 0.0 ? o.viscosity : 1.0 / o.Re;
    ns.set_properties([coupling = coupling_.get(), rho_out, mu_out](const tree::Tree<3>&, std::span<double> rho,
                                                                    std::span<double> mu) {
      coupling->inner_properties(rho_out, mu_out, rho, mu);
    });
  }
}

void CapsuleSet::distribute() {
  coupling_->distribute([this](int i) { return reference_model(case_, i); });
}

CapsuleDiagnostics CapsuleSet::diagnostics(int k) const {
  const ibm::Capsule& c = coupling_->capsule(k);
  const auto s = membrane::shape_diagnostics(c.model.mesh(), c.x);
  const auto i = static_cast<std::size_t>(k);
  const bool moved = c.velocity.cols() == c.x.cols();
  return {s.d12, s.d12_bbox, (s.area - reference_area_[i]) / reference_area_[i],
          (s.volume - reference_volume_[i]) / reference_volume_[i], s.centroid, membrane::inclination_xy(s),
          moved ? membrane::tank_treading_rate(s, c.x, c.velocity) : 0.0, s.extent};
}

std::vector<std::string> CapsuleSet::columns() {
  return {"step", "t", "capsule", "D12", "D12_bbox", "area_rel", "volume_rel", "x", "y", "z",
          "E_membrane", "P_nodes", "W_membrane", "inclination", "omega_z", "Lx", "Ly", "Lz"};
}

std::vector<double> CapsuleSet::rows(long step, double t) const {
  std::vector<double> mine;  // this rank's capsules, ids ascending
  parallel::all_or_none(comm_, [&] {
    for (int k = 0; k < coupling_->num_capsules(); ++k) {
      if (!coupling_->owns(k)) continue;
      const CapsuleDiagnostics m = diagnostics(k);
      const double energy = coupling_->membrane_energy(k);
      mine.insert(mine.end(), {double(step), t, double(k), m.d12, m.d12_bbox, m.area_rel, m.volume_rel, m.centroid.x(),
                               m.centroid.y(), m.centroid.z(), energy, coupling_->node_power(k),
                               coupling_->capsule(k).work, m.inclination, m.omega_z, m.extent.x(),
                               m.extent.y(), m.extent.z()});
    }
  });
  if (!comm_.distributed()) return mine;
  // Rank 0 gathers every capsule's row and orders them by capsule.
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm_.size()));
  for (const double v : mine) send[0].push_back(std::bit_cast<std::uint64_t>(v));
  const auto received = parallel::sparse_exchange(comm_, send);
  if (!comm_.is_root()) return {};
  const std::size_t width = columns().size();
  std::vector<std::vector<double>> all;
  for (const auto& words : received)
    for (std::size_t k = 0; k + width <= words.size(); k += width) {
      std::vector<double> row(width);
      for (std::size_t j = 0; j < width; ++j) row[j] = std::bit_cast<double>(words[k + j]);
      all.push_back(std::move(row));
    }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a[2] < b[2]; });
  std::vector<double> out;
  for (const auto& row : all) out.insert(out.end(), row.begin(), row.end());
  return out;
}

CapsuleDiagnostics CapsuleSet::from_row(std::span<const double> row) {
  return {row[3], row[4], row[5], row[6], Eigen::Vector3d(row[7], row[8], row[9]), row[13], row[14],
          Eigen::Vector3d(row[15], row[16], row[17])};
}

void CapsuleSet::snapshot(const std::filesystem::path& dir, long step, double t, io::PvdSeries* series) const {
  for (int i = 0; i < coupling_->num_capsules(); ++i) {  // each owner writes its capsules
    if (!coupling_->owns(i)) continue;
    const ibm::Capsule& c = coupling_->capsule(i);
    const auto tensions = c.model.element_tensions(c.x);
    std::vector<double> t1, t2;
    for (const auto& p : tensions) {
      t1.push_back(p.t1);
      t2.push_back(p.t2);
    }
    const membrane::Mesh& mesh = c.model.mesh();
    std::vector<io::SurfaceArray> points;
    if (c.forces.cols() == c.x.cols()) points.push_back({"force", {c.forces.data(), std::size_t(c.forces.size())}, 3});
    if (c.velocity.cols() == c.x.cols()) points.push_back({"velocity", {c.velocity.data(), std::size_t(c.velocity.size())}, 3});
    const std::vector<io::SurfaceArray> cells{{"tension_major", t1, 1}, {"tension_minor", t2, 1}};
    io::write_surface_vtu(dir / numbered("membrane", step, i), {.positions = {c.x.data(), std::size_t(c.x.size())},
                                                                 .elements = mesh.elements,
                                                                 .order = surface_order(mesh.order),
                                                                 .point_data = points, .cell_data = cells});
  }
  if (comm_.distributed()) comm_.barrier();  // every membrane written before rank 0 lists them
  if (series)
    for (int i = 0; i < coupling_->num_capsules(); ++i) series->add(t, numbered("membrane", step, i), 1 + i);
}

void CapsuleSet::write_final(const std::filesystem::path& dir) const {
  const auto states = coupling_->gather_on_root();
  if (!comm_.is_root()) return;
  std::vector<double> all;
  for (const auto& s : states) all.insert(all.end(), s.x.data(), s.x.data() + s.x.size());
  io::write_nodes_csv(dir / "membrane_final.csv", all);
}

std::vector<io::ExtraArray> CapsuleSet::checkpoint_extras() const {
  const auto states = coupling_->gather_on_root();
  std::vector<io::ExtraArray> extras;
  if (!comm_.is_root()) return extras;
  for (std::size_t i = 0; i < states.size(); ++i) {
    const auto& s = states[i];
    const auto& x = s.x;
    extras.push_back({fmt::format("capsule_{}_positions", i), {std::size_t(x.cols()), 3}, {x.data(), x.data() + x.size()}});
    const auto& xa = s.x_at_adapt;
    extras.push_back({fmt::format("capsule_{}_positions_at_adapt", i), {std::size_t(xa.cols()), 3},
                      {xa.data(), xa.data() + xa.size()}});
    // The membrane's work since the run began (the energy budget's W_membrane).
    extras.push_back({fmt::format("capsule_{}_work", i), {1}, {s.work}});
    // V of the last step: the next step's AB2 needs it (ibm/capsule_coupling.hpp).
    const auto& v = s.velocity;
    if (v.cols() == x.cols())
      extras.push_back({fmt::format("capsule_{}_velocity", i), {std::size_t(v.cols()), 3}, {v.data(), v.data() + v.size()}});
    // The last step's motion: the next step's BDF2 needs it.
    const auto& m = s.motion;
    if (m.cols() == x.cols())
      extras.push_back(
          {fmt::format("capsule_{}_motion", i), {std::size_t(m.cols()), 3}, {m.data(), m.data() + m.size()}});
  }
  extras.push_back({"coupling_steps_since_adapt", {1}, {static_cast<double>(coupling_->steps_since_adapt())}});
  extras.push_back({"coupling_last_dt", {1}, {coupling_->last_dt()}});
  return extras;
}

void CapsuleSet::restore(const std::vector<io::ExtraArray>& extras, std::int64_t step) {
  coupling_->set_steps(step);
  for (int i = 0; i < coupling_->num_capsules(); ++i) {
    const std::string name = fmt::format("capsule_{}_positions", i);
    auto& x = coupling_->capsule(i).x;
    bool found = false;
    for (const auto& e : extras)
      if (e.name == name && e.values.size() == std::size_t(x.size())) {
        std::copy(e.values.begin(), e.values.end(), x.data());
        found = true;
      }
    if (!found) throw io::CheckpointError(fmt::format("checkpoint: no '{}' with {} nodes", name, x.cols()));
    // The adaptation state (absent from checkpoints older than adapt.max_interval): without
    // it the run adapts as if it had just done so.
    auto& xa = coupling_->capsule(i).x_at_adapt;
    xa = x;
    for (const auto& e : extras)
      if (e.name == name + "_at_adapt" && e.values.size() == std::size_t(x.size()))
        std::copy(e.values.begin(), e.values.end(), xa.data());
    // Without it (an older checkpoint) the work counts from the restart on.
    for (const auto& e : extras)
      if (e.name == fmt::format("capsule_{}_work", i) && e.values.size() == 1) coupling_->capsule(i).work = e.values[0];
    // Without it (an older checkpoint) the first step after the restart is Euler.
    // Likewise BDF2's.
    for (auto [stem, m] : {std::pair{"velocity", &coupling_->capsule(i).velocity},
                           std::pair{"motion", &coupling_->capsule(i).motion}})
      for (const auto& e : extras)
        if (e.name == fmt::format("capsule_{}_{}", i, stem) && e.values.size() == std::size_t(x.size())) {
          m->resize(3, x.cols());
          std::copy(e.values.begin(), e.values.end(), m->data());
        }
  }
  coupling_->set_steps_since_adapt(0);
  for (const auto& e : extras)
    if (e.name == "coupling_steps_since_adapt" && e.values.size() == 1)
      coupling_->set_steps_since_adapt(static_cast<std::int64_t>(e.values[0]));
    else if (e.name == "coupling_last_dt" && e.values.size() == 1)
      coupling_->set_last_dt(e.values[0]);
}

}  // namespace capsflow::app
