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

namespace capsflow::io {
namespace {

using Eigen::Vector3d;
using Facet = std::array<Vector3d, 3>;

// The box [lo, hi] as 12 facets, counter-clockwise seen from outside.
std::vector<Facet> box_facets(const Vector3d& lo, const Vector3d& hi) {
  auto corner = [&](int v) { return Vector3d((v & 1) ? hi[0] : lo[0], (v & 2) ? hi[1] : lo[1], (v & 4) ? hi[2] : lo[2]); };
  const int t[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::vector<Facet> out;
  for (const auto& f : t) out.push_back({corner(f[0]), corner(f[1]), corner(f[2])});
  return out;
}

Vector3d normal_of(const Facet& f) { return (f[1] - f[0]).cross(f[2] - f[0]).normalized(); }

void write_ascii(const std::string& path, const std::vector<Facet>& facets) {
  std::ofstream out(path);
  out << "solid box\n";
  for (const Facet& f : facets) {
    const Vector3d n = normal_of(f);
    out << "  facet normal " << n[0] << ' ' << n[1] << ' ' << n[2] << "\n    outer loop\n";
    for (const Vector3d& v : f) out << "      vertex " << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
    out << "    endloop\n  endfacet\n";
  }
  out << "endsolid box\n";
}

void write_binary(const std::string& path, const std::vector<Facet>& facets) {
  std::ofstream out(path, std::ios::binary);
  const std::string header(80, ' ');
  out.write(header.data(), 80);
  const auto count = static_cast<std::uint32_t>(facets.size());
  out.write(reinterpret_cast<const char*>(&count), 4);
  for (const Facet& f : facets) {
    std::array<float, 12> values{};
    const Vector3d n = normal_of(f);
    for (int d = 0; d < 3; ++d) values[static_cast<std::size_t>(d)] = static_cast<float>(n[d]);
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) values[static_cast<std::size_t>(3 + 3 * k + d)] = static_cast<float>(f[static_cast<std::size_t>(k)][d]);
    out.write(reinterpret_cast<const char*>(values.data()), sizeof(float) * 12);
    const std::uint16_t attributes = 0;
    out.write(reinterpret_cast<const char*>(&attributes), 2);
  }
}

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
