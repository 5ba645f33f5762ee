// Membrane nodes to the owners of their stencils' cells and interpolated velocities back
// (node_routing.hpp).
#include "ibm/node_routing.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include <fmt/format.h>

#include "parallel/sparse_exchange.hpp"
#include "tree/box_owners.hpp"

namespace capsflow::ibm {

namespace {

constexpr int kNodeWords = 8;  // capsule, node, x (3), f (3)

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }
double value(std::uint64_t w) { return std::bit_cast<double>(w); }

// The cell of `level` holding x along each axis (unwrapped across periodic sides).
tree::Coords<3> cell_of(const tree::TreeOptions<3>& o, double h, const double* x) {
  tree::Coords<3> c{};
  for (int d = 0; d < 3; ++d) c[d] = static_cast<std::int32_t>(std::floor((x[d] - o.origin[d]) / h));
  return c;
}

}  // namespace

RoutedNodes route_nodes(const parallel::Comm& comm, const tree::Partition& partition,
                        const tree::TreeOptions<3>& options, int level, std::span<const OutgoingNodes> outgoing) {
  const int p = comm.size();
  const double h = options.root_size / static_cast<double>(std::int64_t{1} << level);
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(p));
  std::vector<int> ranks;
  RoutedNodes out;
  auto pack = [&](int q, const OutgoingNodes& o, Eigen::Index i) {
    auto& w = send[static_cast<std::size_t>(q)];
    w.push_back(static_cast<std::uint64_t>(o.capsule));
    w.push_back(static_cast<std::uint64_t>(i));
    for (int d = 0; d < 3; ++d) w.push_back(bits((*o.x)(d, i)));
    for (int d = 0; d < 3; ++d) w.push_back(bits(o.f ? (*o.f)(d, i) : 0.0));
    if (q != comm.rank()) ++out.nodes_sent;
  };
  for (const OutgoingNodes& o : outgoing) {
    const Eigen::Index n = o.x->cols();
    if (n == 0) continue;
    // The whole capsule's box first: when one rank owns it all (the common case on few ranks),
    // every node goes there without a search of its own.
    tree::Coords<3> lo = cell_of(options, h, &(*o.x)(0, 0)), hi = lo;
    for (Eigen::Index i = 1; i < n; ++i) {
      const tree::Coords<3> c = cell_of(options, h, &(*o.x)(0, i));
      for (int d = 0; d < 3; ++d) {
        lo[d] = std::min(lo[d], c[d]);
        hi[d] = std::max(hi[d], c[d]);
      }
    }
    for (int d = 0; d < 3; ++d) {
      lo[d] -= o.reach;
      hi[d] += o.reach;
    }
    ranks.clear();
    tree::box_owners<3>(partition, options, level, lo, hi, ranks);
    if (ranks.size() == 1) {
      for (Eigen::Index i = 0; i < n; ++i) pack(ranks[0], o, i);
      continue;
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      tree::Coords<3> a{}, b{};
      if (o.box) {
        o.box(&(*o.x)(0, i), a, b);
      } else {
        const tree::Coords<3> c = cell_of(options, h, &(*o.x)(0, i));
        for (int d = 0; d < 3; ++d) {
          a[d] = c[d] - o.reach;
          b[d] = c[d] + o.reach;
        }
      }
      ranks.clear();
      tree::box_owners<3>(partition, options, level, a, b, ranks);
      for (const int q : ranks) pack(q, o, i);
    }
  }
  for (int q = 0; q < p; ++q)
    if (q != comm.rank() && !send[static_cast<std::size_t>(q)].empty()) {
      ++out.ranks_sent_to;
      out.words_sent += static_cast<std::int64_t>(send[static_cast<std::size_t>(q)].size());
    }

  const auto received = parallel::sparse_exchange(comm, send);
  struct Entry {
    int capsule, owner;
    std::int32_t node;
    const std::uint64_t* w;
  };
  std::vector<Entry> entries;
  for (int q = 0; q < p; ++q) {
    const auto& w = received[static_cast<std::size_t>(q)];
    for (std::size_t k = 0; k + kNodeWords <= w.size(); k += kNodeWords)
      entries.push_back({static_cast<int>(w[k]), q, static_cast<std::int32_t>(w[k + 1]), w.data() + k});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.capsule != b.capsule ? a.capsule < b.capsule : a.node < b.node;
  });
  const auto m = static_cast<Eigen::Index>(entries.size());
  out.node.resize(static_cast<std::size_t>(m));
  out.x.resize(3, m);
  out.f.resize(3, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    const Entry& e = entries[static_cast<std::size_t>(i)];
    out.node[static_cast<std::size_t>(i)] = e.node;
    for (int d = 0; d < 3; ++d) {
      out.x(d, i) = value(e.w[2 + d]);
      out.f(d, i) = value(e.w[5 + d]);
    }
    if (out.ranges.empty() || out.ranges.back().capsule != e.capsule) out.ranges.push_back({e.capsule, e.owner, i, i});
    out.ranges.back().end = i + 1;
  }
  return out;
}

std::int64_t return_velocities(const parallel::Comm& comm, const tree::TreeOptions<3>& options, double h,
                               const RoutedNodes& routed, std::span<const PartialVelocities> partials,
                               std::span<const VelocityTargets> targets) {
  if (partials.size() != routed.ranges.size())
    throw std::logic_error("ibm: one set of partial velocities per routed capsule expected");
  // Per reply: capsule, node, axis + 4 kind + 256 count, then the sum or count (slot, value) pairs.
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm.size()));
  for (std::size_t r = 0; r < routed.ranges.size(); ++r) {
    const RoutedNodes::Range& range = routed.ranges[r];
    const PartialVelocities& pv = partials[r];
    auto& w = send[static_cast<std::size_t>(range.owner)];
    for (Eigen::Index i = range.begin; i < range.end; ++i)
      for (int d = 0; d < 3; ++d) {
        const auto k = static_cast<std::size_t>(3 * (i - range.begin) + d);
        const std::uint8_t kind = pv.kind[k];
        if (kind == PartialVelocities::kNothing) continue;
        w.push_back(static_cast<std::uint64_t>(range.capsule));
        w.push_back(static_cast<std::uint64_t>(routed.node[static_cast<std::size_t>(i)]));
        const std::uint64_t count = kind == PartialVelocities::kSum ? 0 : pv.count[k];
        w.push_back(static_cast<std::uint64_t>(d) + 4 * kind + 256 * count);
        if (kind == PartialVelocities::kSum) {
          w.push_back(bits(pv.sum[k]));
          continue;
        }
        for (std::uint32_t j = 0; j < pv.count[k]; ++j) {
          w.push_back(pv.slots[pv.offset[k] + j]);
          w.push_back(bits(pv.values[pv.offset[k] + j]));
        }
      }
  }
  std::int64_t sent = 0;
  for (int q = 0; q < comm.size(); ++q)
    if (q != comm.rank()) sent += static_cast<std::int64_t>(send[static_cast<std::size_t>(q)].size());
  const auto received = parallel::sparse_exchange(comm, send);

  // Flags, not NaN markers: a blown-up flow's NaN must reach the caller's finiteness check.
  std::unordered_map<int, std::pair<const VelocityTargets*, std::vector<std::uint8_t>>> target_of;
  for (const VelocityTargets& t : targets) {
    target_of[t.capsule] = {&t, std::vector<std::uint8_t>(static_cast<std::size_t>(3 * t.x->cols()), 0)};
    t.v->setZero(3, t.x->cols());
  }
  // Slots gathered for the node-components no rank had whole: values in slot order, count.
  struct Gathered {
    std::vector<double> values;
    std::vector<std::uint8_t> set;
    int filled = 0;
  };
  std::unordered_map<std::uint64_t, Gathered> gathered;  // key: capsule, node, axis
  auto fail = [](int capsule, std::int64_t node, int d, const char* what) {
    throw std::logic_error(fmt::format("ibm: capsule {} node {} component {}: {}", capsule, node, d, what));
  };
  for (const auto& w : received) {
    for (std::size_t k = 0; k < w.size();) {
      const int capsule = static_cast<int>(w[k]);
      const auto node = static_cast<Eigen::Index>(w[k + 1]);
      const int d = static_cast<int>(w[k + 2] % 4), kind = static_cast<int>((w[k + 2] / 4) % 64);
      const auto count = static_cast<std::size_t>(w[k + 2] / 256);
      k += 3;
      const auto it = target_of.find(capsule);
      if (it == target_of.end()) fail(capsule, node, d, "velocities for a capsule this rank does not own");
      const VelocityTargets& t = *it->second.first;
      std::uint8_t& done = it->second.second[static_cast<std::size_t>(3 * node + d)];
      if (kind == PartialVelocities::kSum) {
        if (done) fail(capsule, node, d, "two whole sums");
        (*t.v)(d, node) = value(w[k++]);
        done = 1;
        continue;
      }
      const std::uint64_t key = (static_cast<std::uint64_t>(capsule) << 34) | (static_cast<std::uint64_t>(node) << 2) |
                                static_cast<std::uint64_t>(d);
      Gathered& g = gathered[key];
      if (g.values.empty()) {
        const int wd = support_of(t.kernel, false);
        const auto size = static_cast<std::size_t>(t.divergence_free ? wd * wd * (wd + 1) : wd * wd * wd);
        g.values.assign(size, 0.0);
        g.set.assign(size, 0);
      }
      for (std::size_t j = 0; j < count; ++j, k += 2) {
        const auto slot = static_cast<std::size_t>(w[k]);
        if (slot >= g.values.size() || g.set[slot]) fail(capsule, node, d, "a stencil slot twice");
        g.values[slot] = value(w[k + 1]);
        g.set[slot] = 1;
        ++g.filled;
      }
    }
  }
  for (auto& [key, g] : gathered) {
    const int capsule = static_cast<int>(key >> 34), d = static_cast<int>(key & 3);
    const auto node = static_cast<Eigen::Index>((key >> 2) & ((std::uint64_t{1} << 32) - 1));
    auto& [target, done] = target_of.at(capsule);
    const VelocityTargets& t = *target;
    if (g.filled != static_cast<int>(g.values.size())) fail(capsule, node, d, "stencil values missing");
    std::uint8_t& flag = done[static_cast<std::size_t>(3 * node + d)];
    if (flag) fail(capsule, node, d, "a whole sum and slots");
    (*t.v)(d, node) = complete_face_velocity(t.kernel, t.divergence_free, options, h, &(*t.x)(0, node), d, g.values);
    flag = 1;
  }
  for (const auto& [capsule, entry] : target_of)
    for (std::size_t k = 0; k < entry.second.size(); ++k)
      if (!entry.second[k]) fail(capsule, static_cast<std::int64_t>(k / 3), static_cast<int>(k % 3), "no rank interpolated it");
  return sent;
}

}  // namespace capsflow::ibm
