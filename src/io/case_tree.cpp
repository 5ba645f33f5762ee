#include <stdexcept>

#include "io/case_config.hpp"

namespace capsflow::io {

template <int D>
tree::TreeOptions<D> tree_options(const CaseConfig& c) {
  tree::TreeOptions<D> o;
  for (int d = 0; d < D; ++d) {
    o.roots[d] = c.domain.roots[d];
    o.origin[d] = c.domain.origin[d];
    o.periodic[d] = c.domain.periodic[d];
  }
  o.root_size = c.domain.root_size;
  o.max_level = c.adapt.max_level;
  return o;
}

template tree::TreeOptions<2> tree_options<2>(const CaseConfig&);
template tree::TreeOptions<3> tree_options<3>(const CaseConfig&);

namespace {
// The tree owns the key-limit rule (tree::validate); ask it rather than repeat it.
template <int D>
int deepest(const CaseConfig& c) {
  tree::TreeOptions<D> o = tree_options<D>(c);
  int level = 0;
  for (o.max_level = 1; o.max_level <= 64; ++o.max_level) {
    try {
      tree::validate(o);
    } catch (const std::invalid_argument&) {
      break;
    }
    level = o.max_level;
  }
  return level;
}
}  // namespace

int max_tree_level(const CaseConfig& c) { return c.dimension == 2 ? deepest<2>(c) : deepest<3>(c); }

}  // namespace capsflow::io
