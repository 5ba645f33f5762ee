#pragma once
// STL files written by hand for the tests: a box as 12 facets, ASCII or binary (each facet
// its own three corners, as STL stores them).
#include <array>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace capsflow::io::stl_files {

using Eigen::Vector3d;
using Facet = std::array<Vector3d, 3>;

// The box [lo, hi] as 12 facets, counter-clockwise seen from outside.
inline std::vector<Facet> box_facets(const Vector3d& lo, const Vector3d& hi) {
  auto corner = [&](int v) { return Vector3d((v & 1) ? hi[0] : lo[0], (v & 2) ? hi[1] : lo[1], (v & 4) ? hi[2] : lo[2]); };
  const int t[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::vector<Facet> out;
  for (const auto& f : t) out.push_back({corner(f[0]), corner(f[1]), corner(f[2])});
  return out;
}

inline Vector3d normal_of(const Facet& f) { return (f[1] - f[0]).cross(f[2] - f[0]).normalized(); }

inline void write_ascii(const std::string& path, const std::vector<Facet>& facets) {
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

inline void write_binary(const std::string& path, const std::vector<Facet>& facets) {
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

}  // namespace capsflow::io::stl_files
