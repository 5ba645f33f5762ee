#include "tree/leaf_migration.hpp"

#include <stdexcept>

#include <fmt/format.h>

#include "parallel/collective_counts.hpp"

namespace capsflow::tree {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(fmt::format("leaf migration: {} failed (MPI error {})", what, code));
}

std::vector<int> offsets_of(const std::vector<int>& counts) {
  std::vector<int> offsets(counts.size(), 0);
  for (std::size_t q = 1; q < counts.size(); ++q) offsets[q] = offsets[q - 1] + counts[q - 1];
  return offsets;
}

}  // namespace

MigratedLeaves migrate_leaves(const parallel::Comm& comm, const Partition& target, std::span<const CurveCell> leaves,
                              std::span<const double> values, int components) {
  const auto per = static_cast<std::size_t>(components);
  if (components < 1 || values.size() != leaves.size() * per)
    throw std::invalid_argument(
        fmt::format("leaf migration: {} values for {} leaves of {} components", values.size(), leaves.size(), components));
  if (target.ranks() != comm.size())
    throw std::invalid_argument(fmt::format("leaf migration: a partition of {} ranks on {}", target.ranks(), comm.size()));
  if (!comm.distributed()) return {{leaves.begin(), leaves.end()}, {values.begin(), values.end()}};

  const int p = comm.size();
  std::vector<int> cells_out(static_cast<std::size_t>(p), 0);
  int previous = 0;
  for (const CurveCell& c : leaves) {
    const int q = target.owner(c.position);
    if (q < previous) throw std::invalid_argument("leaf migration: leaves not in curve order");
    previous = q;
    ++cells_out[static_cast<std::size_t>(q)];
  }
  std::vector<int> cells_in(static_cast<std::size_t>(p));
  // Counted as two all-to-all exchanges (its two MPI_Alltoallv, collective_counts.hpp).
  parallel::detail::count_all_to_all();
  parallel::detail::count_all_to_all();
  check(MPI_Alltoall(cells_out.data(), 1, MPI_INT, cells_in.data(), 1, MPI_INT, comm.handle()), "MPI_Alltoall");

  // Two words per leaf (position, level), `components` doubles per leaf; runs are contiguous
  // in the send arrays, so the offsets are running sums.
  auto scaled = [](std::vector<int> v, int k) {
    for (auto& x : v) x *= k;
    return v;
  };
  const auto words_out = scaled(cells_out, 2), words_in = scaled(cells_in, 2);
  const auto values_out = scaled(cells_out, components), values_in = scaled(cells_in, components);
  std::vector<std::uint64_t> send_words;
  send_words.reserve(2 * leaves.size());
  for (const CurveCell& c : leaves) {
    send_words.push_back(c.position);
    send_words.push_back(static_cast<std::uint64_t>(c.level));
  }
  int received = 0;
  for (const int n : cells_in) received += n;
  std::vector<std::uint64_t> recv_words(2 * static_cast<std::size_t>(received));
  MigratedLeaves out;
  out.values.resize(static_cast<std::size_t>(received) * per);
  check(MPI_Alltoallv(send_words.data(), words_out.data(), offsets_of(words_out).data(), MPI_UINT64_T,
                      recv_words.data(), words_in.data(), offsets_of(words_in).data(), MPI_UINT64_T, comm.handle()),
        "MPI_Alltoallv (cells)");
  check(MPI_Alltoallv(values.data(), values_out.data(), offsets_of(values_out).data(), MPI_DOUBLE, out.values.data(),
                      values_in.data(), offsets_of(values_in).data(), MPI_DOUBLE, comm.handle()),
        "MPI_Alltoallv (values)");
  out.leaves.reserve(static_cast<std::size_t>(received));
  for (std::size_t i = 0; i + 1 < recv_words.size(); i += 2)
    out.leaves.push_back({recv_words[i], static_cast<int>(recv_words[i + 1])});
  return out;
}

}  // namespace capsflow::tree
