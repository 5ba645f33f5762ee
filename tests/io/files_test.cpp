// atomic_write and the CSV outputs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "io/atomic_write.hpp"
#include "io/diagnostics_csv.hpp"
#include "scratch_dir.hpp"

namespace capsflow::io {
namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::size_t entries(const std::filesystem::path& dir) {
  return static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(dir), {}));
}

TEST(io_atomic_write, FailingWriterLeavesNothingBehind) {
  const ScratchDir dir("atomic_fail");
  const auto target = dir.path() / "snapshot.vtu";
  EXPECT_THROW(atomic_write(target,
                            [](const std::filesystem::path& tmp) {
                              std::ofstream(tmp) << "half a file";
                              throw std::runtime_error("killed mid-write");
                            }),
               std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(target));
  EXPECT_EQ(entries(dir.path()), 0u) << "no temporary file left";
}

TEST(io_atomic_write, FailingWriterKeepsThePreviousFile) {
  const ScratchDir dir("atomic_keep");
  const auto target = dir.path() / "series.pvd";
  atomic_write_text(target, "complete\n");
  EXPECT_THROW(atomic_write(target,
                            [](const std::filesystem::path& tmp) {
                              std::ofstream(tmp) << "trunc";
                              throw std::runtime_error("disk full");
                            }),
               std::runtime_error);
  EXPECT_EQ(read_text(target), "complete\n");
  EXPECT_EQ(entries(dir.path()), 1u);
  atomic_write_text(target, "replaced\n");
  EXPECT_EQ(read_text(target), "replaced\n");
  EXPECT_EQ(entries(dir.path()), 1u);
  EXPECT_THROW(atomic_write(target, [](const std::filesystem::path&) {}), std::runtime_error)
      << "a writer that writes nothing is an error";
}

TEST(io_diagnostics_csv, HeaderRowsAndRoundTripDigits) {
  const ScratchDir dir("csv");
  const auto path = dir.path() / "diagnostics.csv";
  const std::vector<double> row1{1, 0.1 + 0.2, 1e-3 / 7, 123456789, -0.0, 5e-324};
  {
    DiagnosticsCsv csv(path, {"step", "t", "dt", "cells", "D12", "tiny"});
    csv.row(row1);
    // Flushed at once: the row is on disk before the object goes away.
    EXPECT_EQ(read_text(path).substr(0, 22), "step,t,dt,cells,D12,ti");
    EXPECT_THAT(read_text(path), ::testing::HasSubstr("\n1,0.30000000000000004,"));
    csv.row({2, 0.5, 0.25, 8, 1, 2});
    EXPECT_THROW(csv.row({1, 2}), std::invalid_argument);
  }
  std::istringstream lines(read_text(path));
  std::string header, first, second;
  std::getline(lines, header);
  std::getline(lines, first);
  std::getline(lines, second);
  EXPECT_EQ(header, "step,t,dt,cells,D12,tiny");
  EXPECT_EQ(second, "2,0.5,0.25,8,1,2");
  std::istringstream cells(first);
  std::string cell;
  for (const double expected : row1) {
    ASSERT_TRUE(std::getline(cells, cell, ','));
    EXPECT_EQ(std::strtod(cell.c_str(), nullptr), expected) << cell;
  }
  EXPECT_THROW(DiagnosticsCsv(dir.path() / "x.csv", {"a,b"}), std::invalid_argument);
}

TEST(io_diagnostics_csv, StandardColumnsAreDesignMdColumns) {
  const ScratchDir dir("csv_standard");
  { DiagnosticsCsv csv(dir.path() / "diagnostics.csv", standard_diagnostics_columns()); }
  EXPECT_EQ(read_text(dir.path() / "diagnostics.csv"),
            "step,t,dt,cells,max_level,D12,D12_bbox,area_rel,volume_rel,vmax,mg_cycles,wall_s\n");
}

TEST(io_diagnostics_csv, ResumeDropsRowsAfterTheCheckpoint) {
  const ScratchDir dir("csv_resume");
  const auto path = dir.path() / "diagnostics.csv";
  {
    DiagnosticsCsv csv(path, {"step", "t"});
    for (int s = 1; s <= 5; ++s) csv.row({double(s), 0.1 * s});
  }
  {
    DiagnosticsCsv csv = DiagnosticsCsv::resume(path, {"step", "t"}, 3);
    csv.row({4, 0.4});
  }
  EXPECT_EQ(read_text(path), "step,t\n1,0.1\n2,0.2\n3,0.30000000000000004\n4,0.4\n");
  EXPECT_THROW((void)DiagnosticsCsv::resume(path, {"step", "time"}, 3), std::runtime_error);
}

TEST(io_nodes_csv, MembraneFinal) {
  const ScratchDir dir("nodes");
  const std::vector<double> x{0.1, 0.2, 0.3, -1, 0, 1e-20};
  write_nodes_csv(dir.path() / "membrane_final.csv", x);
  EXPECT_EQ(read_text(dir.path() / "membrane_final.csv"), "id,x,y,z\n0,0.1,0.2,0.3\n1,-1,0,1e-20\n");
}

}  // namespace
}  // namespace capsflow::io
