// capsflow run, end to end: every ready case parses and runs (shortened), its outputs read
// back with VTK's readers, and a restart from a checkpoint repeats the run to the last digit.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vtkCellData.h>
#include <vtkNew.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "app_support.hpp"
#include "post_channel.hpp"
#include "io/case_config.hpp"
#include "io/pvd_series.hpp"

namespace capsflow::app {
namespace {

using namespace testing;

std::vector<std::vector<std::string>> rows_of(const fs::path& csv) {
  std::vector<std::vector<std::string>> out;
  std::istringstream in(slurp(csv));
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    out.push_back(cells);
  }
  return out;
}

// The diagnostics of `base` run with --adapt on (and `on_sets`) and with --adapt off, each
// run asserted to succeed.
std::pair<std::vector<std::vector<std::string>>, std::vector<std::vector<std::string>>> adapt_on_and_off(
    const fs::path& dir, const std::string& base, const std::string& on_sets = "") {
  const auto on = capsflow(base + "--adapt on " + on_sets + " --out " + (dir / "on").string(), dir);
  EXPECT_EQ(on.status, 0) << on.err;
  const auto off = capsflow(base + "--adapt off --out " + (dir / "off").string(), dir);
  EXPECT_EQ(off.status, 0) << off.err;
  return {rows_of(dir / "on" / "diagnostics.csv"), rows_of(dir / "off" / "diagnostics.csv")};
}

// A case run for 4 steps with snapshots at 0 and 4.
std::string fmt_args(const std::string& name, const fs::path& dir) {
  return "run " + std::string(CAPSFLOW_CASES_DIR) + "/" + name + ".toml --quiet --set time.cfl=0 --set time.dt=0.005 " +
         "--set time.t_end=0.02 --set output.interval=4 --out " + (dir / "out").string();
}

// A solve forced to fail (one cycle, a tolerance no cycle reaches) is counted in
// mg_unconverged and warned about once; with fail_on_unconverged it stops the run (exit 3).
TEST(AppCases, UnconvergedSolvesAreCountedOrFail) {
  const std::string forced = " --set fluid.multigrid.max_cycles=1 --set fluid.multigrid.tolerance=1e-12";
  const fs::path dir = scratch("unconverged");
  const auto r = capsflow(fmt_args("cavity_2d", dir) + forced, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("warning: step 1, t = 0.005: "));
  EXPECT_THAT(r.err, ::testing::HasSubstr("multigrid solve(s) stopped at max_cycles = 1"));
  EXPECT_EQ(r.err.find("warning:"), r.err.rfind("warning:")) << "warned more than once: " << r.err;
  const auto table = rows_of(dir / "out" / "diagnostics.csv");
  ASSERT_EQ(table.size(), 5u);
  ASSERT_EQ(table[0][12], "mg_unconverged");
  for (std::size_t i = 1; i < table.size(); ++i) EXPECT_GE(std::stoi(table[i][12]), 1) << "row " << i;

  const fs::path dir2 = scratch("unconverged_fails");
  const auto f = capsflow(fmt_args("cavity_2d", dir2) + forced + " --set fluid.multigrid.fail_on_unconverged=true", dir2);
  EXPECT_EQ(f.status, 3) << f.err;
  EXPECT_THAT(f.err, ::testing::HasSubstr("step 1, t = 0.005:"));
  EXPECT_THAT(f.err, ::testing::HasSubstr("fluid.multigrid.fail_on_unconverged = true"));
  // The written case keeps the key.
  EXPECT_TRUE(io::parse_case(dir2 / "out" / "case.toml").fluid.multigrid.fail_on_unconverged);
}

TEST(AppCases, EveryCaseParses) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(CAPSFLOW_CASES_DIR)) {
    if (entry.path().extension() != ".toml") continue;
    EXPECT_NO_THROW((void)io::parse_case(entry.path())) << entry.path();
    ++count;
  }
  EXPECT_GE(count, 2);
}

TEST(AppCases, ShortRunsWriteEveryOutput) {
  for (const std::string name : {"cavity_2d", "duct_3d"}) {
    const fs::path dir = scratch(name);
    const auto r = capsflow(fmt_args(name, dir), dir);
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* f : {"case.toml", "diagnostics.csv", "series.pvd", "fluid_000000.vtu", "fluid_000004.vtu"})
      EXPECT_TRUE(fs::exists(dir / "out" / f)) << name << ": " << f;
    // The written case parses back to the one that ran.
    EXPECT_NO_THROW((void)io::parse_case(dir / "out" / "case.toml"));
    // diagnostics.csv: header + one row per step.
    const auto table = rows_of(dir / "out" / "diagnostics.csv");
    ASSERT_EQ(table.size(), 5u);
    EXPECT_THAT(table[0], ::testing::ElementsAre("step", "t", "dt", "cells", "max_level", "D12", "D12_bbox", "area_rel",
                                                 "volume_rel", "vmax", "mg_cycles", "wall_s", "mg_unconverged",
                                                 "E_membrane", "E_kinetic", "P_nodes", "P_spread", "dissipation",
                                                 "P_boundary", "W_membrane", "W_dissipation", "W_boundary",
                                                 "W_adaptation", "energy_residual"));
    for (std::size_t i = 1; i < table.size(); ++i) EXPECT_EQ(table[i][12], "0") << name << " row " << i;
    // The series lists both snapshots; the last .vtu has one cell per leaf.
    const auto series = io::PvdSeries::load(dir / "out" / "series.pvd");
    ASSERT_EQ(series.entries().size(), 2u);
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName((dir / "out" / "fluid_000004.vtu").c_str());
    reader->Update();
    EXPECT_EQ(static_cast<long>(reader->GetOutput()->GetNumberOfCells()), std::stol(table[4][3])) << name;
    EXPECT_NE(reader->GetOutput()->GetCellData()->GetArray("velocity"), nullptr);
    EXPECT_NE(reader->GetOutput()->GetCellData()->GetArray("pressure"), nullptr);
  }
}
// Restarts the run in dir/full from `checkpoint` in a copy of the folder (dir/part): every
// diagnostics row but the wall clock, and the final membrane if any, must be the full run's.
void expect_restart_repeats_run(const fs::path& dir, const std::string& base, const std::string& checkpoint,
                                const std::vector<std::vector<std::string>>& full) {
  fs::copy(dir / "full", dir / "part", fs::copy_options::recursive);
  const auto again =
      capsflow(base + "--out " + (dir / "part").string() + " --restart " + (dir / "part" / checkpoint).string(), dir);
  ASSERT_EQ(again.status, 0) << again.err;
  const auto resumed = rows_of(dir / "part" / "diagnostics.csv");
  ASSERT_EQ(resumed.size(), full.size());
  for (std::size_t i = 1; i < full.size(); ++i)
    for (std::size_t c = 0; c < full[i].size(); ++c) {
      if (full[0][c] != "wall_s") {
        ASSERT_EQ(resumed[i][c], full[i][c]) << "row " << i << " column " << full[0][c];
      }
    }
  EXPECT_EQ(slurp(dir / "part" / "membrane_final.csv"), slurp(dir / "full" / "membrane_final.csv"));
  EXPECT_EQ(slurp(dir / "part" / "capsules.csv"), slurp(dir / "full" / "capsules.csv"));  // both empty without capsules
}

// Runs `base` whole into dir/full (it must write `rows` diagnostics rows, the header
// included), then restarts it from `checkpoint` (expect_restart_repeats_run).
void expect_run_restarts_exactly(const fs::path& dir, const std::string& base, std::size_t rows,
                                 const std::string& checkpoint) {
  const auto r = capsflow(base + "--out " + (dir / "full").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto full = rows_of(dir / "full" / "diagnostics.csv");
  ASSERT_EQ(full.size(), rows);
  expect_restart_repeats_run(dir, base, checkpoint, full);
}


// Interrupted after a checkpoint and restarted, a run writes the same diagnostics, to the
// last digit (wall time aside), as the run that went straight through.
TEST(AppRestart, RestartRepeatsTheRunExactly) {
  const fs::path dir = scratch("restart");
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/cavity_2d.toml --quiet --set time.t_end=0.2 --set output.checkpoint=true "
                           "--set output.checkpoint_interval=10 --set adapt.interval=3 --set output.interval=5 ";
  ASSERT_EQ(capsflow(base + "--out " + (dir / "full").string(), dir).status, 0);
  const auto full = rows_of(dir / "full" / "diagnostics.csv");
  ASSERT_GT(full.size(), 20u);
  // The run "killed" after step 10: its directory as it was then is the full run's with
  // the checkpoint of step 10; a restart must rewrite the rest identically.
  expect_restart_repeats_run(dir, base, "checkpoint_000010.h5", full);
}

// A capsule carried by the flow into an embedded post stops the run when its membrane comes
// within its kernels' reach of the wall: exit 3, one line naming the capsule, the step, the
// time and the node's place; the output so far is kept.
TEST(AppCapsule, ACapsuleFlowsAroundAnEmbeddedPost) {
  // Its membrane comes within the kernels' reach of the post (near-wall weights) and wraps
  // around it without touching it.
  const fs::path dir = scratch("post");
  const fs::path file = write(dir, "post.toml", test_cases::post_channel(-1.25));
  const auto r = capsflow("run " + file.string() + " --quiet --set time.t_end=0.6 --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto rows = rows_of(dir / "out" / "diagnostics.csv");
  ASSERT_GT(rows.size(), 2u);
  ASSERT_EQ(rows[0][8], "volume_rel");
  EXPECT_LT(std::abs(std::stod(rows.back()[8])), 2e-3);
}

TEST(AppCapsule, ACapsulePulledIntoAThroatStopsWhenItTouchesTheWall) {
  const fs::path dir = scratch("throat");
  const fs::path file = write(dir, "throat.toml", test_cases::throat_channel(-1.1));
  const auto r = capsflow("run " + file.string() + " --quiet --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("capsule 0: node"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("touched an embedded wall"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("(t = "));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_TRUE(fs::exists(dir / "out" / "diagnostics.csv"));
}

// The same with an embedded wall (a cylinder in the cavity, Stokes): the geometry is rebuilt
// on the checkpoint's tree, and the snapshots carry the fluid fraction.
TEST(AppRestart, RestartWithAnEmbeddedWallRepeatsTheRunExactly) {
  const fs::path dir = scratch("restart_solid");
  const fs::path file = write(dir, "cavity_solid.toml",
                              slurp(fs::path(CAPSFLOW_CASES_DIR) / "cavity_2d.toml") +
                                  "\n[[solid]]\nshape = \"sphere\"\ncentre = [0.47, 0.55]\nradius = 0.2\n");
  const std::string base = "run " + file.string() +
                           " --quiet --set fluid.stokes=true --set fluid.Re=10 --set time.t_end=0.2 --set time.cfl=0 --set time.dt=0.008 "
                           "--set output.checkpoint=true --set output.checkpoint_interval=10 --set adapt.interval=3 "
                           "--set adapt.wall_level=7 --set output.interval=5 ";
  const auto r = capsflow(base + "--out " + (dir / "full").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto full = rows_of(dir / "full" / "diagnostics.csv");
  ASSERT_GT(full.size(), 20u);
  EXPECT_NE(slurp(dir / "full" / "fluid_000005.vtu").find("fluid_fraction"), std::string::npos);
  expect_restart_repeats_run(dir, base, "checkpoint_000010.h5", full);
}

}  // namespace
}  // namespace capsflow::app

namespace capsflow::app {
namespace {

using namespace testing;


// The quick seed case, a few steps: membrane snapshots and final positions are written, the
// membrane columns are finite, and a restart with a capsule repeats the run exactly. The
// adaptation may wait (max_interval 4, a 6-cell margin): it adapts after steps 4 and 8, so
// the restart from step 5 must carry the steps since the last adaptation and the positions
// then to adapt after step 8 again.
// Issue 17: in simple shear (cases/shear_quick.toml, dx = a/8, 642 nodes, Euler nodes) the
// cell-centred coupling gains volume steadily: +0.31% at strain 1, +0.77% at 2, a trend of
// +0.43% per unit strain (least squares over [0, 2]). The divergence-free face coupling (the
// default) moves the nodes with an exactly divergence-free velocity; what is left is the
// error of the P2 surface through them, which follows the shape and the node layout: at
// dx = a/16 with 2562 nodes it oscillates within +-0.052% over 10 strain units with the
// tank-treading period and ends at +0.014% (docs/numerics.md), no trend. Here, coarse and
// short, it is -0.045% at strain 2 and its least-squares trend -0.017% per strain (measured):
// the bounds are the fine run's envelope, doubled for the coarse mesh, and 20 times less
// trend than the cells.
// Under AddressSanitizer (the checked build) 4000 steps take over 5 minutes: the runs go to
// strain 0.5 there, which exercises the same code, and only the Release build asserts the
// trends (at 0.5 the divergence-free coupling is at -7.7e-5 against +9.3e-4 on cells).
#if defined(__SANITIZE_ADDRESS__)
constexpr double kShearStrain = 0.5;
#else
constexpr double kShearStrain = 2.0;
#endif

TEST(AppCapsule, DivergenceFreeCouplingKeepsTheVolumeInShear) {
  const fs::path dir = scratch("shear_volume");
  // volume_rel against strain (the shear rate is 1) at every diagnostics row.
  auto history = [&](const std::string& name, const std::string& extra) {
    const auto r = capsflow("run " + std::string(CAPSFLOW_CASES_DIR) +
                                "/shear_quick.toml --quiet --set time.t_end=" + fmt::format("{}", kShearStrain) +
                                " --set output.diagnostics_interval=50" +
                                extra + " --out " + (dir / name).string(),
                            dir);
    EXPECT_EQ(r.status, 0) << r.err;
    const auto table = rows_of(dir / name / "diagnostics.csv");
    EXPECT_EQ(table[0][8], "volume_rel");
    std::vector<std::pair<double, double>> h;
    for (std::size_t i = 1; i < table.size(); ++i) h.emplace_back(std::stod(table[i][1]), std::stod(table[i][8]));
    return h;
  };
  auto trend = [](const std::vector<std::pair<double, double>>& h) {  // least-squares slope
    double mx = 0, my = 0;
    for (const auto& [x, y] : h) mx += x, my += y;
    mx /= static_cast<double>(h.size());
    my /= static_cast<double>(h.size());
    double sxy = 0, sxx = 0;
    for (const auto& [x, y] : h) sxy += (x - mx) * (y - my), sxx += (x - mx) * (x - mx);
    return sxy / sxx;
  };
  const auto free = history("divergence_free", ""), cells = history("cells", " --set capsule[0].staggered=false");
  ASSERT_GE(free.size(), 10u);
  ASSERT_GE(cells.size(), 10u);
  const double free_trend = trend(free), cells_trend = trend(cells);
  double free_max = 0.0;
  for (const auto& [t, v] : free) free_max = std::max(free_max, std::abs(v));
  std::printf("volume_rel trend per unit strain: divergence-free %.3e, cells %.3e (ratio %.1f); at strain %g %.3e, %.3e\n",
              free_trend, cells_trend, cells_trend / std::abs(free_trend), kShearStrain, free.back().second,
              cells.back().second);
  EXPECT_LT(free_max, 2 * 5.2e-4);
  if (kShearStrain < 2.0) {
    EXPECT_LT(std::abs(free.back().second), cells.back().second / 8);
    return;
  }
  EXPECT_GT(cells_trend, 3e-3);  // today's drift, measured 4.3e-3
  EXPECT_LT(std::abs(free_trend), cells_trend / 20);
}

// Issue 17: with time.cfl > 0 and no time.dt, the solver chooses dt for a capsule case:
// half the coupling's measured stability limit min(0.53 sqrt(Ca Re dx^3), 0.42 Ca dx) (or
// less by the CFL). The quick relaxation, coarse (dx = 1/8, 642 nodes, Ca = 0.05), runs
// stably for 150 steps at Re = 0.01 (dt 2.6e-4, the inertial branch) and Re = 10 (1.3e-3,
// the viscous one); the largest dt stable for 150 steps in these two runs was bisected at
// 6.6e-4 - 6.9e-4 and 3.0e-3 - 3.1e-3 (docs/numerics.md): the chosen dt lies below both
// and within a factor 2.6 of them.
TEST(AppCapsule, SolverChosenDtIsStableAtLowAndHighRe) {
  const fs::path dir = scratch("chosen_dt");
  std::string text = slurp(fs::path(CAPSFLOW_CASES_DIR) / "relaxation_quick.toml");
  const auto at = text.find("dt = 0.001");
  ASSERT_NE(at, std::string::npos);
  text.erase(at, text.find('\n', at) - at);  // no time.dt
  const fs::path file = write(dir, "no_dt.toml", text);
  for (const double re : {0.01, 10.0}) {
    const double ca = 0.05, dx = 0.125;
    const double limit = std::min(0.53 * std::sqrt(ca * re * dx * dx * dx), 0.42 * ca * dx);
    const double t_end = 150 * 0.5 * limit;
    const std::string out = (dir / fmt::format("re{}", re)).string();
    const auto r = capsflow(fmt::format("run {} --quiet --set time.cfl=0.5 --set fluid.Re={} --set adapt.max_level=4 "
                                        "--set capsule[0].nodes=642 --set time.t_end={} --set output.vtu=false "
                                        "--set output.diagnostics_interval=1 --out {}",
                                        file.string(), re, t_end, out),
                            dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto table = rows_of(fs::path(out) / "diagnostics.csv");
    ASSERT_EQ(table[0][2], "dt");
    double largest = 0.0;
    for (std::size_t i = 1; i + 1 < table.size(); ++i) largest = std::max(largest, std::stod(table[i][2]));
    std::printf("Re = %g: %zu steps, largest dt %.3e (limit %.3e), volume_rel %s\n", re, table.size() - 1, largest,
                limit, table.back()[8].c_str());
    EXPECT_NEAR(largest, 0.5 * limit, 1e-9 * limit);
    EXPECT_GE(table.size() - 1, 149U);
    EXPECT_LT(std::abs(std::stod(table.back()[8])), 1e-2);
  }
}

TEST(AppCapsule, RelaxationWritesMembraneOutputAndRestartsExactly) {
  const fs::path dir = scratch("capsule");
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set time.dt=0.004 --set capsule[0].nodes=642 "
                           "--set time.t_end=0.04 --set output.interval=5 --set output.diagnostics_interval=1 "
                           "--set output.checkpoint=true --set output.checkpoint_interval=5 "
                           "--set adapt.interval=1 --set adapt.max_interval=4 --set adapt.membrane_band=8 ";
  const auto r = capsflow(base + "--out " + (dir / "full").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* f : {"membrane_000000.vtu", "membrane_000010.vtu", "membrane_final.csv", "checkpoint_000005.h5"})
    EXPECT_TRUE(fs::exists(dir / "full" / f)) << f;
  const auto full = rows_of(dir / "full" / "diagnostics.csv");
  ASSERT_EQ(full.size(), 11u);
  const double d12_first = std::stod(full[1][5]), d12_last = std::stod(full[10][5]);
  EXPECT_GT(d12_first, 0.4);  // the seed ellipsoid starts at 0.4776
  EXPECT_LT(d12_last, d12_first);
  EXPECT_LT(std::abs(std::stod(full[10][8])), 0.02) << "volume_rel";
  const auto nodes = rows_of(dir / "full" / "membrane_final.csv");
  EXPECT_EQ(nodes.size(), 643u);  // header + 642 nodes
  // Restart from step 5 in a copy of the directory: rows 6..10 are rewritten identically.
  expect_restart_repeats_run(dir, base, "checkpoint_000005.h5", full);
}

// Issue 31: a fixed dt above the explicit coupling's measured stability limit is named
// before the first step, with the limit and the keys, as one line on stderr; at a restart
// too; a dt below it says nothing.
TEST(AppCapsule, TimeStepAboveTheStabilityLimitIsNamedBeforeTheFirstStep) {
  const fs::path dir = scratch("above_limit");
  // dx = 1/8, Ca = 0.05, Re = 1: the limit is min(0.53 sqrt(Ca Re dx^3), 0.42 Ca dx) = 2.62e-3.
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set capsule[0].nodes=642 "
                           "--set time.t_end=0.02 --set output.vtu=false --set output.checkpoint=true "
                           "--set output.checkpoint_interval=2 ";
  const auto above = capsflow(base + "--set time.dt=0.005 --out " + (dir / "above").string(), dir);
  ASSERT_EQ(above.status, 0) << above.err;
  EXPECT_EQ(lines(above.err), 1) << above.err;
  EXPECT_THAT(above.err, ::testing::StartsWith("warning: time.dt = 0.005 is 1.9 times the explicit coupling's stability "
                                               "limit measured for this grid and membrane, 0.00262"));
  EXPECT_THAT(above.err, ::testing::HasSubstr("lower time.dt or set time.cfl > 0"));
  const auto restart = capsflow(base + "--set time.dt=0.005 --out " + (dir / "above").string() + " --restart " +
                                    (dir / "above" / "checkpoint_000002.h5").string(),
                                dir);
  ASSERT_EQ(restart.status, 0) << restart.err;
  EXPECT_THAT(restart.err, ::testing::StartsWith("warning: time.dt = 0.005 is 1.9 times")) << "at a restart too";
  const auto below = capsflow(base + "--set time.dt=0.002 --out " + (dir / "below").string(), dir);
  ASSERT_EQ(below.status, 0) << below.err;
  EXPECT_EQ(below.err, "");
  // With the solver's choice (time.cfl > 0) dt stays below the limit: nothing to say.
  const auto chosen = capsflow(base + "--set time.cfl=0.5 --out " + (dir / "cfl").string(), dir);
  ASSERT_EQ(chosen.status, 0) << chosen.err;
  EXPECT_EQ(chosen.err, "");
}

// A checkpoint at a step that is not a multiple of adapt.interval (here 4, interval 3):
// the full run adapts after steps 3, 6 and 9; the restart from step 4 must adapt after 6
// and 9 too (not 3 steps after the restart), or the membrane ends elsewhere.
TEST(AppCapsule, RestartBetweenAdaptationsRepeatsTheRunExactly) {
  const fs::path dir = scratch("capsule_interval");
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set time.dt=0.004 --set capsule[0].nodes=642 "
                           "--set time.t_end=0.04 --set output.vtu=false --set output.diagnostics_interval=1 "
                           "--set output.checkpoint=true --set output.checkpoint_interval=4 "
                           "--set adapt.interval=3 --set adapt.membrane_band=8 ";
  expect_run_restarts_exactly(dir, base, 11, "checkpoint_000004.h5");
}

// Issue 29: an inner fluid's properties come from the node positions at each step's start,
// which the checkpoint keeps: a restart between adaptations repeats the run to the last digit.
TEST(AppCapsule, InnerFluidRestartsExactly) {
  const fs::path dir = scratch("capsule_inner_fluid");
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set capsule[0].nodes=642 "
                           "--set capsule[0].viscosity_ratio=5 --set capsule[0].density_ratio=2 "
                           "--set time.t_end=0.02 --set output.vtu=false --set output.diagnostics_interval=1 "
                           "--set output.checkpoint=true --set output.checkpoint_interval=7 ";
  expect_run_restarts_exactly(dir, base, 21, "checkpoint_000007.h5");
}

// The seed case with an inner fluid 100 times as viscous, at its dt = 1e-3 (explicit coupling,
// backward Euler): the transpose stress is explicit, and without the band's stabilisation
// (NavierStokes::stabilise_band, then BDF2's only) max |u| grew from 2.8 to 130 between
// t = 0.012 and 0.018 and the membrane folded (exit 3); at lambda = 5 it rose from 5.3 to
// 13.9 and fell back by t = 0.035. Stabilised: 3.5 at the first step, then a smooth 1.9-2.8.
TEST(AppCapsule, ViscousInnerFluidIsStableAtTheSeedStep) {
  const fs::path dir = scratch("capsule_viscous_inside");
  const auto r = capsflow("run " + std::string(CAPSFLOW_CASES_DIR) +
                              "/relaxation_stokes.toml --quiet --set capsule[0].viscosity_ratio=100 "
                              "--set time.t_end=0.025 --set output.vtu=false --set output.checkpoint=false "
                              "--set output.diagnostics_interval=1 --out " + (dir / "out").string(),
                          dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto table = rows_of(dir / "out" / "diagnostics.csv");
  ASSERT_EQ(table[0][9], "vmax");
  ASSERT_EQ(table.size(), 26u);
  double largest_after_start = 0.0;
  for (std::size_t i = 2; i < table.size(); ++i) largest_after_start = std::max(largest_after_start, std::stod(table[i][9]));
  std::printf("lambda = 100, seed case to t = 0.025: max |u| after the first step %.3f\n", largest_after_start);
  EXPECT_LT(largest_after_start, 3.5);
}

// Issue 17: the second-order scheme (midpoint nodes, Crank-Nicolson, carried faces) starts
// each step from the last projected faces; the checkpoint keeps them (face_velocity), so a
// restart repeats the run to the last digit: from step 4 (faces current) and from step 3
// (just adapted: the faces carried through the adaptation).
TEST(AppCapsule, SecondOrderSchemeRestartsExactly) {
  for (const int at : {3, 4}) {
    const fs::path dir = scratch(fmt::format("capsule_second_order_{}", at));
    const std::string base =
        "run " + std::string(CAPSFLOW_CASES_DIR) +
        "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set time.dt=0.004 --set capsule[0].nodes=642 "
        "--set time.t_end=0.04 --set output.vtu=false --set output.diagnostics_interval=1 "
        "--set output.checkpoint=true --set adapt.interval=3 --set adapt.membrane_band=8 "
        "--set time.node_scheme=\"midpoint\" --set fluid.crank_nicolson=true --set fluid.carry_faces=true " +
        fmt::format("--set output.checkpoint_interval={} ", at);
    expect_run_restarts_exactly(dir, base, 11, fmt::format("checkpoint_{:06d}.h5", at));
  }
}

// The command's --adapt switch on the quick seed case (dx = 1/16, 642 nodes, 50 steps to
// t = 0.1): the adaptive run follows the uniform one in D12(t) while holding fewer cells.
// Both runs keep the membrane band at the max level and the walls at their own level; they
// differ only where the wavelet criterion (tolerance 1e-3 on velocities of order 1-5)
// coarsens, which allows relative velocity errors of a few 1e-4 there. D12 integrates the
// velocity over the run, so it may differ by a few 1e-4: the bound is 1e-3, against a
// change of D12 of more than 0.1 over the run (measured: 4.9e-4, and 26 % fewer cells).
TEST(AppCapsule, AdaptOnAndOffAgreeAndAdaptiveUsesFewerCells) {
  const fs::path dir = scratch("adapt_on_off");
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/relaxation_quick.toml --quiet --set adapt.wall_level=3 "
                           "--set time.dt=0.002 --set capsule[0].nodes=642 --set time.t_end=0.1 "
                           "--set output.interval=1000 --set output.diagnostics_interval=5 ";
  const auto [a, u] = adapt_on_and_off(dir, base);
  ASSERT_FALSE(::testing::Test::HasFailure());
  ASSERT_EQ(a.size(), u.size());
  ASSERT_EQ(a.size(), 11u);  // header + a row every 5 of the 50 steps
  ASSERT_EQ(a[0][3], "cells");
  ASSERT_EQ(a[0][5], "D12");
  double worst = 0.0, cells_on = 0.0, cells_off = 0.0;
  for (std::size_t i = 1; i < a.size(); ++i) {
    worst = std::max(worst, std::abs(std::stod(a[i][5]) - std::stod(u[i][5])));
    cells_on += std::stod(a[i][3]);
    cells_off += std::stod(u[i][3]);
  }
  std::printf("--adapt on vs off: max |dD12| %.2e (D12 %s vs %s), mean cells %.0f vs %.0f\n", worst, a.back()[5].c_str(),
              u.back()[5].c_str(), cells_on / 10, cells_off / 10);
  EXPECT_LT(std::stod(a.back()[5]), std::stod(a[1][5]) - 0.1);  // the capsule relaxed
  EXPECT_LT(worst, 1e-3);
  EXPECT_EQ(std::stod(u[1][3]), 4 * 32 * 32 * 32);  // uniform at max level 5 on the 4 x 1 x 1 brick
  EXPECT_LT(cells_on, 0.75 * cells_off);
}

}  // namespace
}  // namespace capsflow::app

namespace capsflow::app {
namespace {

using namespace testing;

// Issue 30: the step chosen by accuracy (time.tolerance, app/step_control.hpp) on the quick
// relaxation, coarse (dx = 1/8, 642 nodes, radius 0.6) to t = 0.03. The controller bounds the
// nodes' error per unit time, so the first-order error at t_end scales with the tolerance:
// the differences of D12 between tolerances halved in turn halve too.
TEST(AppStepControl, HalvingTheToleranceHalvesTheError) {
  const fs::path dir = scratch("step_control");
  std::vector<double> d12;
  std::vector<std::size_t> steps;
  for (const double tol : {0.1, 0.05, 0.025, 0.0125}) {
    const fs::path out = dir / fmt::format("tol{}", tol);
    const auto r = capsflow(std::string("run ") + CAPSFLOW_CASES_DIR +
                                "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set capsule[0].nodes=642 "
                                "--set capsule[0].radius=0.6 --set time.t_end=0.03 --set output.vtu=false "
                                "--set output.diagnostics_interval=1 --set time.tolerance=" +
                                fmt::format("{}", tol) + " --out " + out.string(),
                            dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto table = rows_of(out / "diagnostics.csv");
    ASSERT_EQ(table[0][2], "dt");
    ASSERT_EQ(table[0][5], "D12");
    EXPECT_NEAR(std::stod(table.back()[1]), 0.03, 1e-12);
    d12.push_back(std::stod(table.back()[5]));
    steps.push_back(table.size() - 1);
  }
  std::printf("D12(t = 0.03) at tolerances 0.1 / 0.05 / 0.025 / 0.0125: %.6f %.6f %.6f %.6f in %zu / %zu / %zu / %zu steps\n",
              d12[0], d12[1], d12[2], d12[3], steps[0], steps[1], steps[2], steps[3]);
  for (std::size_t k = 0; k + 2 < d12.size(); ++k) {
    const double ratio = (d12[k] - d12[k + 1]) / (d12[k + 1] - d12[k + 2]);
    std::printf("  difference ratio %.2f\n", ratio);
    EXPECT_GT(ratio, 1.6);
    EXPECT_LT(ratio, 2.5);
  }
  EXPECT_GT(steps[3], steps[0]);
}

// The coarse quick relaxation to t_end with the implicit coupling and BDF2, a row per step.
std::string implicit_bdf2_quick_relaxation(const std::string& t_end) {
  return std::string("run ") + CAPSFLOW_CASES_DIR +
         "/relaxation_quick.toml --set adapt.max_level=4 --set capsule[0].nodes=642 --set capsule[0].radius=0.6 "
         "--set time.t_end=" + t_end + " --set output.vtu=false --set output.diagnostics_interval=1 "
         "--set 'time.coupling=\"implicit\"' --set 'time.node_scheme=\"bdf2\"' ";
}

// A step the implicit solve cannot take (one product allowed) is taken again at half the
// length, and the ceiling after it keeps such failures rare; a restart from a checkpoint
// after one (step 20) takes the same steps, its later failures included (the ceiling is in
// the checkpoint). With a fixed dt the same failure stops the run (status 3) naming the
// keys. Measured to t = 0.1: 6 steps taken again in 68, at steps 1, 19, 21, 25, 39 and 66
// (65 in 72 without the ceiling).
TEST(AppStepControl, AStepWhoseImplicitSolveFailsIsTakenAgainShorter) {
  const fs::path dir = scratch("step_rejected");
  const std::string base = implicit_bdf2_quick_relaxation("0.1") + "--set time.implicit_max_iterations=1 ";
  const std::string controlled =
      base + "--set time.tolerance=0.1 --set output.checkpoint=true --set output.checkpoint_interval=20 ";
  const auto r = capsflow(controlled + "--out " + (dir / "full").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("was too long (the implicit coupling's solve stopped at "));
  const auto table = rows_of(dir / "full" / "diagnostics.csv");
  EXPECT_NEAR(std::stod(table.back()[1]), 0.1, 1e-12);
  std::size_t retaken = 0;
  for (std::size_t p = r.err.find("; taken again at "); p != std::string::npos; p = r.err.find("; taken again at ", p + 1))
    ++retaken;
  EXPECT_GE(retaken, 2u);
  EXPECT_LE(retaken * 5, table.size() - 1) << retaken << " of " << table.size() - 1;
  expect_restart_repeats_run(dir, controlled, "checkpoint_000020.h5", table);
  const auto fixed = capsflow(base + "--quiet --set time.dt=0.01 --out " + (dir / "fixed").string(), dir);
  EXPECT_EQ(fixed.status, 3);
  EXPECT_THAT(fixed.err, ::testing::HasSubstr("raise time.implicit_max_iterations or lower time.dt"));
  EXPECT_THAT(fixed.err, ::testing::HasSubstr("dt = 0.01 is long"));
}

// A step too long for the implicit step's linearisation or for BDF2's prediction of the
// positions folds an element. The coarse quick relaxation with a first step of 4 (1500
// times the explicit limit): that step would end with element 4 folded (the check before
// the nodes move), the next step's prediction X + dt V_last at dt = 2 folds it too, and at
// t = 4 the prediction reaches the side's kernel reach; each is taken again at half the
// length, and the run ends at t = 8 (measured: 3 steps taken again in 13). With a fixed dt
// the same folds stop the run (status 3) naming the keys.
TEST(AppStepControl, AStepThatWouldFoldTheMembraneIsTakenAgainShorter) {
  const fs::path dir = scratch("step_folds");
  const std::string base = implicit_bdf2_quick_relaxation("8");
  const auto r = capsflow(base + "--set time.dt=4 --set time.tolerance=0.1 --out " + (dir / "controlled").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("step 1, t = 0: dt = 4 was too long (capsule 0: element 4 would end the step "
                                          "inverted or collapsed"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("step 2, t = 2: dt = 2 was too long (capsule 0: element 4 is inverted"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("3 step(s) taken again shorter"));
  const auto table = rows_of(dir / "controlled" / "diagnostics.csv");
  EXPECT_NEAR(std::stod(table.back()[1]), 8.0, 1e-12);
  EXPECT_DOUBLE_EQ(std::stod(table[1][2]), 2.0);  // the first step, halved once
  const auto end = capsflow(base + "--quiet --set time.dt=4 --out " + (dir / "fixed_end").string(), dir);
  EXPECT_EQ(end.status, 3);
  EXPECT_THAT(end.err, ::testing::HasSubstr("element 4 would end the step inverted or collapsed"));
  EXPECT_THAT(end.err, ::testing::HasSubstr("dt = 4 is long for the implicit step"));
  const auto predicted = capsflow(base + "--quiet --set time.dt=2 --out " + (dir / "fixed_prediction").string(), dir);
  EXPECT_EQ(predicted.status, 3);
  EXPECT_THAT(predicted.err, ::testing::HasSubstr("step 2 (t = 2): capsule 0: element 4 is inverted or collapsed"));
  EXPECT_THAT(predicted.err, ::testing::HasSubstr("dt = 2 is long for BDF2's prediction of the positions"));
}

// The capsule relaxing off the channel's axis (centre y = 0.15, the sphere's top would be at
// 0.75) reaches the brick's side y = 1 within its kernels' reach (y > 0.6875 at dx = 1/8).
// With Euler's nodes (forces at X: no prediction to catch it) a long implicit step that
// would end there is taken again shorter (step 14, t = 0.9: 0.266 went through at 0.133);
// once the membrane creeps to the reach by itself, the halved steps fall to the explicit
// coupling's limit (2.6e-3 here) and the run stops there, naming the cause, instead of
// halving towards the wall for ever (measured: t = 1.074 at step 19).
TEST(AppStepControl, AMembraneThatReachesTheSideByItselfStopsOnceTheStepIsShort) {
  const fs::path dir = scratch("step_reaches_side");
  const auto r = capsflow(std::string("run ") + CAPSFLOW_CASES_DIR +
                              "/relaxation_quick.toml --set adapt.max_level=4 --set capsule[0].nodes=642 "
                              "--set capsule[0].radius=0.6 --set capsule[0].centre=[0.0,0.15,0.0] --set time.t_end=2 "
                              "--set output.vtu=false --set output.diagnostics_interval=1 "
                              "--set 'time.coupling=\"implicit\"' --set 'time.node_scheme=\"euler\"' "
                              "--set time.dt=0.1 --set time.tolerance=0.1 --out " + (dir / "run").string(),
                          dir);
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("would end the step at"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("within the immersed-boundary kernel's reach of side y_hi); taken again at"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("Likely cause: the step was taken again down to dt = "));
  EXPECT_THAT(r.err, ::testing::HasSubstr("the membrane reaches it by itself"));
  const auto table = rows_of(dir / "run" / "diagnostics.csv");
  const double t_last = std::stod(table.back()[1]);
  EXPECT_GT(t_last, 1.0);  // past the first retry, which went through
  EXPECT_LT(t_last, 1.1);
  EXPECT_GT(std::stod(table.back()[2]), 1e-3);  // no step crept below the limit's order
}

// The coarse quick relaxation to t = 0.02 with the step control at tolerance 0.1, a row per
// step and a checkpoint every `interval` steps; `scheme`: the time.* keys of the coupling.
std::string controlled_quick_relaxation(const std::string& scheme, int interval) {
  return std::string("run ") + CAPSFLOW_CASES_DIR +
         "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set capsule[0].nodes=642 "
         "--set capsule[0].radius=0.6 --set time.t_end=0.02 --set output.vtu=false --set output.diagnostics_interval=1 " +
         scheme + " --set time.tolerance=0.1 --set output.checkpoint=true --set output.checkpoint_interval=" +
         std::to_string(interval) + " ";
}

// A run with the implicit coupling and the step control, interrupted after a checkpoint and
// restarted, repeats the uninterrupted run to the last digit (the controller's proposal is
// in the checkpoint; the nodes' last velocity gives the next estimate).
TEST(AppStepControl, RestartWithTheImplicitCouplingRepeatsTheRunExactly) {
  const fs::path dir = scratch("restart_step_control");
  const std::string base = controlled_quick_relaxation("--set 'time.coupling=\"implicit\"'", 8);
  expect_run_restarts_exactly(dir, base, 31, "checkpoint_000008.h5");
  const auto full = rows_of(dir / "full" / "diagnostics.csv");
  EXPECT_NE(full[3][2], full[8][2]);  // the controller changed the step
}

// The same with BDF2 and time.coupling = "auto": the capsule's last motion and the flow's
// u^(n-1) and history step come back from the checkpoint.
TEST(AppStepControl, RestartWithBdf2RepeatsTheRunExactly) {
  const fs::path dir = scratch("restart_bdf2");
  const std::string base =
      controlled_quick_relaxation("--set 'time.coupling=\"auto\"' --set 'time.node_scheme=\"bdf2\"'", 6);
  expect_run_restarts_exactly(dir, base, 12, "checkpoint_000006.h5");
}

// --adapt off with embedded walls: the walls were made on the coarse tree before the uniform
// refinement and not again (the run read past their arrays: a segmentation fault). The
// uniform run at level 4 must equal the adaptive one held at level 4 (min_level = max_level)
// in every diagnostic but the wall time.
TEST(AppRun, AdaptOffWithEmbeddedWallsEqualsTheAdaptiveRunOnTheSameUniformTree) {
  const fs::path dir = scratch("adapt_off_walls");
  const std::string base = "run " + std::string(CAPSFLOW_CASES_DIR) +
                           "/constriction_stokes.toml --quiet --set adapt.max_level=4 --set adapt.wall_level=4 "
                           "--set time.t_end=0.03 --set output.interval=1000 ";
  const auto [b, a] = adapt_on_and_off(dir, base, "--set adapt.min_level=4");
  ASSERT_FALSE(::testing::Test::HasFailure());
  ASSERT_EQ(a.size(), 4u);  // header + 3 steps
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a[0][3], "cells");
  ASSERT_EQ(a[0][9], "vmax");
  EXPECT_EQ(std::stod(a[1][3]), 4 * 16 * 16 * 16);
  EXPECT_GT(std::stod(a.back()[9]), 3.0);  // the throat's jet (five times the mean at steady state)
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t k = 0; k < a[i].size(); ++k) {
      if (a[0][k] == "wall_s") continue;
      EXPECT_EQ(a[i][k], b[i][k]) << "row " << i << " column " << a[0][k];
    }
}

}  // namespace
}  // namespace capsflow::app
