#include "tree/leaf_migration.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <stdexcept>

#include <fmt/format.h>

#include "parallel/sparse_exchange.hpp"

namespace capsflow::tree {

MigratedLeaves migrate_leaves(const parallel::Comm& comm, const Partition& target, std::span<const CurveCell> leaves,
                              std::span<const double> values, int components) {
  const auto per = static_cast<std::size_t>(components);
  if (components < 1 || values.size() != leaves.size() * per)
    throw std::invalid_argument(
        fmt::format("leaf migration: {} values for {} leaves of {} components", values.size(), leaves.size(), components));
  if (target.ranks() != comm.size())
    throw std::invalid_argument(fmt::format("leaf migration: a partition of {} ranks on {}", target.ranks(), comm.size()));
  if (!comm.distributed()) return {{leaves.begin(), leaves.end()}, {values.begin(), values.end()}};

  // Each leaf to its new owner as (position, level, the values' bits): a rank sends to the
  // few ranks its range overlaps (parallel::sparse_exchange), not to every rank.
  const int p = comm.size();
  const std::size_t words_per_leaf = 2 + per;
  std::vector<int> owner(leaves.size());
  std::vector<std::size_t> count_to(static_cast<std::size_t>(p), 0);
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    owner[i] = target.owner(leaves[i].position);
    if (i > 0 && owner[i] < owner[i - 1]) throw std::invalid_argument("leaf migration: leaves not in curve order");
    ++count_to[static_cast<std::size_t>(owner[i])];
  }
  // The leaves that stay (one run: the leaves are in curve order) are not packed.
  const int me = comm.rank();
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(p));
  for (int q = 0; q < p; ++q)
    if (q != me) send[static_cast<std::size_t>(q)].reserve(words_per_leaf * count_to[static_cast<std::size_t>(q)]);
  std::size_t stay_begin = leaves.size();
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    if (owner[i] == me) {
      stay_begin = std::min(stay_begin, i);
      continue;
    }
    const CurveCell& c = leaves[i];
    auto& w = send[static_cast<std::size_t>(owner[i])];
    w.push_back(c.position);
    w.push_back(static_cast<std::uint64_t>(c.level));
    for (std::size_t k = 0; k < per; ++k) w.push_back(std::bit_cast<std::uint64_t>(values[i * per + k]));
  }
  const auto received = parallel::sparse_exchange(comm, send);
  const std::size_t stay = count_to[static_cast<std::size_t>(me)];
  std::size_t count = stay;
  for (const auto& w : received) {
    if (w.size() % words_per_leaf != 0) throw std::runtime_error("leaf migration: a message of partial leaves");
    count += w.size() / words_per_leaf;
  }
  // By sender rank: the old parts are consecutive ranges of the curve, so this is curve order.
  MigratedLeaves out;
  out.leaves.reserve(count);
  out.values.reserve(count * per);
  for (int q = 0; q < p; ++q) {
    if (q == me) {
      out.leaves.insert(out.leaves.end(), leaves.begin() + static_cast<std::ptrdiff_t>(stay_begin),
                        leaves.begin() + static_cast<std::ptrdiff_t>(stay_begin + stay));
      out.values.insert(out.values.end(), values.begin() + static_cast<std::ptrdiff_t>(stay_begin * per),
                        values.begin() + static_cast<std::ptrdiff_t>((stay_begin + stay) * per));
      continue;
    }
    const auto& w = received[static_cast<std::size_t>(q)];
    for (std::size_t i = 0; i < w.size(); i += words_per_leaf) {
      out.leaves.push_back({w[i], static_cast<int>(w[i + 1])});
      for (std::size_t k = 0; k < per; ++k) out.values.push_back(std::bit_cast<double>(w[i + 2 + k]));
    }
  }
  return out;
}

}  // namespace capsflow::tree
