// Bad input is refused with a message that names the value.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>

#include "tree/tree.hpp"

namespace capsflow::tree {
namespace {

using ::testing::HasSubstr;

template <class E, class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "no exception";
}

TEST(TreeErrors, NonPositiveBrick) {
  EXPECT_THAT(message_of<std::invalid_argument>([] { Tree<3> t({.roots = {4, 0, 1}}); }),
              HasSubstr("roots along y must be >= 1, got 0"));
  EXPECT_THAT(message_of<std::invalid_argument>([] { Tree<2> t({.roots = {-2, 1}}); }),
              HasSubstr("roots along x must be >= 1, got -2"));
  EXPECT_THAT(message_of<std::invalid_argument>([] { Tree<2> t({.roots = {1, 1}, .root_size = -0.5}); }),
              HasSubstr("root_size must be > 0, got -0.5"));
}

TEST(TreeErrors, MaxLevelAboveKeyLimit) {
  EXPECT_THAT(message_of<std::invalid_argument>([] { Tree<3> t({.roots = {4, 1, 1}, .max_level = 20}); }),
              HasSubstr("max_level 20 is above the key limit 19"));
  EXPECT_THAT(message_of<std::invalid_argument>([] { Tree<2> t({.roots = {1, 1}, .max_level = -1}); }),
              HasSubstr("max_level must be >= 0, got -1"));
  EXPECT_NO_THROW(Tree<3>({.roots = {4, 1, 1}, .max_level = 19}));
}

TEST(TreeErrors, PointOutsideDomain) {
  Tree<3> t({.roots = {4, 1, 1}, .root_size = 2, .origin = {-4, -1, -1}, .max_level = 6});
  EXPECT_THAT(message_of<std::out_of_range>([&] { (void)t.locate({0.0, 1.5, 0.0}); }),
              HasSubstr("point (0, 1.5, 0) is outside the domain along y: [-1, 1]"));
  EXPECT_NO_THROW((void)t.locate({4.0, 1.0, -1.0}));  // the closed boundary is inside
}

TEST(TreeErrors, AdaptLevelsOutOfRange) {
  Tree<2> t({.roots = {1, 1}, .max_level = 5});
  EXPECT_THAT(message_of<std::invalid_argument>([&] { (void)t.adapt({.max_level = 7}); }),
              HasSubstr("adapt max_level 7 exceeds the tree's max_level 5"));
  EXPECT_THAT(message_of<std::invalid_argument>([&] { (void)t.adapt({.min_level = 4, .max_level = 3}); }),
              HasSubstr("adapt min_level 4 is outside [0, max_level 3]"));
  const FieldId f = t.add_field({.name = "u"});
  EXPECT_THAT(message_of<std::invalid_argument>([&] { (void)t.adapt({.criteria = {{f, -1.0}}}); }),
              HasSubstr("wavelet tolerance of field 'u' must be > 0, got -1"));
  EXPECT_THAT(message_of<std::invalid_argument>([&] { (void)t.add_field({.name = "u"}); }),
              HasSubstr("field 'u' is registered twice"));
}

}  // namespace
}  // namespace capsflow::tree
