#include "tree/distributed_forest.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <stdexcept>

#include <fmt/format.h>

#include "parallel/all_to_all.hpp"
#include "parallel/sparse_exchange.hpp"
#include "parallel/reduce.hpp"
#include "tree/leaf_migration.hpp"
#include "tree/radix_sort.hpp"
#include "tree/tree_from_cells.hpp"

namespace capsflow::tree {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS)
    throw std::runtime_error(fmt::format("distributed forest: {} failed (MPI error {})", what, code));
}

// Answers to "does this cell exist": not at all, as a leaf, as a parent.
enum : std::uint64_t { kAbsent = 0, kLeafCell = 1, kParentCell = 2 };

// Messages of level l carry this tag: exchanges of different levels never match.
constexpr int kTagBase = 7400;

template <int D>
Index local_index(const Tree<D>& t, const CurveCell& c) {
  const Index i = t.find(c.level, morton_decode<D>(key_of<D>(c, t.max_level())));
  if (i == kNone || i >= t.level(c.level).active_end())
    throw std::logic_error(fmt::format("distributed forest: cell (position {}, level {}) is not an active cell of the "
                                       "local tree",
                                       c.position, c.level));
  return i;
}

}  // namespace

template <int D>
DistributedForest<D>::DistributedForest(const parallel::Comm& comm, const Partition& partition,
                                        const TreeOptions<D>& o, std::span<const CurveCell> owned_leaves, int width)
    : width_(width), comm_(comm), partition_(partition), options_(o) {
  plan(partition, owned_leaves);
}

template <int D>
void DistributedForest<D>::plan(const Partition& partition, std::span<const CurveCell> owned_leaves) {
  if (partition.ranks() != comm_.size())
    throw std::invalid_argument(
        fmt::format("distributed forest: a partition of {} ranks on {}", partition.ranks(), comm_.size()));
  partition_ = partition;
  owned_.assign(owned_leaves.begin(), owned_leaves.end());
  required_.clear();
  peer_cells_.clear();
  level_peers_.clear();
  const parallel::Comm& comm = comm_;
  const TreeOptions<D>& o = options_;
  const int width = width_;
  const int me = comm.rank(), ranks = comm.size(), top = o.max_level;
  const Key begin = partition.split(me), end = partition.split(me + 1);
  auto mine = [&](Key position) { return position >= begin && position < end; };
  // Whether every cell of level m in the box [lo, hi] (inside the brick) is this rank's:
  // Morton keys grow with each coordinate, so the box's keys lie between its corners'. Most
  // stencils lie inside the rank's range and are settled by this test alone, without
  // visiting their cells (the plan of a 4 M-leaf part visited ~400 cells per leaf).
  auto box_is_mine = [&](int m, Coords<D> lo, Coords<D> hi) {
    for (int d = 0; d < D; ++d) {
      const std::int64_t extent = static_cast<std::int64_t>(o.roots[d]) << m;
      if (lo[d] >= 0 && hi[d] < extent) continue;
      if (o.periodic[d]) return false;  // wrapped across a periodic side: visit the cells
      lo[d] = std::max(lo[d], 0);       // beyond a wall there are no cells
      hi[d] = static_cast<std::int32_t>(std::min<std::int64_t>(hi[d], extent - 1));
    }
    return mine(curve_position<D>(m, morton_encode<D>(lo), top)) && mine(curve_position<D>(m, morton_encode<D>(hi), top));
  };
  auto around = [](const Coords<D>& c, int reach, int scale, int extra) {
    Coords<D> lo{}, hi{};
    for (int d = 0; d < D; ++d) {
      lo[d] = (c[d] - reach) * scale;
      hi[d] = (c[d] + reach) * scale + extra;
    }
    return std::pair{lo, hi};
  };
  for (const CurveCell& c : owned_)
    if (!mine(c.position)) throw std::invalid_argument("distributed forest: a leaf outside this rank's range");

  // 1. The centres of this rank's stencils per level, (a) and (b), and the children (c)
  //    of the cells next to every owned cell (leaves: fine faces at a jump; parents: the
  //    owner decides a merge, which looks at its neighbours' children).
  std::vector<std::vector<Key>> centres(static_cast<std::size_t>(top) + 1);
  std::vector<CurveCell> asked;  // remote cells this rank reads, before deduplication
  auto ask_children_around = [&](int m, Key key) {
    if (m >= top) return;
    // The children of the cells within one cell: the box [2(c - 1), 2(c + 1) + 1] of level m + 1.
    if (const auto [lo, hi] = around(morton_decode<D>(key), 1, 2, 1); box_is_mine(m + 1, lo, hi)) return;
    auto children_of = [&](const CurveCell& x) {
      const Key k = key_of<D>(x, top) << D;
      for (Key b = 0; b < Key{kChildren<D>}; ++b) {
        const CurveCell child{curve_position<D>(m + 1, k | b, top), m + 1};
        if (!mine(child.position)) asked.push_back(child);
      }
    };
    children_of({curve_position<D>(m, key, top), m});
    for_each_stencil_cell<D>(o, m, morton_decode<D>(key), 1, children_of);
  };
  // Owned ancestors: leaves come in curve order, so chains of ancestors share a prefix and
  // a walk up stops where it meets the previous one (or leaves this rank's range).
  std::vector<Key> last_ancestor(static_cast<std::size_t>(top) + 1, ~Key{0});
  std::vector<std::vector<CurveCell>> owned_cells(static_cast<std::size_t>(top) + 1);  // active, curve order per level
  for (const CurveCell& leaf : owned_) {
    const int m = leaf.level;
    const Key key = key_of<D>(leaf, top);
    centres[static_cast<std::size_t>(m)].push_back(key);
    owned_cells[static_cast<std::size_t>(m)].push_back(leaf);
    ask_children_around(m, key);
    for (int l = m - 1; l >= 0; --l) {
      const Key anc = key >> (D * (m - l));
      if (last_ancestor[static_cast<std::size_t>(l)] == anc || !mine(curve_position<D>(l, anc, top))) break;
      last_ancestor[static_cast<std::size_t>(l)] = anc;
      owned_cells[static_cast<std::size_t>(l)].push_back({curve_position<D>(l, anc, top), l});
      ask_children_around(l, anc);
    }
  }
  // Coarse levels with few cells per rank are replicated: every rank holds all their cells
  // and relaxes them all, identically, so the multigrid's many sweeps there need no message
  // (one exchange per level after the restriction brings every cell's residual). Without
  // it the level-0 sweeps alone were 350 exchanges a step of the seed shell on 2 ranks.
  replicated_levels_ = 0;
  {
    std::vector<std::int64_t> counts;
    for (const auto& cells : owned_cells) counts.push_back(static_cast<std::int64_t>(cells.size()));
    for (int l = 0; l <= top; ++l) {
      const std::int64_t total = parallel::global_sum(comm, counts[static_cast<std::size_t>(l)]);
      if (total == 0 || total > std::min<std::int64_t>(kReplicatedCellsPerRank * ranks, kReplicatedCellsMax)) break;
      replicated_levels_ = l + 1;
    }
    if (ranks == 1) replicated_levels_ = 0;
  }
  // From the finest level up, the parent of every cell within one cell of a centre is a
  // centre: a prolongation into level l reads the parent's neighbours, and the faces of a
  // ghost next to an owned cell read that ghost's halo, filled from its coarse neighbour's
  // block; those halo cells may in turn be filled from the level above, and so on (each
  // step stays within 2 cells of the ancestors' centres).
  for (int l = top; l >= 0; --l) {
    auto& keys = centres[static_cast<std::size_t>(l)];
    radix_sort(keys, [](Key k) { return k; });
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    if (l == 0) break;
    auto& parents = centres[static_cast<std::size_t>(l) - 1];
    auto inside = [&](const Coords<D>& c) {
      for (int d = 0; d < D; ++d)
        if (c[d] < 1 || c[d] + 1 >= (static_cast<std::int64_t>(o.roots[d]) << l)) return false;
      return true;
    };
    // Siblings (consecutive keys with one parent P) share their parents: child b's 3^D block
    // has the 2^D parents P + o with o_d in {-1, 0} where b's bit d is 0, {0, 1} where it is
    // 1. A run of siblings away from the sides pushes the union once (at most 3^D keys, not
    // 2^D per child: the sort below was most of a large plan's time).
    // A parent whose 3^D block is all this rank's pushes itself alone: every cell of the
    // block exists (2:1 balance around its children) and is this rank's, so it is a centre
    // already (each existing owned cell is: its first child is one, from the finest level up).
    constexpr int kBlock = ipow(3, D);
    for (std::size_t i = 0; i < keys.size();) {
      const Key parent = keys[i] >> D;
      std::size_t j = i;
      bool all_inside = true;
      for (; j < keys.size() && (keys[j] >> D) == parent; ++j) all_inside = all_inside && inside(morton_decode<D>(keys[j]));
      if (const auto [lo, hi] = around(morton_decode<D>(parent), 1, 1, 0); box_is_mine(l - 1, lo, hi)) {
        parents.push_back(parent);
      } else if (all_inside) {
        std::array<bool, kBlock> covered{};
        for (std::size_t r = i; r < j; ++r) {
          const auto b = static_cast<unsigned>(keys[r] & (Key{kChildren<D>} - 1));
          for (unsigned corner = 0; corner < kChildren<D>; ++corner) {
            int index = 0;
            for (int d = D - 1; d >= 0; --d) {
              const int offset = static_cast<int>((b >> d) & 1u) - 1 + static_cast<int>((corner >> d) & 1u);  // -1..1
              index = index * 3 + offset + 1;
            }
            covered[static_cast<std::size_t>(index)] = true;
          }
        }
        const Coords<D> p = morton_decode<D>(parent);
        for (int index = 0; index < kBlock; ++index) {
          if (!covered[static_cast<std::size_t>(index)]) continue;
          Coords<D> x{};
          for (int d = 0, rest = index; d < D; ++d, rest /= 3) x[d] = p[d] + rest % 3 - 1;
          parents.push_back(morton_encode<D>(x));
        }
      } else {
        for (std::size_t r = i; r < j; ++r) {
          parents.push_back(parent);
          for_each_stencil_cell<D>(o, l, morton_decode<D>(keys[r]), 1,
                                   [&](const CurveCell& x) { parents.push_back(key_of<D>(x, top) >> D); });
        }
      }
      i = j;
    }
  }
  // The cells within `width` of the centres whose box leaves this rank's range: the box is
  // the product of one interval per axis, so the union of the boxes is the centres dilated
  // along one axis after the other, each time sorted and deduplicated (2 D w + D keys per
  // centre instead of (2w + 1)^D: near the split most of a box's cells are a neighbour's).
  // The centres themselves are in the union; one that is another rank's is then asked too.
  std::vector<Key> near, dilated;
  for (int l = 0; l <= top; ++l) {
    auto& keys = centres[static_cast<std::size_t>(l)];
    near.clear();
    for (const Key k : keys)
      if (const auto [lo, hi] = around(morton_decode<D>(k), width, 1, 0); !box_is_mine(l, lo, hi)) near.push_back(k);
    std::vector<Key>().swap(keys);
    for (int d = 0; d < D && !near.empty(); ++d) {
      const std::int64_t extent = static_cast<std::int64_t>(o.roots[d]) << l;
      dilated.clear();
      for (const Key k : near) {
        Coords<D> c = morton_decode<D>(k);
        const std::int64_t centre = c[d];
        for (int offset = -width; offset <= width; ++offset) {
          std::int64_t v = centre + offset;
          if (v < 0 || v >= extent) {
            if (!o.periodic[d]) continue;  // beyond a wall: no cell
            v = ((v % extent) + extent) % extent;
          }
          c[d] = static_cast<std::int32_t>(v);
          dilated.push_back(morton_encode<D>(c));
        }
      }
      radix_sort(dilated, [](Key k) { return k; });
      dilated.erase(std::unique(dilated.begin(), dilated.end()), dilated.end());
      near.swap(dilated);
    }
    for (const Key k : near)
      if (const Key position = curve_position<D>(l, k, top); !mine(position)) asked.push_back({position, l});
  }
  sort_in_curve_order(asked);
  asked.erase(std::unique(asked.begin(), asked.end()), asked.end());
  std::erase_if(asked, [&](const CurveCell& c) { return c.level < replicated_levels_; });

  // 2. Ask each owner.
  std::vector<std::vector<CurveCell>> asked_of(static_cast<std::size_t>(ranks));
  std::vector<std::vector<std::uint64_t>> requests(static_cast<std::size_t>(ranks));
  for (const CurveCell& c : asked) {
    const int q = partition.owner(c.position);
    asked_of[static_cast<std::size_t>(q)].push_back(c);
    requests[static_cast<std::size_t>(q)].push_back(c.position);
    requests[static_cast<std::size_t>(q)].push_back(static_cast<std::uint64_t>(c.level));
  }
  const auto incoming = parallel::sparse_exchange(comm, requests);

  // 3. Answer: a cell exists iff one of this rank's leaves starts at its position at its
  //    level or deeper (its first descendant); it is a leaf iff that leaf has its level.
  std::vector<std::vector<std::uint64_t>> answers(static_cast<std::size_t>(ranks));
  std::vector<std::vector<CurveCell>> mirrors(static_cast<std::size_t>(ranks));
  for (int q = 0; q < ranks; ++q) {
    const auto& words = incoming[static_cast<std::size_t>(q)];
    for (std::size_t w = 0; w + 1 < words.size(); w += 2) {
      const CurveCell c{words[w], static_cast<int>(words[w + 1])};
      if (c.level < 0 || c.level > top || !mine(c.position))
        throw std::runtime_error("distributed forest: asked for a cell this rank does not own");
      const auto it = std::lower_bound(owned_.begin(), owned_.end(), CurveCell{c.position, 0}, curve_less);
      std::uint64_t answer = kAbsent;
      if (it != owned_.end() && it->position == c.position && it->level >= c.level)
        answer = it->level == c.level ? kLeafCell : kParentCell;
      answers[static_cast<std::size_t>(q)].push_back(answer);
      if (answer != kAbsent) mirrors[static_cast<std::size_t>(q)].push_back(c);
    }
  }
  const auto answered = parallel::sparse_exchange(comm, answers);

  // 4. The ghosts, and the cells the local tree must hold.
  required_ = owned_;
  for (int q = 0; q < ranks; ++q) {
    const auto u = static_cast<std::size_t>(q);
    if (answered[u].size() != asked_of[u].size())
      throw std::runtime_error("distributed forest: an owner answered a different number of cells");
    PeerCells peer{.rank = q, .send = std::move(mirrors[u]), .receive = {}};
    for (std::size_t i = 0; i < asked_of[u].size(); ++i) {
      if (answered[u][i] == kAbsent) continue;
      const CurveCell c = asked_of[u][i];
      peer.receive.push_back(c);
      required_.push_back(c);
      if (answered[u][i] == kParentCell) required_.push_back({c.position, c.level + 1});
    }
    if (!peer.send.empty() || !peer.receive.empty()) peer_cells_.push_back(std::move(peer));
  }
  // 5. Replicated levels: every owned cell to every other rank (after the stencil cells
  //    in each peer's lists, in the owner's curve order on both sides).
  if (replicated_levels_ > 0) {
    std::vector<std::uint64_t> words;
    for (int l = 0; l < replicated_levels_; ++l)
      for (const CurveCell& c : owned_cells[static_cast<std::size_t>(l)]) {
        const auto it = std::lower_bound(owned_.begin(), owned_.end(), CurveCell{c.position, 0}, curve_less);
        words.push_back(c.position);
        words.push_back(static_cast<std::uint64_t>(c.level));
        words.push_back(it->level == c.level ? kLeafCell : kParentCell);
      }
    std::vector<std::vector<std::uint64_t>> to_all(static_cast<std::size_t>(ranks));
    for (int q = 0; q < ranks; ++q)
      if (q != me) to_all[static_cast<std::size_t>(q)] = words;
    const auto from_all = parallel::all_to_all(comm, to_all);
    for (int q = 0; q < ranks; ++q) {
      if (q == me) continue;
      auto peer = std::find_if(peer_cells_.begin(), peer_cells_.end(), [q](const PeerCells& x) { return x.rank == q; });
      if (peer == peer_cells_.end())
        peer = peer_cells_.insert(std::upper_bound(peer_cells_.begin(), peer_cells_.end(), q,
                                                   [](int r, const PeerCells& x) { return r < x.rank; }),
                                  PeerCells{.rank = q, .send = {}, .receive = {}});
      for (int l = 0; l < replicated_levels_; ++l)
        peer->send.insert(peer->send.end(), owned_cells[static_cast<std::size_t>(l)].begin(),
                          owned_cells[static_cast<std::size_t>(l)].end());
      const auto& w = from_all[static_cast<std::size_t>(q)];
      for (std::size_t i = 0; i + 2 < w.size(); i += 3) {
        const CurveCell c{w[i], static_cast<int>(w[i + 1])};
        peer->receive.push_back(c);
        required_.push_back(c);
        if (w[i + 2] == kParentCell) required_.push_back({c.position, c.level + 1});
      }
    }
  }
  sort_in_curve_order(required_);
  required_.erase(std::unique(required_.begin(), required_.end()), required_.end());
}

template <int D>
bool DistributedForest<D>::replicated(int level) const {
  return level < replicated_levels_;
}

template <int D>
Tree<D> DistributedForest<D>::make_tree() const {
  return tree_refined_to<D>(options_, required_);
}

template <int D>
void DistributedForest<D>::attach(Tree<D>& t) {
  const int top = t.max_level();
  level_peers_.assign(static_cast<std::size_t>(top) + 1, {});
  for (const PeerCells& pc : peer_cells_) {
    std::vector<Peer> per_level(static_cast<std::size_t>(top) + 1);
    const auto colour = [&](const CurveCell& c) {
      return static_cast<std::size_t>(std::popcount(key_of<D>(c, top) & (Key{kChildren<D>} - 1)) & 1);
    };
    for (const CurveCell& c : pc.send) {
      Peer& p = per_level[static_cast<std::size_t>(c.level)];
      p.send.push_back(local_index(t, c));
      p.send_colour[colour(c)].push_back(p.send.back());
    }
    for (const CurveCell& c : pc.receive) {
      Peer& p = per_level[static_cast<std::size_t>(c.level)];
      p.receive.push_back(local_index(t, c));
      p.receive_colour[colour(c)].push_back(p.receive.back());
    }
    for (int l = 0; l <= top; ++l) {
      Peer& p = per_level[static_cast<std::size_t>(l)];
      if (p.send.empty() && p.receive.empty()) continue;
      p.rank = pc.rank;
      level_peers_[static_cast<std::size_t>(l)].push_back(std::move(p));
    }
  }
  const Key begin = partition_.split(comm_.rank()), end = partition_.split(comm_.rank() + 1);
  // Replicated levels: the peers' lists of those levels become one gather (every peer gets
  // the same list of this rank's cells there, in curve order).
  gathers_.assign(static_cast<std::size_t>(replicated_levels_), {});
  for (int l = 0; l < replicated_levels_; ++l) {
    Gather& g = gathers_[static_cast<std::size_t>(l)];
    const Level<D>& lv = t.level(l);
    for (Index i = 0; i < lv.n_active; ++i) {
      const Key position = curve_position<D>(l, lv.keys[static_cast<std::size_t>(i)], top);
      if (position >= begin && position < end) g.send.push_back(lv.base + i);
    }
    g.counts.assign(static_cast<std::size_t>(comm_.size()), 0);
    for (const Peer& p : level_peers_[static_cast<std::size_t>(l)])
      g.counts[static_cast<std::size_t>(p.rank)] = static_cast<int>(p.receive.size());
    g.counts[static_cast<std::size_t>(comm_.rank())] = static_cast<int>(g.send.size());
    for (int q = 0; q < comm_.size(); ++q) {
      g.offsets.push_back(static_cast<int>(g.receive.size()));
      if (q == comm_.rank()) {
        g.receive.insert(g.receive.end(), g.send.size(), kNone);
        continue;
      }
      for (const Peer& p : level_peers_[static_cast<std::size_t>(l)])
        if (p.rank == q) g.receive.insert(g.receive.end(), p.receive.begin(), p.receive.end());
    }
  }
  // exchange_all(): the replicated levels' gathers as one (each rank's block: its cells of
  // every replicated level, coarse to fine), the distributed levels' lists per peer one
  // after the other (both sides concatenate in the same level order).
  whole_gather_ = {};
  whole_gather_.counts.assign(static_cast<std::size_t>(comm_.size()), 0);
  for (const Gather& g : gathers_) {
    whole_gather_.send.insert(whole_gather_.send.end(), g.send.begin(), g.send.end());
    for (std::size_t q = 0; q < g.counts.size(); ++q) whole_gather_.counts[q] += g.counts[q];
  }
  for (std::size_t q = 0; q < whole_gather_.counts.size(); ++q) {
    whole_gather_.offsets.push_back(static_cast<int>(whole_gather_.receive.size()));
    for (const Gather& g : gathers_) {
      const auto block = g.receive.begin() + g.offsets[q];
      whole_gather_.receive.insert(whole_gather_.receive.end(), block, block + g.counts[q]);
    }
  }
  whole_peers_.clear();
  for (const PeerCells& pc : peer_cells_) {
    Peer whole;
    whole.rank = pc.rank;
    for (int l = replicated_levels_; l <= top; ++l)
      for (const Peer& p : level_peers_[static_cast<std::size_t>(l)])
        if (p.rank == pc.rank) {
          whole.send.insert(whole.send.end(), p.send.begin(), p.send.end());
          whole.receive.insert(whole.receive.end(), p.receive.begin(), p.receive.end());
        }
    if (!whole.send.empty() || !whole.receive.empty()) whole_peers_.push_back(std::move(whole));
  }
  std::vector<std::uint8_t> roles(static_cast<std::size_t>(t.num_cells()), Tree<D>::kPlaceholder);
  for (const auto& peers : level_peers_)
    for (const Peer& p : peers)
      for (const Index c : p.receive) roles[static_cast<std::size_t>(c)] = Tree<D>::kGhostCell;
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index i = 0; i < lv.n_active; ++i) {
      const Key position = curve_position<D>(l, lv.keys[static_cast<std::size_t>(i)], top);
      if (position >= begin && position < end) roles[static_cast<std::size_t>(lv.base + i)] = Tree<D>::kOwnedCell;
    }
  }
  t.set_distribution(this, std::move(roles), this);
  if constexpr (kAssertions) check_plan(t);
}

template <int D>
void DistributedForest<D>::check_plan(const Tree<D>& t) const {
  const int top = t.max_level();
  // 1. What this rank sends a peer is what the peer expects from it, cell for cell: each
  //    side's lists of the other go to the other and are compared there.
  std::vector<std::vector<std::uint64_t>> sends(static_cast<std::size_t>(comm_.size()));
  for (const PeerCells& pc : peer_cells_)
    for (const CurveCell& c : pc.send) {
      sends[static_cast<std::size_t>(pc.rank)].push_back(c.position);
      sends[static_cast<std::size_t>(pc.rank)].push_back(static_cast<std::uint64_t>(c.level));
    }
  const auto sent_to_me = parallel::sparse_exchange(comm_, sends);
  for (int q = 0; q < comm_.size(); ++q) {
    std::vector<std::uint64_t> expected;
    for (const PeerCells& pc : peer_cells_)
      if (pc.rank == q)
        for (const CurveCell& c : pc.receive) {
          expected.push_back(c.position);
          expected.push_back(static_cast<std::uint64_t>(c.level));
        }
    CAPSFLOW_ASSERT(expected == sent_to_me[static_cast<std::size_t>(q)],
                    fmt::format("distributed forest: rank {} sends rank {} other cells than it expects",
                                q, comm_.rank()));
  }
  // 2. Every cell of the local tree within `width` cells of an owned cell, at its level, is
  //    owned or a ghost: a stencil never reads a placeholder (every local cell is a cell of
  //    the global forest, and the plan asked for all of those near owned cells).
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index i = 0; i < lv.n_active; ++i) {
      if (!t.owns(lv.base + i)) continue;
      for_each_stencil_cell<D>(options_, l, morton_decode<D>(lv.keys[static_cast<std::size_t>(i)]), width_,
                               [&](const CurveCell& x) {
                                 const Index n = t.find(l, morton_decode<D>(key_of<D>(x, top)));
                                 CAPSFLOW_ASSERT(n == kNone || n >= lv.active_end() || t.holds(n),
                                                 fmt::format("distributed forest: rank {}: cell (position {}, level {}) "
                                                             "next to an owned cell is neither owned nor a ghost",
                                                             comm_.rank(), x.position, l));
                               });
    }
  }
}

template <int D>
void DistributedForest<D>::gather(const Gather& g, Fields fields) const {
  const std::size_t nf = fields.size(), n = g.send.size();
  gather_send_.resize(n * nf);
  gather_receive_.resize(g.receive.size() * nf);
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t i = 0; i < n; ++i) gather_send_[f * n + i] = fields[f][static_cast<std::size_t>(g.send[i])];
  // Each rank's block holds its fields one after the other.
  gather_counts_.resize(g.counts.size());
  gather_offsets_.resize(g.offsets.size());
  for (std::size_t q = 0; q < g.counts.size(); ++q) {
    gather_counts_[q] = g.counts[q] * static_cast<int>(nf);
    gather_offsets_[q] = g.offsets[q] * static_cast<int>(nf);
  }
  values_sent_ += static_cast<std::int64_t>(n * nf);
  const auto start = std::chrono::steady_clock::now();
  check(MPI_Allgatherv(gather_send_.data(), static_cast<int>(gather_send_.size()), MPI_DOUBLE, gather_receive_.data(),
                       gather_counts_.data(), gather_offsets_.data(), MPI_DOUBLE, comm_.handle()),
        "MPI_Allgatherv");
  waiting_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t q = 0; q < g.counts.size(); ++q) {
    const auto count = static_cast<std::size_t>(g.counts[q]), offset = static_cast<std::size_t>(g.offsets[q]);
    for (std::size_t f = 0; f < nf; ++f) {
      const double* block = gather_receive_.data() + nf * offset + f * count;
      for (std::size_t i = 0; i < count; ++i) {
        const Index c = g.receive[offset + i];
        if (c != kNone) fields[f][static_cast<std::size_t>(c)] = block[i];
      }
    }
  }
}

template <int D>
void DistributedForest<D>::exchange(int level, Fields fields) const {
  if (level < 0 || level >= static_cast<int>(level_peers_.size())) return;
  if (exchanges_.size() < level_peers_.size()) exchanges_.resize(level_peers_.size(), 0);
  if (level < replicated_levels_) {  // every rank calls it: every rank holds these levels
    ++exchanges_[static_cast<std::size_t>(level)];
    gather(gathers_[static_cast<std::size_t>(level)], fields);
    return;
  }
  const auto& peers = level_peers_[static_cast<std::size_t>(level)];
  if (peers.empty()) return;
  ++exchanges_[static_cast<std::size_t>(level)];
  exchange_lists(peers, kTagBase + level, fields, [](const Peer& p) { return std::pair{&p.send, &p.receive}; });
}

template <int D>
void DistributedForest<D>::exchange_colour(int level, std::span<double> v, int colour) const {
  if (level < replicated_levels_) {  // no lists by colour there: the whole level
    exchange(level, {&v, 1});
    return;
  }
  if (level >= static_cast<int>(level_peers_.size())) return;
  const auto& peers = level_peers_[static_cast<std::size_t>(level)];
  if (peers.empty()) return;
  if (colour_exchanges_.size() < level_peers_.size()) colour_exchanges_.resize(level_peers_.size(), 0);
  ++colour_exchanges_[static_cast<std::size_t>(level)];
  const auto k = static_cast<std::size_t>(colour & 1);
  const double waited = waiting_;
  exchange_lists(peers, kTagBase + level, {&v, 1},
                 [k](const Peer& p) { return std::pair{&p.send_colour[k], &p.receive_colour[k]}; });
  waiting_colour_ += waiting_ - waited;
}

template <int D>
void DistributedForest<D>::exchange_all(Fields fields) const {
  ++whole_exchanges_;
  whole_exchange_fields_ += static_cast<std::int64_t>(fields.size());
  if (replicated_levels_ > 0) gather(whole_gather_, fields);
  exchange_lists(whole_peers_, kTagBase - 1, fields, [](const Peer& p) { return std::pair{&p.send, &p.receive}; });
}

template <int D>
template <class Pick>
void DistributedForest<D>::exchange_lists(std::span<const Peer> peers, int tag, Fields fields, Pick pick) const {
  if (peers.empty()) return;
  const std::size_t nf = fields.size();
  send_buffers_.resize(std::max(send_buffers_.size(), peers.size()));
  receive_buffers_.resize(std::max(receive_buffers_.size(), peers.size()));
  std::vector<MPI_Request>& requests = requests_;  // kept: this runs ~1000 times a step
  requests.clear();
  for (std::size_t k = 0; k < peers.size(); ++k) {
    const std::vector<Index>& receive = *pick(peers[k]).second;
    if (receive.empty()) continue;
    // Buffers only grow: the levels take turns with them, and resizing up and down
    // zero-filled them each time (a tenth of the exchange's cost on 128^3).
    auto& b = receive_buffers_[k];
    const std::size_t n = receive.size() * nf;
    if (b.size() < n) b.resize(n);
    requests.emplace_back();
    check(MPI_Irecv(b.data(), static_cast<int>(n), MPI_DOUBLE, peers[k].rank, tag, comm_.handle(),
                    &requests.back()),
          "MPI_Irecv");
  }
  for (std::size_t k = 0; k < peers.size(); ++k) {
    const std::vector<Index>& send = *pick(peers[k]).first;
    if (send.empty()) continue;
    auto& b = send_buffers_[k];
    const std::size_t n = send.size();
    if (b.size() < n * nf) b.resize(n * nf);
    for (std::size_t f = 0; f < nf; ++f) {
      const std::span<double> v = fields[f];
      double* out = b.data() + f * n;
      for (std::size_t i = 0; i < n; ++i) out[i] = v[static_cast<std::size_t>(send[i])];
    }
    values_sent_ += static_cast<std::int64_t>(n * nf);
    requests.emplace_back();
    check(MPI_Isend(b.data(), static_cast<int>(n * nf), MPI_DOUBLE, peers[k].rank, tag, comm_.handle(),
                    &requests.back()),
          "MPI_Isend");
  }
  const auto start = std::chrono::steady_clock::now();
  check(MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE), "MPI_Waitall");
  waiting_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t k = 0; k < peers.size(); ++k) {
    const std::vector<Index>& receive = *pick(peers[k]).second;
    const std::size_t n = receive.size();
    for (std::size_t f = 0; f < nf; ++f) {
      const std::span<double> v = fields[f];
      const double* in = receive_buffers_[k].data() + f * n;
      for (std::size_t i = 0; i < n; ++i) v[static_cast<std::size_t>(receive[i])] = in[i];
    }
  }
}

template <int D>
template <class F>
auto DistributedForest<D>::timed_reduction(F&& f) const {
  const auto start = std::chrono::steady_clock::now();
  const auto result = f();
  reducing_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ++reductions_;
  return result;
}

template <int D>
double DistributedForest<D>::sum(const parallel::ExactSum& local) const {
  return timed_reduction([&] { return parallel::global_sum(comm_, local); });
}

template <int D>
double DistributedForest<D>::max(double local) const {
  return timed_reduction([&] { return parallel::global_max(comm_, local); });
}

template <int D>
std::int64_t DistributedForest<D>::sum(std::int64_t local) const {
  return timed_reduction([&] { return parallel::global_sum(comm_, local); });
}

template <int D>
std::int64_t DistributedForest<D>::max(std::int64_t local) const {
  return timed_reduction([&] { return parallel::global_max(comm_, local); });
}

template <int D>
AdaptCounts DistributedForest<D>::adapt(Tree<D>& t, int min_level) {
  constexpr int C = kChildren<D>;
  const int top = t.max_level();
  const auto n = static_cast<std::size_t>(t.num_cells());
  const std::span<const Index> owned_leaves = t.owned_leaves();
  // This rank's wishes for its leaves (+1 split, -1 merge candidate, 0 keep).
  std::vector<std::int8_t> wish(n, 0);
  for (const Index c : owned_leaves) wish[static_cast<std::size_t>(c)] = t.flags_[static_cast<std::size_t>(c)];
  std::vector<double> flags(n), merges(n);
  // An active cell's parent: the parent of its sibling group (no search).
  auto parent_of = [&](Index c, int l) {
    const Level<D>& lv = t.level(l);
    return lv.group_parent[static_cast<std::size_t>((c - lv.base) / C)];
  };
  for (int round = 0;; ++round) {
    if (round > 4 * (top + 1) * comm_.size())
      throw std::logic_error("distributed adapt: the ranks did not agree on the refinement");
    // The owners' wishes on the ghosts; placeholders keep.
    std::fill(flags.begin(), flags.end(), 0.0);
    for (const Index c : owned_leaves) flags[static_cast<std::size_t>(c)] = wish[static_cast<std::size_t>(c)];
    t.update_ghosts(flags);
    for (const Index c : t.leaves()) t.flags_[static_cast<std::size_t>(c)] = static_cast<std::int8_t>(flags[static_cast<std::size_t>(c)]);
    (void)t.decide(min_level);
    // A merge is the parent's owner's decision.
    std::fill(merges.begin(), merges.end(), 0.0);
    for (int l = 0; l < t.depth(); ++l) {
      const Level<D>& lv = t.level(l);
      for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
        if (!lv.is_leaf(c) && t.owns(c) && !t.refined_next_[static_cast<std::size_t>(c)]) merges[static_cast<std::size_t>(c)] = 1.0;
    }
    t.update_ghosts(merges);
    std::int64_t changed = 0;
    for (const Index c : owned_leaves) {
      const int l = t.level_of(c);
      std::int8_t decided = 0;
      if (t.refined_next_[static_cast<std::size_t>(c)]) decided = 1;
      else if (l > 0 && merges[static_cast<std::size_t>(parent_of(c, l))] != 0.0) decided = -1;
      if (decided != wish[static_cast<std::size_t>(c)]) {
        wish[static_cast<std::size_t>(c)] = decided;
        changed = 1;
      }
    }
    if (parallel::global_max(comm_, changed) == 0) break;
  }
  // Nothing to refine or merge on any rank: the local trees stay as they are (a repartition
  // by unchanged weights would rebuild the same ones), and so do the values that live outside
  // the fields (the flow's projected faces).
  std::int64_t wishes = 0;
  for (const Index c : owned_leaves) wishes += wish[static_cast<std::size_t>(c)] != 0;
  if (parallel::global_sum(comm_, wishes) == 0)
    return {.refined = 0, .coarsened = 0, .leaves = static_cast<Index>(t.owned_leaves().size()), .cells = t.num_cells()};

  // The new leaves of this rank's range, in curve order, with every field's values.
  const int fields = t.num_fields();
  std::vector<std::pair<CurveCell, Index>> old_leaves;
  for (const Index c : owned_leaves) {
    const int l = t.level_of(c);
    const Level<D>& lv = t.level(l);
    old_leaves.push_back({{curve_position<D>(l, lv.keys[static_cast<std::size_t>(c - lv.base)], top), l}, c});
  }
  sort_in_curve_order(old_leaves, [](const auto& x) -> const CurveCell& { return x.first; });
  std::vector<CurveCell> cells;
  std::vector<double> values;
  cells.reserve(old_leaves.size());
  values.reserve(old_leaves.size() * static_cast<std::size_t>(fields));
  std::vector<const double*> field;  // every field's values, taken once (not per leaf)
  for (int f = 0; f < fields; ++f) field.push_back(t.values(f).data());
  AdaptCounts counts;
  double children[C];
  for (const auto& [cell, c] : old_leaves) {
    const std::int8_t w = wish[static_cast<std::size_t>(c)];
    const int l = cell.level;
    if (w == 1) {
      ++counts.refined;
      const Key first = key_of<D>(cell, top) << D;
      const std::size_t at = values.size();
      values.resize(at + static_cast<std::size_t>(C * fields));
      for (int f = 0; f < fields; ++f) {
        t.child_values(c, f, children);
        for (int k = 0; k < C; ++k) values[at + static_cast<std::size_t>(k * fields + f)] = children[k];
      }
      for (Key k = 0; k < Key{C}; ++k) cells.push_back({curve_position<D>(l + 1, first | k, top), l + 1});
    } else if (w == -1) {
      // The merged leaf is emitted once, by the first child, on the parent's owner.
      const Index p = parent_of(c, l);
      const Level<D>& up = t.level(l - 1);
      const Index fc = up.first_child[static_cast<std::size_t>(p - up.base)];
      if (fc != c) continue;
      ++counts.coarsened;
      cells.push_back({cell.position, l - 1});
      for (int f = 0; f < fields; ++f) {
        const double* v = field[static_cast<std::size_t>(f)];
        double sum = 0.0;
        for (int k = 0; k < C; ++k) sum += v[static_cast<std::size_t>(fc + k)];
        values.push_back(t.field_spec(f).prolongation == Prolongation::none ? 0.0 : sum * (1.0 / C));
      }
    } else {
      cells.push_back(cell);
      for (int f = 0; f < fields; ++f) values.push_back(field[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)]);
    }
  }

  repartition(t, cells, std::move(values));
  counts.leaves = static_cast<Index>(t.owned_leaves().size());
  counts.cells = t.num_cells();
  return counts;
}

template <int D>
std::vector<std::int64_t> DistributedForest<D>::weights_of(std::span<const CurveCell> leaves) const {
  std::vector<std::int64_t> weights(leaves.size(), 1);
  if (weight_)
    for (std::size_t i = 0; i < leaves.size(); ++i) weights[i] = weight_(leaves[i].level, key_of<D>(leaves[i], options_.max_level));
  return weights;
}

template <int D>
std::int64_t DistributedForest<D>::owned_weight() const {
  std::int64_t sum = 0;
  for (const std::int64_t w : weights_of(owned_)) sum += w;
  return sum;
}

template <int D>
void DistributedForest<D>::repartition(Tree<D>& t, std::span<const CurveCell> leaves, std::vector<double> values) {
  const int fields = t.num_fields();
  if (fields == 0) values.assign(leaves.size(), 0.0);  // migrate_leaves carries one component at least
  std::vector<Key> positions(leaves.size());
  for (std::size_t i = 0; i < leaves.size(); ++i) positions[i] = leaves[i].position;
  const Partition next = Partition::by_weight(comm_, positions, weights_of(leaves));
  const MigratedLeaves moved = migrate_leaves(comm_, next, leaves, values, std::max(fields, 1));
  std::vector<FieldSpec<D>> specs;
  for (int f = 0; f < fields; ++f) specs.push_back(t.field_spec(f));
  plan(next, moved.leaves);
  t = make_tree();
  for (const auto& spec : specs) (void)t.add_field(spec);
  attach(t);
  for (std::size_t i = 0; i < moved.leaves.size(); ++i) {
    const Index c = local_index(t, moved.leaves[i]);
    for (int f = 0; f < fields; ++f)
      t.values(f)[static_cast<std::size_t>(c)] = moved.values[i * static_cast<std::size_t>(fields) + static_cast<std::size_t>(f)];
  }
  // Every field's ghosts in one exchange (one message per peer, not one per field).
  std::vector<std::span<double>> all;
  for (int f = 0; f < fields; ++f) all.push_back(t.values(f));
  t.update_ghosts(all);
}

template <int D>
void DistributedForest<D>::rebalance(Tree<D>& t) {
  const int fields = t.num_fields();
  std::vector<double> values;
  values.reserve(owned_.size() * static_cast<std::size_t>(fields));
  for (const CurveCell& cell : owned_) {
    const Index c = local_index(t, cell);
    for (int f = 0; f < fields; ++f) values.push_back(t.values(f)[static_cast<std::size_t>(c)]);
  }
  const std::vector<CurveCell> leaves = owned_;
  repartition(t, leaves, std::move(values));
}

template <int D>
typename DistributedForest<D>::Traffic DistributedForest<D>::traffic() const {
  Traffic out;
  for (const auto& peers : level_peers_) {
    std::int64_t ghosts = 0, messages = 0;
    for (const Peer& p : peers) {
      ghosts += static_cast<std::int64_t>(p.receive.size());
      out.mirror_cells += static_cast<std::int64_t>(p.send.size());
      messages += p.send.empty() ? 0 : 1;
    }
    out.ghost_cells += ghosts;
    out.messages += messages;
    out.ghosts_per_level.push_back(ghosts);
    out.messages_per_level.push_back(messages);
    const std::size_t l = out.ghosts_per_level.size() - 1;
    out.exchanges_per_level.push_back(l < exchanges_.size() ? exchanges_[l] : 0);
    out.colour_exchanges_per_level.push_back(l < colour_exchanges_.size() ? colour_exchanges_[l] : 0);
  }
  out.whole_exchanges = whole_exchanges_;
  out.whole_exchange_fields = whole_exchange_fields_;
  return out;
}

template <int D>
std::optional<Tree<D>> DistributedForest<D>::gather_on_root(const Tree<D>& local) const {
  const int fields = local.num_fields();
  const auto leaves = local.owned_leaves();
  std::vector<std::uint64_t> cells;
  std::vector<double> values;
  cells.reserve(2 * leaves.size());
  values.reserve(leaves.size() * static_cast<std::size_t>(fields));
  for (const Index c : leaves) {
    const int l = local.level_of(c);
    const Level<D>& lv = local.level(l);
    cells.push_back(curve_position<D>(l, lv.keys[static_cast<std::size_t>(c - lv.base)], local.max_level()));
    cells.push_back(static_cast<std::uint64_t>(l));
    for (int f = 0; f < fields; ++f) values.push_back(local.values(f)[static_cast<std::size_t>(c)]);
  }
  // Counts, then the cells and values of every rank on rank 0 (rank order is curve order).
  const int ranks = comm_.size();
  int count = static_cast<int>(leaves.size());
  std::vector<int> counts(static_cast<std::size_t>(ranks));
  check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm_.handle()), "MPI_Gather");
  std::vector<int> cell_counts, cell_offsets, value_counts, value_offsets;
  std::int64_t total = 0;
  if (comm_.is_root()) {
    for (int q = 0; q < ranks; ++q) {
      const int n = counts[static_cast<std::size_t>(q)];
      cell_offsets.push_back(static_cast<int>(2 * total));
      value_offsets.push_back(static_cast<int>(total * fields));
      cell_counts.push_back(2 * n);
      value_counts.push_back(n * fields);
      total += n;
    }
  }
  std::vector<std::uint64_t> all_cells(comm_.is_root() ? static_cast<std::size_t>(2 * total) : 0);
  std::vector<double> all_values(comm_.is_root() ? static_cast<std::size_t>(total * fields) : 0);
  check(MPI_Gatherv(cells.data(), static_cast<int>(cells.size()), MPI_UINT64_T, all_cells.data(), cell_counts.data(),
                    cell_offsets.data(), MPI_UINT64_T, 0, comm_.handle()),
        "MPI_Gatherv");
  check(MPI_Gatherv(values.data(), static_cast<int>(values.size()), MPI_DOUBLE, all_values.data(),
                    value_counts.data(), value_offsets.data(), MPI_DOUBLE, 0, comm_.handle()),
        "MPI_Gatherv");
  if (!comm_.is_root()) return std::nullopt;
  std::vector<CurveCell> all(static_cast<std::size_t>(total));
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = {all_cells[2 * i], static_cast<int>(all_cells[2 * i + 1])};
  // Each rank's leaves come level by level, not in curve order.
  std::vector<CurveCell> sorted = all;
  sort_in_curve_order(sorted);
  Tree<D> whole = tree_refined_to<D>(options_, sorted);
  for (int f = 0; f < fields; ++f) (void)whole.add_field(local.field_spec(f));
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Index c = local_index(whole, all[i]);
    for (int f = 0; f < fields; ++f)
      whole.values(f)[static_cast<std::size_t>(c)] = all_values[i * static_cast<std::size_t>(fields) + static_cast<std::size_t>(f)];
  }
  return whole;
}

template <int D>
std::unique_ptr<DistributedForest<D>> distribute(const parallel::Comm& comm, Tree<D>& t, LeafWeight weight) {
  const int top = t.max_level();
  std::vector<CurveCell> leaves;
  leaves.reserve(static_cast<std::size_t>(t.num_leaves()));
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index i = 0; i < lv.n_active; ++i)
      if (lv.leaf[static_cast<std::size_t>(i)])
        leaves.push_back({curve_position<D>(l, lv.keys[static_cast<std::size_t>(i)], top), l});
  }
  sort_in_curve_order(leaves);
  // Every rank holds the forest: rank 0 passes every leaf, the others none (by_weight is
  // collective and takes each rank's own leaves in rank order).
  std::vector<Key> positions;
  std::vector<std::int64_t> weights;
  if (comm.is_root())
    for (const CurveCell& c : leaves) {
      positions.push_back(c.position);
      weights.push_back(weight ? weight(c.level, key_of<D>(c, top)) : 1);
    }
  const Partition partition = Partition::by_weight(comm, positions, weights);
  const Key begin = partition.split(comm.rank()), end = partition.split(comm.rank() + 1);
  std::vector<CurveCell> owned;
  for (const CurveCell& c : leaves)
    if (c.position >= begin && c.position < end) owned.push_back(c);
  auto forest = std::make_unique<DistributedForest<D>>(comm, partition, t.options(), owned);
  forest->set_leaf_weight(std::move(weight));
  Tree<D> local = forest->make_tree();
  for (int f = 0; f < t.num_fields(); ++f) (void)local.add_field(t.field_spec(f));
  // Every active cell of the local tree is a cell of the forest (placeholders included).
  for (int l = 0; l <= local.depth(); ++l) {
    const Level<D>& lv = local.level(l);
    for (Index i = 0; i < lv.n_active; ++i) {
      const Index g = t.find(l, morton_decode<D>(lv.keys[static_cast<std::size_t>(i)]));
      if (g == kNone) continue;
      for (int f = 0; f < t.num_fields(); ++f)
        local.values(f)[static_cast<std::size_t>(lv.base + i)] = t.values(f)[static_cast<std::size_t>(g)];
    }
  }
  t = std::move(local);
  forest->attach(t);
  return forest;
}

template class DistributedForest<2>;
template class DistributedForest<3>;
template std::unique_ptr<DistributedForest<2>> distribute<2>(const parallel::Comm&, Tree<2>&, LeafWeight);
template std::unique_ptr<DistributedForest<3>> distribute<3>(const parallel::Comm&, Tree<3>&, LeafWeight);

}  // namespace capsflow::tree
