#include "tree/ghost_layer.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "parallel/all_to_all.hpp"
#include "tree/curve_stencil.hpp"

namespace capsflow::tree {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(fmt::format("ghost layer: {} failed (MPI error {})", what, code));
}

}  // namespace

template <int D>
GhostLayer<D>::GhostLayer(const parallel::Comm& comm, const Partition& partition, const TreeOptions<D>& o,
                          std::span<const CurveCell> leaves, int width) {
  if (width < 1) throw std::invalid_argument(fmt::format("ghost layer: width {} must be >= 1", width));
  if (partition.ranks() != comm.size())
    throw std::invalid_argument(fmt::format("ghost layer: a partition of {} ranks on {}", partition.ranks(), comm.size()));
  if (!comm.distributed()) return;  // one rank: nothing is remote
  const int me = comm.rank(), p = comm.size();
  const int top = o.max_level;

  // 1. The stencil cells of every leaf, sent (level, position) to each rank that owns part
  //    of them. Ranks own contiguous ranges, so a cell's owners are owner(first)..owner(last).
  std::vector<std::vector<std::uint64_t>> requests(static_cast<std::size_t>(p));
  {
    std::vector<std::vector<CurveCell>> cells(static_cast<std::size_t>(p));
    std::vector<CurveCell> around;
    for (const CurveCell& leaf : leaves) {
      around.clear();
      const Key key = leaf.position >> (D * (top - leaf.level));
      stencil_cells<D>(o, leaf.level, morton_decode<D>(key), width, around);
      for (const CurveCell& c : around) {
        const Key last = c.position + (span_of<D>(c.level, top) - 1);
        for (int q = partition.owner(c.position); q <= partition.owner(last); ++q)
          if (q != me && partition.split(q) < partition.split(q + 1)) cells[static_cast<std::size_t>(q)].push_back(c);
      }
    }
    for (int q = 0; q < p; ++q) {
      auto& list = cells[static_cast<std::size_t>(q)];
      std::sort(list.begin(), list.end(), [](const CurveCell& a, const CurveCell& b) {
        return a.position != b.position ? a.position < b.position : a.level < b.level;
      });
      list.erase(std::unique(list.begin(), list.end()), list.end());
      for (const CurveCell& c : list) {
        requests[static_cast<std::size_t>(q)].push_back(c.position);
        requests[static_cast<std::size_t>(q)].push_back(static_cast<std::uint64_t>(c.level));
      }
    }
  }
  const auto asked = parallel::all_to_all(comm, requests);

  // 2. The leaves overlapping each asked cell: those starting inside its range (itself or its
  //    descendants) and the one starting before it if that one contains it (an ancestor).
  std::vector<Key> starts(leaves.size());
  for (std::size_t i = 0; i < leaves.size(); ++i) starts[i] = leaves[i].position;
  std::vector<std::vector<std::uint64_t>> answers(static_cast<std::size_t>(p));
  for (int q = 0; q < p; ++q) {
    const auto& words = asked[static_cast<std::size_t>(q)];
    if (words.empty()) continue;
    std::vector<std::int32_t> mirrors;
    for (std::size_t w = 0; w + 1 < words.size(); w += 2) {
      const Key begin = words[w];
      const int level = static_cast<int>(words[w + 1]);
      if (level < 0 || level > top) throw std::runtime_error("ghost layer: a request for a level out of range");
      const Key end = begin + span_of<D>(level, top);
      auto it = std::lower_bound(starts.begin(), starts.end(), begin);
      if (it != starts.begin()) {
        const auto before = static_cast<std::size_t>(it - starts.begin()) - 1;
        if (starts[before] + span_of<D>(leaves[before].level, top) > begin)
          mirrors.push_back(static_cast<std::int32_t>(before));
      }
      for (; it != starts.end() && *it < end; ++it) mirrors.push_back(static_cast<std::int32_t>(it - starts.begin()));
    }
    std::sort(mirrors.begin(), mirrors.end());
    mirrors.erase(std::unique(mirrors.begin(), mirrors.end()), mirrors.end());
    for (const std::int32_t i : mirrors) {
      answers[static_cast<std::size_t>(q)].push_back(leaves[static_cast<std::size_t>(i)].position);
      answers[static_cast<std::size_t>(q)].push_back(static_cast<std::uint64_t>(leaves[static_cast<std::size_t>(i)].level));
    }
    peers_.push_back({.rank = q, .mirrors = std::move(mirrors)});
  }
  const auto answered = parallel::all_to_all(comm, answers);

  // 3. The ghosts, by owner: each owner's answer is in its curve order, and the owners' ranges
  //    follow the curve, so the concatenation is in curve order.
  for (int q = 0; q < p; ++q) {
    const auto& words = answered[static_cast<std::size_t>(q)];
    if (words.empty()) continue;
    auto peer = std::find_if(peers_.begin(), peers_.end(), [q](const Peer& x) { return x.rank == q; });
    if (peer == peers_.end()) peer = peers_.insert(std::upper_bound(peers_.begin(), peers_.end(), q,
                                                                     [](int r, const Peer& x) { return r < x.rank; }),
                                                   Peer{.rank = q});
    peer->ghost_begin = static_cast<std::int32_t>(ghosts_.size());
    for (std::size_t w = 0; w + 1 < words.size(); w += 2)
      ghosts_.push_back({words[w], static_cast<int>(words[w + 1])});
    peer->ghost_end = static_cast<std::int32_t>(ghosts_.size());
  }
}

template <int D>
void GhostLayer<D>::exchange(const parallel::Comm& comm, std::span<const double> leaf_values,
                             std::span<double> ghost_values, int components) const {
  if (ghost_values.size() != ghosts_.size() * static_cast<std::size_t>(components))
    throw std::invalid_argument(fmt::format("ghost layer: {} ghost values for {} ghosts of {} components",
                                            ghost_values.size(), ghosts_.size(), components));
  if (peers_.empty()) return;
  constexpr int kTag = 7301;
  std::vector<MPI_Request> requests;
  requests.reserve(2 * peers_.size());
  // Receives first, so that a send can land directly in place.
  for (const Peer& peer : peers_) {
    if (peer.ghost_end == peer.ghost_begin) continue;
    requests.emplace_back();
    check(MPI_Irecv(ghost_values.data() + static_cast<std::ptrdiff_t>(peer.ghost_begin) * components,
                    (peer.ghost_end - peer.ghost_begin) * components, MPI_DOUBLE, peer.rank, kTag, comm.handle(),
                    &requests.back()),
          "MPI_Irecv");
  }
  std::vector<std::vector<double>> buffers(peers_.size());
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    const Peer& peer = peers_[k];
    if (peer.mirrors.empty()) continue;
    auto& b = buffers[k];
    b.reserve(peer.mirrors.size() * static_cast<std::size_t>(components));
    for (const std::int32_t i : peer.mirrors)
      for (int c = 0; c < components; ++c)
        b.push_back(leaf_values[static_cast<std::size_t>(i) * static_cast<std::size_t>(components) + static_cast<std::size_t>(c)]);
    requests.emplace_back();
    check(MPI_Isend(b.data(), static_cast<int>(b.size()), MPI_DOUBLE, peer.rank, kTag, comm.handle(), &requests.back()),
          "MPI_Isend");
  }
  check(MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE), "MPI_Waitall");
}

template <int D>
std::int64_t GhostLayer<D>::mirrors_sent() const {
  std::int64_t n = 0;
  for (const Peer& peer : peers_) n += static_cast<std::int64_t>(peer.mirrors.size());
  return n;
}

template class GhostLayer<2>;
template class GhostLayer<3>;

}  // namespace capsflow::tree
