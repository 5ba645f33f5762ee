// CAPSFLOW_ASSERT: aborts with file:line, condition and message when assertions are on;
// evaluates nothing when they are off.
#include <gtest/gtest.h>

#include <string>

#include "common/assert.hpp"

namespace capsflow {
namespace {

TEST(Assert, PassingConditionIsSilent) {
  int evaluated = 0;
  CAPSFLOW_ASSERT(++evaluated == 1, "never printed");
  EXPECT_EQ(evaluated, kAssertions ? 1 : 0);
}

TEST(Assert, ReleaseEvaluatesNeitherConditionNorMessage) {
  if (kAssertions) GTEST_SKIP() << "assertions are on in this build";
  int evaluated = 0;
  auto message = [&] {
    ++evaluated;
    return std::string("costly");
  };
  CAPSFLOW_ASSERT(++evaluated < 0, message());
  EXPECT_EQ(evaluated, 0);
}

TEST(AssertDeathTest, FailureAbortsNamingTheConditionAndMessage) {
  if (!kAssertions) GTEST_SKIP() << "assertions are compiled out in this build";
  const int cells = 3;
  EXPECT_DEATH(CAPSFLOW_ASSERT(cells == 4, std::string("field has ") + std::to_string(cells) + " cells"),
               "assert_test\\.cpp:[0-9]+: capsflow assertion failed: cells == 4\n  field has 3 cells");
}

}  // namespace
}  // namespace capsflow
