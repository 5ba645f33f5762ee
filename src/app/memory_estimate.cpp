#include "app/memory_estimate.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <sys/resource.h>
#include <unistd.h>

#include <fmt/format.h>

#include "app/output_dir.hpp"
#include "parallel/reduce.hpp"

namespace capsflow::app {

namespace {

// Peak resident memory per tree cell, measured with /usr/bin/time -v (maximum resident set
// size) on uniform runs one level apart, whose difference removes the fixed part:
//   3D duct_3d, levels 5 and 6 (149 796 and 1 198 372 cells): 534 B/cell without snapshots,
//     818 B/cell with them (write_tree_vtu holds the points and connectivity of every leaf);
//   2D cavity_2d, levels 9 and 10 (349 525 and 1 398 101 cells): 414 and 430 B/cell.
// Both are Navier-Stokes runs (the advection holds every component's slopes and fluxes); a
// Stokes run holds about 100 B/cell less in 3D, so the estimate is an upper bound there.
// The fixed part (code, libraries, VTK, the membrane of a capsule case) is about 40 MB.
constexpr double kBytesPerCell[2][2] = {{414.0, 430.0}, {534.0, 818.0}};  // [3D][snapshots]
constexpr double kFixedBytes = 40e6;

std::string human(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024.0 && u < 6) {
    bytes /= 1024.0;
    ++u;
  }
  return fmt::format("{:.3g} {}", bytes, units[u]);
}

std::optional<double> meminfo_available() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  double value = 0.0;
  while (in >> key >> value >> unit)
    if (key == "MemAvailable:") return value * 1024.0;
  return std::nullopt;
}

// cgroup v2: memory.max ("max" when unlimited) minus memory.current.
std::optional<double> cgroup_available() {
  std::ifstream max_in("/sys/fs/cgroup/memory.max"), current_in("/sys/fs/cgroup/memory.current");
  std::string max;
  double current = 0.0;
  if (!(max_in >> max) || max == "max" || !(current_in >> current)) return std::nullopt;
  try {
    return std::max(0.0, std::stod(max) - current);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

}  // namespace

MemoryEstimate estimate_memory(const io::CaseConfig& c) {
  const int dim = c.dimension;
  MemoryEstimate e;
  e.lower_bound = c.adapt.enabled;
  e.level = c.adapt.enabled ? c.adapt.min_level : c.adapt.max_level;
  double roots = 1.0;
  for (int d = 0; d < dim; ++d) roots *= c.domain.roots[d];
  // Every level from the roots down: the multilevel tree stores the ancestors too.
  const double per_level = std::pow(2.0, dim);
  double cells_per_root = 0.0, at_level = 1.0;
  for (int l = 0; l <= e.level; ++l, at_level *= per_level) cells_per_root += at_level;
  e.cells = roots * cells_per_root;
  e.bytes = kFixedBytes + e.cells * kBytesPerCell[dim == 3 ? 1 : 0][c.output.vtu ? 1 : 0];
  return e;
}

// What `ulimit -v` (RLIMIT_AS) leaves of the address space: the limit minus what the process
// has mapped already (VmSize, first field of /proc/self/statm, in pages). None when unlimited.
std::optional<double> address_space_left() {
  rlimit r{};
  if (getrlimit(RLIMIT_AS, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return std::nullopt;
  std::ifstream statm("/proc/self/statm");
  double pages = 0.0;
  if (!(statm >> pages)) return std::nullopt;
  return std::max(0.0, double(r.rlim_cur) - pages * double(sysconf(_SC_PAGESIZE)));
}

std::optional<double> available_memory() {
  const auto mem = meminfo_available();
  const auto group = cgroup_available();
  if (mem && group) return std::min(*mem, *group);
  return mem ? mem : group;
}

std::uint64_t parse_memory_size(const std::string& text) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument("expected a size such as 4G, 512M or 2000000000 (bytes)");
  }
  std::string unit = text.substr(used);
  for (char& ch : unit) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  if (unit.ends_with("IB"))
    unit.resize(unit.size() - 2);
  else if (unit.size() == 2 && unit.back() == 'B')
    unit.resize(1);
  const std::string prefixes = "KMGTP";
  double scale = 1.0;
  if (unit == "B") unit.clear();
  if (!unit.empty()) {
    const auto at = prefixes.find(unit);
    if (unit.size() != 1 || at == std::string::npos)
      throw std::invalid_argument("expected a size such as 4G, 512M or 2000000000 (bytes)");
    scale = std::pow(1024.0, double(at + 1));
  }
  if (!(value > 0.0) || !std::isfinite(value * scale) || value * scale > 1.8e19)
    throw std::invalid_argument("expected a positive size such as 4G, 512M or 2000000000 (bytes)");
  return static_cast<std::uint64_t>(value * scale);
}

void check_memory(const io::CaseConfig& c, std::optional<std::uint64_t> limit, const std::string& source,
                  const parallel::Comm& comm) {
  const MemoryEstimate e = estimate_memory(c);
  // What the run may use in all, from each node's memory over its share of the ranks (and
  // each process's address-space limit over its 1/N): the tightest rank decides for all.
  const int on_node = comm.ranks_on_this_node();  // collective: once
  const double ranks = comm.size(), node_share = on_node / ranks;
  const double inf = std::numeric_limits<double>::infinity();
  const auto node_available = available_memory();
  const double available =
      parallel::global_min(comm, node_available ? *node_available / node_share : inf);
  const auto left_here = address_space_left();
  const double left = parallel::global_min(comm, left_here ? *left_here * ranks : inf);
  const auto all_ranks = [&](double bytes) {
    return ranks > 1 ? fmt::format("{} in all ({} on a node holding {} of the {} ranks)", human(bytes),
                                   human(bytes * node_share), on_node, comm.size())
                     : human(bytes);
  };
  std::string over;
  if (limit && e.bytes > double(*limit))
    over = fmt::format("--max-memory {}", human(double(*limit)));
  else if (e.bytes > available)
    over = fmt::format("the available memory, {}", all_ranks(available));
  else if (e.bytes - kFixedBytes > left)
    over = fmt::format("what the address-space limit (ulimit -v) leaves, {}", all_ranks(left));
  if (over.empty()) return;
  throw RequestError(
      fmt::format("{}: memory estimate {} ({:.3g} cells on levels 0 to {} of the tree{}) exceeds {}; lower "
                  "{} or domain.roots",
                  source, human(e.bytes), e.cells, e.level,
                  e.lower_bound ? ", the adaptive run's coarsest grid" : ", a uniform grid", over,
                  e.lower_bound ? "adapt.min_level" : "adapt.max_level (or use --adapt on)"));
}

}  // namespace capsflow::app
