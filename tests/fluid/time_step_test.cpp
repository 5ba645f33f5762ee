// fluid::TimeStep (the named stages of a step): every attached body runs each stage before
// the next one starts, in the order of attachment, with the flow step between spreading and
// interpolation; motion gets the flow step's own statistics; a flow step that throws tells
// every body (flow_failed) and reaches the caller, and no later stage runs; an implicit body
// reruns the step from its start (NavierStokes::save_state).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "fluid/time_step.hpp"

namespace capsflow::fluid {
namespace {

struct Recorder final : StepBody {
  Recorder(std::string n, std::vector<std::string>& l) : name(std::move(n)), log(l) {}
  void forces() override { log.push_back(name + ".forces"); }
  void spreading() override { log.push_back(name + ".spreading"); }
  void flow_failed() override { log.push_back(name + ".flow_failed"); }
  void interpolation() override { log.push_back(name + ".interpolation"); }
  void motion(const StepStats& flow, double seconds) override {
    log.push_back(name + ".motion");
    seen = flow;
    flow_seconds = seconds;
  }
  std::string name;
  std::vector<std::string>& log;
  StepStats seen;
  double flow_seconds = -1.0;
};

struct Box {
  static FlowOptions<2> flow() {
    FlowOptions<2> o{.Re = 1.0, .stokes = true, .dt = 0.01};
    for (auto& s : o.boundaries) s.kind = SideKind::wall;
    return o;
  }
  Box() { (void)tree.refine_to([](const tree::Box<2>&) { return 3; }); }
  tree::Tree<2> tree{tree::TreeOptions<2>{.roots = {1, 1}, .root_size = 1.0, .max_level = 3}};
  NavierStokes<2> ns{tree, flow()};
};

// Two recording bodies attached to one step, a then b.
struct TwoBodies : ::testing::Test {
  TwoBodies() {
    step.attach(a);
    step.attach(b);
  }
  Box box;
  std::vector<std::string> log;
  Recorder a{"a", log}, b{"b", log};
  TimeStep<2> step{box.ns};
};

TEST_F(TwoBodies, EachStageRunsForEveryBodyInOrderAroundTheFlowStep) {
  // The flow step reads its face force between spreading and interpolation.
  box.ns.set_face_force([&](const tree::Tree<2>&, FaceField<2>&) { log.push_back("flow"); });
  const StepStats st = step.run();
  const std::vector<std::string> expected{"a.forces",        "b.forces",        "a.spreading", "b.spreading", "flow",
                                          "a.interpolation", "b.interpolation", "a.motion",    "b.motion"};
  EXPECT_EQ(log, expected);
  EXPECT_EQ(a.seen.t, st.t);
  EXPECT_EQ(a.seen.dt, st.dt);
  EXPECT_EQ(b.seen.cycles(), st.cycles());
  EXPECT_DOUBLE_EQ(st.t, 0.01);
  EXPECT_GE(a.flow_seconds, 0.0);
}

TEST_F(TwoBodies, AFailedFlowStepTellsEveryBodyAndStopsTheStep) {
  box.ns.set_face_force([](const tree::Tree<2>&, FaceField<2>&) { throw std::runtime_error("the flow failed"); });
  EXPECT_THROW((void)step.run(), std::runtime_error);
  const std::vector<std::string> expected{"a.forces", "b.forces", "a.spreading", "b.spreading", "a.flow_failed",
                                          "b.flow_failed"};
  EXPECT_EQ(log, expected);
}

TEST(TimeStep, WithoutBodiesItIsTheFlowStep) {
  Box stepped, plain;
  TimeStep<2> step(stepped.ns);
  const StepStats a = step.run(), b = plain.ns.step();
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(a.cycles(), b.cycles());
}

// An implicit body takes the flow step again from its start with other forces: the step's
// flow is then the last rerun's, to the last bit that of one plain step with that force, the
// time advances once, and the statistics count every flow step's cycles.
struct Rerunner final : StepBody {
  explicit Rerunner(double& a) : amplitude(a) {}
  void forces() override {}
  void spreading() override {}
  void interpolation() override {}
  void motion(const StepStats& flow, double) override { seen = flow; }
  bool implicit() const override { return true; }
  void correct(const std::function<StepStats()>& rerun) override {
    for (const double a : {2.0, 3.0}) {
      amplitude = a;
      rerun_cycles += rerun().cycles();
    }
  }
  double& amplitude;
  StepStats seen;
  int rerun_cycles = 0;
};

TEST(TimeStep, AnImplicitBodyRerunsTheStepFromItsStart) {
  double amplitude = 1.0;
  const auto force = [&amplitude](const tree::Tree<2>& t, FaceField<2>& f) {
    for_each_face<2>(t, [&](int d, Index, Index hi, double, const tree::Level<2>&) {
      f[d][hi] = d == 0 ? amplitude * t.center(hi)[1] : 0.0;  // a shear force along x
    });
  };
  Box stepped, plain;
  stepped.ns.set_face_force(force);
  plain.ns.set_face_force(force);
  // A first step each, so the rerun starts from a flow with a pressure and faces.
  (void)stepped.ns.step();
  (void)plain.ns.step();
  Rerunner body(amplitude);
  TimeStep<2> step(stepped.ns);
  step.attach(body);
  const StepStats st = step.run();
  amplitude = 3.0;
  const StepStats once = plain.ns.step();
  EXPECT_EQ(st.t, once.t);
  EXPECT_EQ(stepped.ns.time(), plain.ns.time());
  EXPECT_GT(body.rerun_cycles, 0);
  EXPECT_GT(st.cycles(), body.rerun_cycles);  // the first flow step's cycles, and the reruns'
  EXPECT_EQ(body.seen.cycles(), st.cycles());
  for (int d = 0; d < 2; ++d)
    for (const Index c : stepped.tree.leaves()) ASSERT_EQ(stepped.ns.u(d)[c], plain.ns.u(d)[c]) << "cell " << c;
  for (const Index c : stepped.tree.leaves()) ASSERT_EQ(stepped.ns.p()[c], plain.ns.p()[c]) << "cell " << c;
}

// The implicit coupling's products step at looser tolerances (set_tolerance_scale): the
// solves stop sooner, and scale 1 gives back the options' own step to the last bit.
TEST(NavierStokesToleranceScale, LoosensTheSolvesAndScaleOneRestoresThem) {
  const auto force = [](const tree::Tree<2>& t, FaceField<2>& f) {
    for_each_face<2>(t, [&](int d, Index, Index hi, double, const tree::Level<2>&) {
      f[d][hi] = d == 0 ? 100.0 * t.center(hi)[1] : 0.0;  // a shear force along x
    });
  };
  Box tight, loose, back;
  for (Box* b : {&tight, &loose, &back}) b->ns.set_face_force(force);
  loose.ns.set_tolerance_scale(100.0);
  EXPECT_DOUBLE_EQ(loose.ns.options().viscous.tolerance, 100.0 * tight.ns.options().viscous.tolerance);
  EXPECT_DOUBLE_EQ(loose.ns.options().projection.tolerance, 100.0 * tight.ns.options().projection.tolerance);
  const StepStats a = tight.ns.step(), b = loose.ns.step();
  EXPECT_LT(b.cycles(), a.cycles());
  back.ns.set_tolerance_scale(100.0);
  back.ns.set_tolerance_scale(1.0);
  (void)back.ns.step();
  for (int d = 0; d < 2; ++d)
    for (const Index c : tight.tree.leaves()) ASSERT_EQ(back.ns.u(d)[c], tight.ns.u(d)[c]) << "cell " << c;
  for (const double bad : {0.5, 0.0, std::nan("")}) EXPECT_THROW(back.ns.set_tolerance_scale(bad), std::invalid_argument);
}

TEST(NavierStokesState, RestoreOnAnotherTreeIsRefused) {
  Box a;
  const auto saved = a.ns.save_state();
  tree::Tree<2> other{tree::TreeOptions<2>{.roots = {1, 1}, .root_size = 1.0, .max_level = 3}};
  (void)other.refine_to([](const tree::Box<2>&) { return 2; });
  NavierStokes<2> ns(other, Box::flow());
  EXPECT_THROW(ns.restore_state(saved), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::fluid
