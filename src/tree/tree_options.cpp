#include "tree/tree_options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>

#include "tree/morton.hpp"
#include <stdexcept>

namespace capsflow::tree {

namespace {
int bits_for(int n) {  // bits needed to hold 0 .. n-1
  int b = 0;
  while ((std::int64_t{1} << b) < n) ++b;
  return b;
}
}  // namespace

template <int D>
void validate(const TreeOptions<D>& o) {
  static constexpr char kAxis[] = {'x', 'y', 'z'};
  int widest = 0;
  for (int d = 0; d < D; ++d) {
    if (o.roots[d] < 1)
      throw std::invalid_argument(fmt::format("tree: roots along {} must be >= 1, got {}",
                                              kAxis[d], o.roots[d]));
    widest = std::max(widest, bits_for(o.roots[d]));
  }
  if (!(o.root_size > 0.0))
    throw std::invalid_argument(fmt::format("tree: root_size must be > 0, got {}", o.root_size));
  if (o.max_level < 0)
    throw std::invalid_argument(fmt::format("tree: max_level must be >= 0, got {}", o.max_level));
  // Coordinates of every level, and of the ghost layer around the brick, must fit in the
  // bits of a Morton key per direction (and in a signed 32-bit coordinate).
  const int limit = std::min(kKeyBitsPerDim<D>, 30) - widest;
  if (o.max_level > limit)
    throw std::invalid_argument(fmt::format(
        "tree: max_level {} is above the key limit {} for a brick {} roots wide", o.max_level,
        limit, std::int64_t{1} << widest));
}

template void validate<2>(const TreeOptions<2>&);
template void validate<3>(const TreeOptions<3>&);

}  // namespace capsflow::tree
