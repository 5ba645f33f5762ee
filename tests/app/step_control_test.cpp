// The step chosen by accuracy (app/step_control.hpp): the next step from the error estimate,
// its bounds, the landing on the adaptation instants, and its restart.
#include "app/step_control.hpp"

#include <gtest/gtest.h>

namespace capsflow::app {
namespace {

TEST(StepControl, NextStepFollowsTheErrorPerUnitTime) {
  StepControl c({.tolerance = 0.01, .first_dt = 1e-3});
  ASSERT_TRUE(c.enabled());
  EXPECT_EQ(c.next(0.0), 1e-3);
  c.after_step(1e-3, -1.0);  // no estimate yet (the first step): the same step
  EXPECT_EQ(c.next(1e-3), 1e-3);
  c.after_step(1e-3, 0.0075);  // e = 0.0075: 0.9 x 0.01 / 0.0075 = 1.2
  EXPECT_DOUBLE_EQ(c.error(), 0.0075);
  EXPECT_DOUBLE_EQ(c.next(2e-3), 1.2e-3);
  c.after_step(1.2e-3, 0.001);  // e = 0.001: growth capped at 2
  EXPECT_DOUBLE_EQ(c.next(0.0), 2.4e-3);
  c.after_step(2.4e-3, 0.5);  // e = 0.5: shrink capped at a quarter
  EXPECT_DOUBLE_EQ(c.next(0.0), 6e-4);
  c.after_step(6e-4, 0.0);  // no change at all: growth capped
  EXPECT_DOUBLE_EQ(c.next(0.0), 1.2e-3);
}

// A second-order step's error falls as dt^2: the step follows the square root of the ratio.
TEST(StepControl, SecondOrderStepsFollowTheSquareRoot) {
  StepControl c({.tolerance = 0.01, .first_dt = 1e-3});
  c.after_step(1e-3, 0.0081, 2);  // 0.9 sqrt(0.01 / 0.0081) = 1
  EXPECT_DOUBLE_EQ(c.next(0.0), 1e-3);
  c.after_step(1e-3, 0.0324, 2);  // 0.9 sqrt(0.01 / 0.0324) = 0.5
  EXPECT_DOUBLE_EQ(c.next(0.0), 5e-4);
  c.after_step(5e-4, 1.0, 2);  // still a quarter at most
  EXPECT_DOUBLE_EQ(c.next(0.0), 1.25e-4);
}

TEST(StepControl, DtMaxCapsAndOffIsOff) {
  StepControl c({.tolerance = 1.0, .first_dt = 1e-3, .dt_max = 1.5e-3});
  c.after_step(1e-3, 0.0);
  EXPECT_DOUBLE_EQ(c.next(0.0), 1.5e-3);
  StepControl off({.tolerance = 0.0, .first_dt = 1e-3});
  EXPECT_FALSE(off.enabled());
  off.after_step(1e-3, 0.0);
  EXPECT_EQ(off.proposal(), 1e-3);
}

// Steps land on the multiples of the adaptation interval, so adaptations come at the same
// instants whatever the steps; the steps up to one are equal, so none is a sliver.
TEST(StepControl, StepsLandOnTheInstantsInEqualSteps) {
  StepControl c({.tolerance = 1.0, .first_dt = 0.003, .instants = 0.004});
  EXPECT_DOUBLE_EQ(c.next(0.0), 0.002);     // two equal steps to 0.004, not 0.003 and 0.001
  EXPECT_DOUBLE_EQ(c.next(0.003), 0.001);   // the rest of the way
  EXPECT_NEAR(c.next(0.0039), 1e-4, 1e-15);  // a sliver only when the run put t there itself
  c.after_step(0.003, 0.0);                 // proposes 0.006
  EXPECT_DOUBLE_EQ(c.next(0.004), 0.004);   // 0.004 + 0.006 passes 0.008: lands on it
  EXPECT_DOUBLE_EQ(c.next(0.005), 0.003);   // lands on 0.008
  c.after_step(0.006, 0.0);                 // proposes 0.012
  EXPECT_DOUBLE_EQ(c.next(0.008), 0.012);   // three intervals, on to 0.020
  EXPECT_DOUBLE_EQ(c.next(0.007), 0.009);   // to 0.008, then on to 0.016
  StepControl d({.tolerance = 1.0, .first_dt = 0.0009, .instants = 0.004});
  EXPECT_DOUBLE_EQ(d.next(0.0), 0.0008);  // five equal steps, not four and a tenth of one
  // A time summed with round-off just below an instant counts as on it: the step runs to
  // 0.020, not to an instant 1e-16 away.
  EXPECT_NEAR(c.next(0.0079999999999999), 0.012, 1e-15);
}

// A cap that must hold (time.coupling = "auto" keeps its steps explicit): the proposal when
// shorter, else the cap, landed on the instants below it, never above it by land()'s slack.
TEST(StepControl, ACapHoldsAndStillLandsOnTheInstants) {
  StepControl c({.tolerance = 1.0, .first_dt = 0.003, .instants = 0.004});
  EXPECT_DOUBLE_EQ(c.next(0.0, 0.01), 0.002);    // the proposal, landed
  EXPECT_DOUBLE_EQ(c.next(0.0, 0.0015), 0.004 / 3);  // the cap, landed: three steps to 0.004
  c.after_step(0.003, 0.0);                      // proposes 0.006
  EXPECT_DOUBLE_EQ(c.next(0.004, 0.004), 0.004);
  // Three steps of this cap fall 8e-10 short of the instant 0.004: land()'s slack would take
  // three steps of 0.004 / 3, just above the cap; four steps of 0.001 stay below it.
  const double cap = 0.004 / 3.0 * (1.0 - 2e-7);
  EXPECT_DOUBLE_EQ(c.next(0.0, cap), 0.001);
}

TEST(StepControl, RestartTakesTheSameNextStep) {
  StepControl a({.tolerance = 0.01, .first_dt = 1e-3});
  a.after_step(1e-3, 0.002);
  a.reject(4e-3);
  a.after_step(2e-3, 1e-6);
  StepControl b({.tolerance = 0.01, .first_dt = 1e-3});
  b.restore(a.proposal(), a.ceiling());
  EXPECT_EQ(b.next(0.5), a.next(0.5));
  a.after_step(a.next(0.5), 1e-6);
  b.after_step(b.next(0.5), 1e-6);  // the ceiling came back too
  EXPECT_EQ(b.next(0.6), a.next(0.6));
}

// A step whose implicit solve failed: half of it next, then proposals below a ceiling of
// 0.7 times it that rises 5% a step, however small the error.
TEST(StepControl, ARejectedStepIsHalvedAndCeilsTheNextOnes) {
  StepControl c({.tolerance = 0.01, .first_dt = 1e-3});
  c.reject(0.1);
  EXPECT_DOUBLE_EQ(c.next(0.0), 0.05);
  EXPECT_DOUBLE_EQ(c.ceiling(), 0.07);
  c.after_step(0.05, 1e-9);  // would double
  EXPECT_DOUBLE_EQ(c.next(0.05), 0.07 * 1.05);
  c.after_step(0.0735, 1e-9);
  EXPECT_DOUBLE_EQ(c.next(0.1235), 0.07 * 1.05 * 1.05);
  StepControl capped({.tolerance = 0.01, .first_dt = 1e-3, .dt_max = 0.02});
  capped.reject(0.1);
  EXPECT_DOUBLE_EQ(capped.next(0.0), 0.02);  // dt_max still caps
}

}  // namespace
}  // namespace capsflow::app
