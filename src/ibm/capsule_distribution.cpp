// The capsule coupling on N ranks (capsule_coupling.hpp, distribute()): ownership and its
// migration, the routed stages of the step, and the reductions of its collective decisions.
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "ibm/capsule_coupling.hpp"
#include "parallel/all_or_none.hpp"
#include "parallel/sparse_exchange.hpp"

namespace capsflow::ibm {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }
double value(std::uint64_t w) { return std::bit_cast<double>(w); }

void push_matrix(std::vector<std::uint64_t>& w, const Eigen::Matrix3Xd& m) {
  for (Eigen::Index i = 0; i < m.size(); ++i) w.push_back(bits(m.data()[i]));
}

const std::uint64_t* pop_matrix(const std::uint64_t* w, Eigen::Matrix3Xd& m, Eigen::Index nodes) {
  m.resize(3, nodes);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = value(*w++);
  return w;
}

// The state a capsule carries from step to step besides its positions: V of the last step
// (AB2, the step control) and its motion (BDF2), each when it has one.
std::uint64_t history_flags(const Capsule& c) {
  return (c.velocity.cols() == c.x.cols() ? 1u : 0u) | (c.motion.cols() == c.x.cols() ? 2u : 0u);
}
void push_history(std::vector<std::uint64_t>& w, const Capsule& c) {
  const std::uint64_t flags = history_flags(c);
  if (flags & 1u) push_matrix(w, c.velocity);
  if (flags & 2u) push_matrix(w, c.motion);
}
const std::uint64_t* pop_history(const std::uint64_t* p, std::uint64_t flags, Eigen::Index nodes,
                                 Eigen::Matrix3Xd& velocity, Eigen::Matrix3Xd& motion) {
  if (flags & 1u) p = pop_matrix(p, velocity, nodes);
  if (flags & 2u) p = pop_matrix(p, motion, nodes);
  return p;
}

}  // namespace

void CapsuleCoupling::collectively(const std::function<void()>& f) const {
  if (!distributed()) {
    f();
    return;
  }
  // all_or_none throws std::runtime_error on every rank; a failure that a shorter step may
  // mend (fluid::StepTooLong, see fail) stays one if it was that on every rank that failed.
  bool failed_for_good = false, at_positions = false;
  try {
    parallel::all_or_none(forest_->comm(), [&] {
      try {
        f();
      } catch (const fluid::StepTooLong& e) {
        at_positions = e.at_positions();
        throw;
      } catch (...) {
        failed_for_good = true;
        throw;
      }
    });
  } catch (const std::runtime_error& e) {
    if (any_rank(failed_for_good)) throw;
    throw fluid::StepTooLong(e.what(), any_rank(at_positions));
  }
}

bool CapsuleCoupling::any_rank(bool local) const {
  if (!distributed()) return local;
  return ns_.tree().global_max(std::int64_t{local ? 1 : 0}) != 0;
}

OwnedPositions CapsuleCoupling::owned_positions() const {
  if (!distributed()) return {};
  const int r = forest_->comm().rank();
  return {forest_->partition().split(r), forest_->partition().split(r + 1)};
}

int CapsuleCoupling::owner_of(const Eigen::Matrix3Xd& x) const {
  const tree::TreeOptions<3>& o = ns_.tree().options();
  const int level = o.max_level;
  const double h = ns_.tree().cell_size(level);
  const Eigen::Vector3d centre = x.rowwise().mean();
  tree::Coords<3> c{};
  for (int d = 0; d < 3; ++d) {
    const std::int64_t extent = std::int64_t{o.roots[d]} << level;
    auto i = static_cast<std::int64_t>(std::floor((centre[d] - o.origin[d]) / h));
    i = o.periodic[d] ? ((i % extent) + extent) % extent : std::clamp<std::int64_t>(i, 0, extent - 1);
    c[d] = static_cast<std::int32_t>(i);
  }
  return forest_->partition().owner(tree::curve_position<3>(level, tree::morton_encode<3>(c), level));
}

void CapsuleCoupling::distribute(ModelFactory factory) {
  factory_ = std::move(factory);
  forest_ = dynamic_cast<const tree::DistributedForest<3>*>(ns_.tree().distribution());
  if (!forest_) return;
  // Every rank holds every capsule here (they were added, or restored, on all): each keeps its own.
  const int me = forest_->comm().rank();
  for (auto& p : capsules_)
    if (p && owner_of(p->x) != me) p.reset();
}

void CapsuleCoupling::migrate() {
  const parallel::Comm& comm = forest_->comm();
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm.size()));
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    const Capsule& c = capsule(k);
    const int q = owner_of(c.x);
    if (q == comm.rank()) continue;
    // The state a step reads from the last one; forces, X* and the start velocity are recomputed.
    auto& w = send[static_cast<std::size_t>(q)];
    w.insert(w.end(), {static_cast<std::uint64_t>(k), static_cast<std::uint64_t>(c.x.cols()), history_flags(c)});
    push_matrix(w, c.x);
    push_matrix(w, c.x_at_adapt);
    push_history(w, c);
    w.insert(w.end(), {bits(c.work), bits(c.energy)});
    traffic_.words_sent += 5 + 12 * c.x.cols();
    capsules_[static_cast<std::size_t>(k)].reset();
    ++migrations_;
  }
  const auto received = parallel::sparse_exchange(comm, send);
  for (const auto& w : received)
    for (const std::uint64_t* p = w.data(); p < w.data() + w.size();) {
      const auto k = static_cast<int>(*p++);
      const auto nodes = static_cast<Eigen::Index>(*p++);
      const std::uint64_t flags = *p++;
      auto c = std::make_unique<Capsule>(Capsule{.model = factory_(k), .kernels = kernels_[static_cast<std::size_t>(k)]});
      p = pop_matrix(p, c->x, nodes);
      p = pop_matrix(p, c->x_at_adapt, nodes);
      p = pop_history(p, flags, nodes, c->velocity, c->motion);
      c->work = value(*p++);
      c->energy = value(*p++);
      capsules_[static_cast<std::size_t>(k)] = std::move(c);
    }
}

int CapsuleCoupling::stencil_reach(int k) const {
  // A face stencil of support W (W + 1 along its axis for the divergence-free form) lies
  // within W/2 + 1 cells of the cell holding the node; one more for safety.
  const KernelChoice& kc = kernels_[static_cast<std::size_t>(k)];
  const bool df = kc.staggered && kc.divergence_free;
  return std::max(support_of(kc.spread, df), support_of(kc.interpolate, df)) / 2 + 2;
}

RoutedNodes CapsuleCoupling::route(const std::function<const Eigen::Matrix3Xd&(const Capsule&)>& at, bool with_forces,
                                   const std::function<int(int)>& reach, bool stencil_boxes) const {
  const tree::Tree<3>& t = ns_.tree();
  const double h = t.cell_size(t.max_level());
  std::vector<OutgoingNodes> out;
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    OutgoingNodes o{k, &at(capsule(k)), with_forces ? &capsule(k).forces : nullptr, reach(k), {}};
    const KernelChoice& kc = kernels_[static_cast<std::size_t>(k)];
    if (stencil_boxes && kc.staggered)
      o.box = [&t, h, kc](const double* x, tree::Coords<3>& lo, tree::Coords<3>& hi) {
        const std::array kinds{kc.spread, kc.interpolate};
        const NodeBox b = node_box(t.options(), h, x, kinds, kc.divergence_free);
        for (int d = 0; d < 3; ++d) {
          lo[d] = b.first[d];
          hi[d] = b.first[d] + b.widths[d] - 1;
        }
      };
    out.push_back(std::move(o));
  }
  return route_nodes(forest_->comm(), forest_->partition(), t.options(), t.max_level(), out);
}

void CapsuleCoupling::spread_routed(int step) {
  const tree::Tree<3>& t = ns_.tree();
  const OwnedPositions own = owned_positions();
  any_cells_ = any_faces_ = false;
  // Capsules ascending, nodes ascending within each: the one-rank order of every face's sum.
  for (std::size_t r = 0; r < routed_.ranges.size(); ++r) {
    const RoutedNodes::Range& range = routed_.ranges[r];
    const KernelChoice& kc = kernels_[static_cast<std::size_t>(range.capsule)];
    const Eigen::Index n = range.end - range.begin;
    const Eigen::Matrix3Xd x = routed_.x.middleCols(range.begin, n), f = routed_.f.middleCols(range.begin, n);
    bool& started = kc.staggered ? any_faces_ : any_cells_;
    const SpreadMode mode = started ? SpreadMode::add : SpreadMode::assign;
    require_open_faces(step, range.capsule, r,
                       [&](Eigen::Index i) { return routed_.node[static_cast<std::size_t>(range.begin + i)]; });
    try {
      if (kc.staggered) spread_faces(kc.spread, kc.divergence_free, t, x, f, face_force_, workspace_, mode, own, boxes(r),
                                     spread_walls(r));
      else spread(kc.spread, t, x, f, force_, workspace_, mode, own);
    } catch (const StencilError& e) {  // named by the node's index in its capsule
      StencilError::Where w = e.where();
      w.node = routed_.node[static_cast<std::size_t>(range.begin + w.node)];
      fail_stencil(step, range.capsule, StencilError(e.what(), e.missing(), w));
    }
    started = true;
  }
  zero_unspread_forces();
}

void CapsuleCoupling::interpolate_routed(int step, const fluid::FaceField<3>& uf,
                                         const std::function<Eigen::Matrix3Xd&(Capsule&)>& velocity_of) {
  const tree::Tree<3>& t = ns_.tree();
  const OwnedPositions own = owned_positions();
  std::vector<PartialVelocities> partials(routed_.ranges.size());
  collectively([&] {
    for (std::size_t r = 0; r < routed_.ranges.size(); ++r) {
      const RoutedNodes::Range& range = routed_.ranges[r];
      const KernelChoice& kc = kernels_[static_cast<std::size_t>(range.capsule)];
      const Eigen::Matrix3Xd x = routed_.x.middleCols(range.begin, range.end - range.begin);
      try {
        interpolate_faces_owned(kc.interpolate, kc.divergence_free, t, uf, x, own, partials[r], boxes(r),
                                interpolation_walls(r));
      } catch (const StencilError& e) {
        StencilError::Where w = e.where();
        w.node = routed_.node[static_cast<std::size_t>(range.begin + w.node)];
        fail_stencil(step, range.capsule, StencilError(e.what(), e.missing(), w));
      }
    }
  });
  std::vector<VelocityTargets> targets;
  for (int k = 0; k < num_capsules(); ++k)
    if (owns(k)) {
      Capsule& c = capsule(k);
      targets.push_back({k, c.kernels.interpolate, c.kernels.divergence_free, &stage_positions(c), &velocity_of(c)});
    }
  // Local inconsistencies found after its exchange stop every rank alike.
  collectively([&] {
    traffic_.words_sent += return_velocities(forest_->comm(), t.options(), t.cell_size(t.max_level()), routed_, partials, targets);
  });
}

void CapsuleCoupling::distributed_forces(int step) {
  for (const KernelChoice& kc : kernels_)
    if (!kc.staggered)
      throw std::invalid_argument("ibm: the cell-centred coupling (staggered = false) runs on one rank only");
  migrate();
  collectively([&] {
    if (scheme_ == NodeScheme::midpoint) place_midpoints();
    if (scheme_ == NodeScheme::bdf2) place_bdf2_predictions();
    compute_forces(step);
  });
}

void CapsuleCoupling::distributed_spreading(int step) {
  auto t0 = Clock::now();
  routed_ = route([this](const Capsule& c) -> const Eigen::Matrix3Xd& { return stage_positions(c); }, true,
                  [this](int k) { return stencil_reach(k); }, true);
  traffic_.words_sent += routed_.words_sent;
  traffic_.most_capsules_received = std::max<std::int64_t>(traffic_.most_capsules_received,
                                                           static_cast<std::int64_t>(routed_.ranges.size()));
  traffic_.most_nodes_received = std::max<std::int64_t>(traffic_.most_nodes_received, routed_.x.cols());
  collectively([&] {
    find_boxes(routed_.ranges.size(), [this](std::size_t r) -> Eigen::Ref<const Eigen::Matrix3Xd> {
      const RoutedNodes::Range& range = routed_.ranges[r];
      return routed_.x.middleCols(range.begin, range.end - range.begin);
    }, [this](std::size_t r) -> const KernelChoice& { return kernels_[static_cast<std::size_t>(routed_.ranges[r].capsule)]; },
               owned_positions());
    spread_routed(step);
  });
  // The ghosts' faces hold their owners' sums (the flow's face loops read them).
  ns_.tree().update_ghosts(fluid::components<3>(face_force_));
  face_force_zero_ = false;  // the ghosts now hold their owners' sums
  // A rank that spread nothing may still hold a neighbour's forces on its ghosts' faces (an
  // owned cell's high face lies on the cell above it, which a node's stencil may reach while
  // missing every owned cell): the flow reads the face forces wherever a capsule spreads on
  // faces, on every rank alike.
  any_faces_ = any_faces_ || std::any_of(kernels_.begin(), kernels_.end(), [](const KernelChoice& kc) { return kc.staggered; });
  force_ready_ = true;
  times_.spreading += seconds_since(t0);
  if (scheme_ == NodeScheme::midpoint) {  // J(X*) u^n, as predict_midpoint on one rank
    t0 = Clock::now();
    interpolate_routed(step, start_face_velocity(), [](Capsule& c) -> Eigen::Matrix3Xd& { return c.start_velocity; });
    times_.interpolation += seconds_since(t0);
  }
}


std::int64_t CapsuleCoupling::leaf_weight(int level, tree::Key key, std::int64_t band_weight) const {
  if (level != ns_.tree().max_level()) return 1;
  const tree::Coords<3> ijk = tree::morton_decode<3>(key);
  auto in_band = [&](const MembraneTags& tags) { return tags.level() == level && tags.tagged(level, ijk); };
  if (distributed()) {
    for (const MembraneTags& tags : bands_)
      if (in_band(tags)) return band_weight;
  } else {
    for (const auto& c : capsules_)
      if (in_band(c->tags)) return band_weight;
  }
  return 1;
}

std::vector<CapsuleCoupling::SavedState> CapsuleCoupling::gather_on_root() const {
  std::vector<SavedState> all(static_cast<std::size_t>(num_capsules()));
  auto save = [](const Capsule& c) { return SavedState{c.x, c.x_at_adapt, c.velocity, c.motion, c.work}; };
  if (!distributed()) {
    for (int k = 0; k < num_capsules(); ++k) all[static_cast<std::size_t>(k)] = save(capsule(k));
    return all;
  }
  const parallel::Comm& comm = forest_->comm();
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm.size()));
  auto& w = send[0];
  for (int k = 0; k < num_capsules(); ++k) {
    if (!owns(k)) continue;
    const Capsule& c = capsule(k);
    w.insert(w.end(), {static_cast<std::uint64_t>(k), static_cast<std::uint64_t>(c.x.cols()), history_flags(c)});
    push_matrix(w, c.x);
    push_matrix(w, c.x_at_adapt);
    push_history(w, c);
    w.push_back(bits(c.work));
  }
  const auto received = parallel::sparse_exchange(comm, send);
  if (!comm.is_root()) return {};
  for (const auto& words : received)
    for (const std::uint64_t* p = words.data(); p < words.data() + words.size();) {
      const auto k = static_cast<std::size_t>(*p++);
      const auto nodes = static_cast<Eigen::Index>(*p++);
      const std::uint64_t flags = *p++;
      SavedState& s = all[k];
      p = pop_matrix(p, s.x, nodes);
      p = pop_matrix(p, s.x_at_adapt, nodes);
      p = pop_history(p, flags, nodes, s.velocity, s.motion);
      s.work = value(*p++);
    }
  return all;
}

}  // namespace capsflow::ibm
