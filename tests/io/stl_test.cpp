// STL files as closed surfaces: a box written by hand as ASCII and as binary STL (each facet
// its own three corners, as STL stores them) reads back as 8 shared vertices and 12
// triangles whose solid is geometry::box; a missing file, a file that is not STL and an
// open surface are each one CaseError line naming the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/solid.hpp"
#include "io/errors.hpp"
#include "io/stl_read.hpp"
#include "scratch_dir.hpp"
#include "stl_files.hpp"

namespace capsflow::io {
namespace {

using Eigen::Vector3d;
using stl_files::Facet;
using stl_files::box_facets;
using stl_files::write_ascii;
using stl_files::write_binary;

TEST(Stl, AsciiAndBinaryBoxesReadAsTheBox) {
  ScratchDir dir("stl_box");
  // Corners exact in single precision (binary STL stores floats).
  const Vector3d lo(-1.0, -0.5, 0.25), hi(1.5, 0.5, 2.0);
  const std::string ascii = (dir.path() / "box_ascii.stl").string(), binary = (dir.path() / "box_binary.stl").string();
  write_ascii(ascii, box_facets(lo, hi));
  write_binary(binary, box_facets(lo, hi));
  const geometry::SolidPtr exact = geometry::box(lo, hi);
  for (const std::string& path : {ascii, binary}) {
    const geometry::TriangleMesh mesh = read_stl(path);
    EXPECT_EQ(mesh.vertices.cols(), 8) << path << ": coincident corners merged";
    EXPECT_EQ(mesh.triangles.size(), 12u) << path;
    const geometry::SolidPtr solid = read_stl_solid(path);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    for (int i = 0; i < 500; ++i) {
      const Vector3d x(u(rng), u(rng), u(rng));
      EXPECT_NEAR(solid->signed_distance(x), exact->signed_distance(x), 1e-12) << path << " at " << x.transpose();
    }
  }
}

TEST(Stl, BadFilesAreOneLineNamingTheFile) {
  ScratchDir dir("stl_bad");
  auto message = [](const std::string& path) {
    try {
      (void)read_stl_solid(path);
    } catch (const CaseError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string missing = (dir.path() / "missing.stl").string();
  EXPECT_THAT(message(missing), testing::AllOf(testing::HasSubstr(missing), testing::HasSubstr("no such STL file")));
  const std::string text = (dir.path() / "notes.stl").string();
  std::ofstream(text) << "these are not facets\n";
  EXPECT_THAT(message(text), testing::AllOf(testing::HasSubstr(text), testing::HasSubstr("not a readable STL file")));
  const std::string open = (dir.path() / "open.stl").string();
  std::vector<Facet> facets = box_facets({0, 0, 0}, {1, 1, 1});
  facets.pop_back();
  write_ascii(open, facets);
  EXPECT_THAT(message(open), testing::AllOf(testing::HasSubstr(open), testing::HasSubstr("not closed")));
  for (const std::string& m : {message(missing), message(text), message(open)}) EXPECT_EQ(m.find('\n'), std::string::npos);
}

}  // namespace
}  // namespace capsflow::io
