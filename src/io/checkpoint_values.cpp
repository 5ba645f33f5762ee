#include "io/checkpoint_values.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>

namespace capsflow::io::detail {

void check_scalars(const H5Io& io, const CheckpointScalars& s, const CheckpointExpectations& expect) {
  if (!std::isfinite(s.time)) io.fail(fmt::format("/scalars/time = {}: must be finite", s.time));
  if (s.time < 0.0) io.fail(fmt::format("/scalars/time = {}: must be >= 0", s.time));
  // The time loop runs while t < t_end (1 - 1e-12): a checkpoint at or past the end would
  // restart into zero steps and cut the outputs back to its time.
  if (s.time >= expect.t_end * (1 - 1e-12))
    io.fail(fmt::format("/scalars/time = {} is at or past time.t_end = {} of this case: nothing left to run "
                        "(raise time.t_end to continue)",
                        s.time, expect.t_end));
  if (s.step < 0) io.fail(fmt::format("/scalars/step = {}: must be >= 0", s.step));
  if (!std::isfinite(s.dt) || !(s.dt > 0.0)) io.fail(fmt::format("/scalars/dt = {}: must be finite and > 0", s.dt));
}

void check_finite(const H5Io& io, const std::string& path, std::span<const double> values) {
  const auto bad = std::find_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); });
  if (bad != values.end())
    io.fail(fmt::format("{}[{}] = {}: every value must be finite (was the run that wrote it blowing up?)", path,
                        bad - values.begin(), *bad));
}

namespace {

// i of "capsule_<i>_positions", or nothing for another name.
std::optional<std::size_t> capsule_index(const std::string& name) {
  constexpr std::string_view head = "capsule_", tail = "_positions";
  if (name.size() <= head.size() + tail.size() || !name.starts_with(head) || !name.ends_with(tail)) return {};
  const std::string digits = name.substr(head.size(), name.size() - head.size() - tail.size());
  if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(c); }))
    return {};
  return std::stoul(digits);
}

}  // namespace

void check_capsules(const H5Io& io, const std::vector<ExtraArray>& extras, const CheckpointExpectations& expect) {
  if (!expect.capsule_nodes) return;
  const std::vector<std::size_t>& nodes = *expect.capsule_nodes;
  std::size_t count = 0;
  for (const ExtraArray& e : extras)
    if (capsule_index(e.name)) ++count;
  if (count != nodes.size())
    io.fail(fmt::format("the checkpoint holds {} capsule(s), this case has {} ([[capsule]] tables): "
                        "restart from a checkpoint of this case",
                        count, nodes.size()));
  for (const ExtraArray& e : extras) {
    const std::optional<std::size_t> i = capsule_index(e.name);
    if (!i) continue;
    if (*i >= nodes.size())
      io.fail(fmt::format("/extras/{}: this case has capsules 0 to {} only", e.name, nodes.size() - 1));
    if (e.shape.size() != 2 || e.shape[1] != 3 || e.shape[0] != nodes[*i])
      io.fail(fmt::format("/extras/{} has shape [{}], capsule[{}] of this case has {} nodes (shape [{}, 3])", e.name,
                          fmt::join(e.shape, ", "), *i, nodes[*i], nodes[*i]));
  }
}

}  // namespace capsflow::io::detail
