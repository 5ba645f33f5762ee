// The output folder (issue 15): series.pvd names its files so ParaView finds them, a restart
// may start a new folder, another run's folder is not overwritten without --force, and an
// unusable --out is refused before any work.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <vtkCell.h>
#include <vtkNew.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkXMLUnstructuredGridReader.h>

#include "app_support.hpp"

namespace capsflow::app {
namespace {

using namespace testing;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

// The 2D cavity for 4 steps, snapshots at steps 0 and 4.
std::string cavity(const std::string& extra) {
  return "run " + std::string(CAPSFLOW_CASES_DIR) +
         "/cavity_2d.toml --quiet --set time.cfl=0 --set time.dt=0.005 --set time.t_end=0.02 "
         "--set output.interval=4 " +
         extra;
}

// Every file series.pvd lists, resolved against the .pvd's folder as ParaView does, is a
// .vtu that VTK's reader opens; returns how many there were.
int check_series(const fs::path& pvd) {
  vtkNew<vtkXMLDataParser> parser;
  parser->SetFileName(pvd.c_str());
  EXPECT_EQ(parser->Parse(), 1) << pvd;
  vtkXMLDataElement* collection = parser->GetRootElement()->FindNestedElementWithName("Collection");
  if (collection == nullptr) return 0;
  int n = 0;
  for (int i = 0; i < collection->GetNumberOfNestedElements(); ++i) {
    const fs::path file = pvd.parent_path() / collection->GetNestedElement(i)->GetAttribute("file");
    EXPECT_TRUE(fs::exists(file)) << file;
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName(file.c_str());
    reader->Update();
    EXPECT_GT(reader->GetOutput()->GetNumberOfPoints(), 0) << file;
    ++n;
  }
  return n;
}

// A relative --out from another working directory: the .pvd still names files that exist
// next to it (it used to name them relative to the working directory).
TEST(AppOutput, SeriesNamesFilesRelativeToThePvd) {
  const fs::path dir = scratch("series_relative");
  fs::create_directories(dir / "work");
  const std::string cd = "cd " + (dir / "work").string() + " && ";
  const std::string cmd = cd + "OMP_NUM_THREADS=1 " + CAPSFLOW_BINARY + " " + cavity("--out runs/a") +
                          " 2> " + (dir / "err.txt").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir / "err.txt");
  EXPECT_EQ(check_series(dir / "work" / "runs" / "a" / "series.pvd"), 2);

  // The same with a capsule: fluid and membrane pieces.
  const std::string capsule = cd + "OMP_NUM_THREADS=1 " + CAPSFLOW_BINARY + " run " + CAPSFLOW_CASES_DIR +
                              "/relaxation_quick.toml --quiet --set adapt.max_level=4 --set time.dt=0.004 "
                              "--set capsule[0].nodes=642 --set time.t_end=0.004 --out runs/b 2> " +
                              (dir / "err.txt").string();
  ASSERT_EQ(std::system(capsule.c_str()), 0) << slurp(dir / "err.txt");
  EXPECT_EQ(check_series(dir / "work" / "runs" / "b" / "series.pvd"), 4);
}

// A restart into a new (nested) folder starts its own diagnostics.csv and series.pvd.
TEST(AppOutput, RestartIntoANewFolder) {
  const fs::path dir = scratch("restart_new");
  const std::string base = cavity("--set output.checkpoint=true --set output.checkpoint_interval=2 ");
  ASSERT_EQ(capsflow(base + "--out " + (dir / "old").string(), dir).status, 0);
  const auto r =
      capsflow(base + "--set output.diagnostics_interval=1 --out " + (dir / "fresh" / "r").string() +
                   " --restart " + (dir / "old" / "checkpoint_000002.h5").string(),
               dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string csv = slurp(dir / "fresh" / "r" / "diagnostics.csv");
  EXPECT_THAT(csv, StartsWith("step,t,dt,"));
  EXPECT_EQ(lines(csv), 3) << csv;                                 // the header, steps 3 and 4
  EXPECT_EQ(check_series(dir / "fresh" / "r" / "series.pvd"), 1);  // step 4
  // Over another run only with --force, and then its diagnostics are not continued.
  ASSERT_EQ(capsflow(base + "--out " + (dir / "other").string(), dir).status, 0);
  const std::string restart = " --restart " + (dir / "old" / "checkpoint_000002.h5").string();
  EXPECT_EQ(capsflow(base + "--out " + (dir / "other").string() + restart, dir).status, 2);
  EXPECT_EQ(capsflow(base + "--set output.diagnostics_interval=1 --force --out " + (dir / "other").string() +
                         restart,
                     dir)
                .status,
            0);
  EXPECT_EQ(lines(slurp(dir / "other" / "diagnostics.csv")), 3);  // the header, steps 3 and 4
  // An empty existing folder works too.
  fs::create_directories(dir / "empty");
  EXPECT_EQ(capsflow(base + "--out " + (dir / "empty").string() + " --restart " +
                         (dir / "old" / "checkpoint_000002.h5").string(),
                     dir)
                .status,
            0);
}

// Another run's folder is refused (status 2, naming it) unless --force; the old run is intact.
TEST(AppOutput, AnotherRunsFolderNeedsForce) {
  const fs::path dir = scratch("force");
  const std::string out = (dir / "out").string();
  ASSERT_EQ(capsflow(cavity("--out " + out), dir).status, 0);
  const std::string before = slurp(dir / "out" / "diagnostics.csv");
  const auto r = capsflow(cavity("--set time.t_end=0.01 --out " + out), dir);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr(out));
  EXPECT_THAT(r.err, HasSubstr("--force"));
  EXPECT_EQ(lines(r.err), 1) << r.err;
  EXPECT_EQ(slurp(dir / "out" / "diagnostics.csv"), before);
  const auto forced = capsflow(cavity("--set time.t_end=0.01 --force --out " + out), dir);
  EXPECT_EQ(forced.status, 0) << forced.err;
  EXPECT_NE(slurp(dir / "out" / "diagnostics.csv"), before);
  // A folder with only a checkpoint in it also holds a run.
  fs::create_directories(dir / "ck");
  write(dir / "ck", "checkpoint_000010.h5", "x");
  EXPECT_EQ(capsflow(cavity("--out " + (dir / "ck").string()), dir).status, 2);
}

// An --out that cannot hold files is refused up front with status 2 and one line.
TEST(AppOutput, UnusableOutIsRefusedBeforeWork) {
  const fs::path dir = scratch("unusable");
  write(dir, "plain.txt", "not a folder");
  for (const fs::path& out : {dir / "plain.txt", dir / "plain.txt" / "sub", fs::path("/proc/capsflow_x")}) {
    const auto r = capsflow(cavity("--out " + out.string()), dir);
    EXPECT_EQ(r.status, 2) << out << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr(out.string()));
    EXPECT_EQ(lines(r.err), 1) << r.err;
  }
  EXPECT_EQ(slurp(dir / "plain.txt"), "not a folder");
  // A checkpoint refused after the folder was checked leaves no empty folder behind.
  write(dir, "broken.h5", "not HDF5");
  EXPECT_EQ(
      capsflow(cavity("--out " + (dir / "new").string() + " --restart " + (dir / "broken.h5").string()), dir)
          .status,
      2);
  EXPECT_FALSE(fs::exists(dir / "new"));
  if (::geteuid() != 0) {  // root writes anywhere
    fs::create_directories(dir / "locked");
    fs::permissions(dir / "locked", fs::perms::owner_read | fs::perms::owner_exec);
    EXPECT_EQ(capsflow(cavity("--out " + (dir / "locked" / "o").string()), dir).status, 2);
  }
}

}  // namespace
}  // namespace capsflow::app

namespace capsflow::app {
namespace {

// The embedded walls as a surface ParaView reads (walls.vtu): the constricted channel's slab
// inside the brick, two faces of 2 x 2 less the hole (pi 0.5^2 each) and the hole's side
// (2 pi 0.5 x 1), 9.57 in all, to the cut cells' second order at dx = 1/16.
TEST(AppOutput, TheEmbeddedWallsAreASurfaceParaViewReads) {
  const fs::path dir = scratch("walls_surface");
  const auto r = capsflow("run " + std::string(CAPSFLOW_CASES_DIR) +
                              "/constriction_stokes.toml --quiet --set time.t_end=0.01 --out " + (dir / "out").string(),
                          dir);
  ASSERT_EQ(r.status, 0) << r.err;
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName((dir / "out" / "walls.vtu").c_str());
  reader->Update();
  vtkUnstructuredGrid* grid = reader->GetOutput();
  ASSERT_GT(grid->GetNumberOfCells(), 1000);
  double area = 0.0;
  for (vtkIdType k = 0; k < grid->GetNumberOfCells(); ++k) {
    double p[3][3];
    for (int v = 0; v < 3; ++v) grid->GetPoint(grid->GetCell(k)->GetPointId(v), p[v]);
    const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    area += 0.5 * std::sqrt(std::pow(u[1] * w[2] - u[2] * w[1], 2) + std::pow(u[2] * w[0] - u[0] * w[2], 2) +
                            std::pow(u[0] * w[1] - u[1] * w[0], 2));
  }
  const double exact = 2.0 * (4.0 - M_PI * 0.25) + M_PI;
  std::printf("walls.vtu: %lld triangles, area %.5f (exact %.5f)\n", static_cast<long long>(grid->GetNumberOfCells()), area, exact);
  EXPECT_NEAR(area, exact, 0.01 * exact);
}

}  // namespace
}  // namespace capsflow::app
