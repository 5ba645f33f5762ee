#pragma once
// How much memory a run will take, estimated from the case before anything is allocated, so
// that a grid that cannot fit is refused at once (exit status 2) instead of growing for
// minutes and dying of std::bad_alloc.
#include <cstdint>
#include <optional>
#include <string>

#include "io/case_config.hpp"
#include "parallel/comm.hpp"

namespace capsflow::app {

struct MemoryEstimate {
  double cells = 0.0;  // on every level of the tree (leaves and their ancestors)
  double bytes = 0.0;
  int level = 0;             // the uniform level the count is for
  bool lower_bound = false;  // adaptive: only the min_level grid is known before the run
};

// A uniform run (adapt.enabled = false): the exact cell count of the tree refined to
// max_level times the measured bytes per cell. An adaptive run: the min_level grid only,
// a lower bound (how far it refines depends on the flow); it refuses only runs that cannot
// even start.
[[nodiscard]] MemoryEstimate estimate_memory(const io::CaseConfig& c);

// The memory this process may still use: MemAvailable from /proc/meminfo, lowered to the
// cgroup's limit (containers) when there is one; nullopt when neither can be read.
[[nodiscard]] std::optional<double> available_memory();

// "4G", "512M", "1.5GiB", "800k", "2000000000" (bytes); powers of 1024. Throws
// std::invalid_argument for anything else.
[[nodiscard]] std::uint64_t parse_memory_size(const std::string& text);

// Throws RequestError (output_dir.hpp) with the estimate when it exceeds `limit` (the whole
// run's memory, every rank together) or what the machines have: on N ranks each rank holds
// about 1/N of the cells (the start too: no rank builds the whole forest), so a node must
// hold its ranks' share, and the run fits if every node does. The message begins with
// `source` (the case file). Collective over comm: every rank takes the same decision.
void check_memory(const io::CaseConfig& c, std::optional<std::uint64_t> limit, const std::string& source,
                  const parallel::Comm& comm);

}  // namespace capsflow::app
