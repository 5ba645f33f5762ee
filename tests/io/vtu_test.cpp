// .vtu snapshots and series.pvd, read back with VTK's own readers.
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <vtkCellData.h>
#include <vtkCellTypes.h>
#include <vtkDataArray.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>

#include "io/pvd_series.hpp"
#include "io/vtu_surface.hpp"
#include "io/vtu_tree.hpp"
#include "scratch_dir.hpp"

namespace capsflow::io {
namespace {

vtkSmartPointer<vtkUnstructuredGrid> read_vtu(const std::filesystem::path& path) {
  auto reader = vtkSmartPointer<vtkXMLUnstructuredGridReader>::New();
  reader->SetFileName(path.c_str());
  reader->Update();
  EXPECT_EQ(reader->GetErrorCode(), 0u) << path;
  return reader->GetOutput();
}

// An adaptive tree: finest near a circle/sphere of radius 0.3 around (0.5, 0.5[, 0.5]).
template <int D>
tree::Tree<D> adaptive_tree(int max_level) {
  tree::TreeOptions<D> o;
  o.roots.fill(1);
  o.roots[0] = 2;
  o.max_level = max_level;
  tree::Tree<D> t(o);
  (void)t.refine_to([&](const tree::Box<D>& b) {
    double r2 = 0.0;
    for (int d = 0; d < D; ++d) {
      const double c = 0.5 * (b.lo[d] + b.hi[d]) - 0.5;
      r2 += c * c;
    }
    return std::abs(std::sqrt(r2) - 0.3) < 0.1 ? max_level : 2;
  });
  return t;
}

template <int D>
void check_tree_round_trip(int max_level, int expected_type) {
  tree::Tree<D> t = adaptive_tree<D>(max_level);
  const tree::FieldId p = t.add_field({.name = "p"});
  const tree::FieldId u = t.add_field({.name = "u"});
  const tree::FieldId v = t.add_field({.name = "v"});
  double pmin = 1e300, pmax = -1e300;
  for (const tree::Index c : t.leaves()) {
    const auto x = t.center(c);
    t.values(p)[c] = std::sin(3 * x[0]) + x[1];
    t.values(u)[c] = x[0];
    t.values(v)[c] = -x[1];
    pmin = std::min(pmin, t.values(p)[c]);
    pmax = std::max(pmax, t.values(p)[c]);
  }
  ASSERT_GT(t.depth(), 2) << "the tree must be adaptive";
  const ScratchDir dir("vtu_tree");
  const auto path = dir.path() / "fluid_000000.vtu";
  const std::vector<CellField> fields{{.name = "pressure", .components = {t.values(p)}},
                                      {.name = "velocity", .components = {t.values(u), t.values(v)}}};
  write_tree_vtu<D>(path, t, fields);

  const auto grid = read_vtu(path);
  ASSERT_EQ(grid->GetNumberOfCells(), t.num_leaves());
  EXPECT_EQ(grid->GetNumberOfPoints(), t.num_leaves() * (1 << D));
  auto types = vtkSmartPointer<vtkCellTypes>::New();
  grid->GetCellTypes(types);
  ASSERT_EQ(types->GetNumberOfTypes(), 1);
  EXPECT_EQ(types->GetCellType(0), expected_type);

  vtkDataArray* level = grid->GetCellData()->GetArray("level");
  ASSERT_NE(level, nullptr);
  for (vtkIdType i = 0; i < grid->GetNumberOfCells(); ++i)
    ASSERT_EQ(level->GetTuple1(i), t.level_of(t.leaves()[static_cast<std::size_t>(i)])) << i;
  vtkDataArray* pressure = grid->GetCellData()->GetArray("pressure");
  ASSERT_NE(pressure, nullptr);
  double range[2];
  pressure->GetRange(range);
  EXPECT_EQ(range[0], pmin);
  EXPECT_EQ(range[1], pmax);
  vtkDataArray* velocity = grid->GetCellData()->GetArray("velocity");
  ASSERT_NE(velocity, nullptr);
  EXPECT_EQ(velocity->GetNumberOfComponents(), 3);
  // Cell i's geometry: its bounds are the leaf's box.
  const tree::Index c = t.leaves().back();
  double bounds[6];
  grid->GetCell(grid->GetNumberOfCells() - 1)->GetBounds(bounds);
  for (int d = 0; d < D; ++d) {
    EXPECT_EQ(bounds[2 * d], t.box(c).lo[d]);
    EXPECT_EQ(bounds[2 * d + 1], t.box(c).hi[d]);
  }
  EXPECT_EQ(velocity->GetComponent(grid->GetNumberOfCells() - 1, 0), t.center(c)[0]);
}

TEST(io_vtu_tree, AdaptiveQuadtreeReadsBack) { check_tree_round_trip<2>(7, VTK_QUAD); }
TEST(io_vtu_tree, AdaptiveOctreeReadsBack) { check_tree_round_trip<3>(5, VTK_HEXAHEDRON); }

TEST(io_vtu_tree, RejectsFieldsOfTheWrongSize) {
  tree::Tree<2> t = adaptive_tree<2>(4);
  const std::vector<double> short_field(3, 0.0);
  const std::vector<CellField> fields{{.name = "x", .components = {short_field}}};
  const ScratchDir dir("vtu_bad");
  EXPECT_THROW(write_tree_vtu<2>(dir.path() / "x.vtu", t, fields), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "x.vtu"));
}

// An octahedron of P2 triangles: 6 vertices, 12 mid-edge nodes, 8 elements.
struct P2Octahedron {
  std::vector<double> x;
  std::vector<std::int32_t> elements;
  P2Octahedron() {
    const double v[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const auto& p : v) x.insert(x.end(), p, p + 3);
    const int faces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      if (auto it = mid.find(key); it != mid.end()) return it->second;
      const int id = static_cast<int>(x.size() / 3);
      for (int d = 0; d < 3; ++d) x.push_back(0.5 * (x[3 * a + d] + x[3 * b + d]));
      mid[key] = id;
      return id;
    };
    for (const auto& f : faces) {
      elements.insert(elements.end(), f, f + 3);
      elements.push_back(midpoint(f[0], f[1]));
      elements.push_back(midpoint(f[1], f[2]));
      elements.push_back(midpoint(f[2], f[0]));
    }
  }
};

TEST(io_vtu_surface, QuadraticTrianglesReadBack) {
  const P2Octahedron m;
  ASSERT_EQ(m.x.size(), 18u * 3);
  std::vector<double> force(m.x.size()), area(8, 0.5), tension(8 * 2, 1.0);
  for (std::size_t i = 0; i < force.size(); ++i) force[i] = -m.x[i];
  const ScratchDir dir("vtu_surface");
  const auto path = dir.path() / "membrane_000000.vtu";
  write_surface_vtu(path, {.positions = m.x,
                           .elements = m.elements,
                           .order = SurfaceOrder::quadratic,
                           .point_data = {{.name = "force", .values = force, .components = 3}},
                           .cell_data = {{.name = "area", .values = area},
                                         {.name = "tensions", .values = tension, .components = 2}}});
  const auto grid = read_vtu(path);
  EXPECT_EQ(grid->GetNumberOfPoints(), 18);
  ASSERT_EQ(grid->GetNumberOfCells(), 8);
  EXPECT_EQ(grid->GetCellType(0), VTK_QUADRATIC_TRIANGLE);
  EXPECT_EQ(grid->GetCell(3)->GetNumberOfPoints(), 6);
  EXPECT_EQ(grid->GetCell(3)->GetPointId(4), m.elements[3 * 6 + 4]);
  ASSERT_NE(grid->GetPointData()->GetArray("force"), nullptr);
  EXPECT_EQ(grid->GetPointData()->GetArray("force")->GetNumberOfComponents(), 3);
  EXPECT_EQ(grid->GetPointData()->GetArray("force")->GetComponent(7, 2), -m.x[7 * 3 + 2]);
  ASSERT_NE(grid->GetCellData()->GetArray("tensions"), nullptr);
  EXPECT_EQ(grid->GetCellData()->GetArray("tensions")->GetNumberOfComponents(), 2);
  EXPECT_EQ(grid->GetCellData()->GetArray("area")->GetTuple1(5), 0.5);
}

TEST(io_vtu_surface, LinearTrianglesAndBadInput) {
  const std::vector<double> x{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<std::int32_t> tri{0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
  const ScratchDir dir("vtu_surface_p1");
  write_surface_vtu(dir.path() / "t.vtu", {.positions = x, .elements = tri});
  const auto grid = read_vtu(dir.path() / "t.vtu");
  EXPECT_EQ(grid->GetNumberOfPoints(), 4);
  EXPECT_EQ(grid->GetNumberOfCells(), 4);
  EXPECT_EQ(grid->GetCellType(2), VTK_TRIANGLE);
  const std::vector<std::int32_t> out_of_range{0, 1, 4};
  EXPECT_THROW(write_surface_vtu(dir.path() / "u.vtu", {.positions = x, .elements = out_of_range}),
               std::invalid_argument);
  const std::vector<double> short_data(3);
  EXPECT_THROW(write_surface_vtu(dir.path() / "u.vtu",
                                 {.positions = x, .elements = tri, .point_data = {{.name = "s", .values = short_data}}}),
               std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "u.vtu"));
}

TEST(io_pvd_series, ListsEverySnapshot) {
  const ScratchDir dir("pvd");
  tree::Tree<2> t = adaptive_tree<2>(4);
  PvdSeries series(dir.path() / "series.pvd");
  const std::vector<double> times{0.0, 0.1, 0.30000000000000004};
  for (std::size_t k = 0; k < times.size(); ++k) {
    const std::string name = fmt::format("fluid_{:06}.vtu", k * 10);
    write_tree_vtu<2>(dir.path() / name, t, {});
    series.add(times[k], name);
    series.add(times[k], dir.path() / fmt::format("membrane_{:06}.vtu", k * 10), 1);  // absolute: made relative
  }
  // Parse the .pvd as XML, as ParaView does.
  auto parser = vtkSmartPointer<vtkXMLDataParser>::New();
  parser->SetFileName((dir.path() / "series.pvd").c_str());
  ASSERT_EQ(parser->Parse(), 1);
  vtkXMLDataElement* root = parser->GetRootElement();
  ASSERT_STREQ(root->GetAttribute("type"), "Collection");
  vtkXMLDataElement* collection = root->FindNestedElementWithName("Collection");
  ASSERT_NE(collection, nullptr);
  ASSERT_EQ(collection->GetNumberOfNestedElements(), 6);
  for (int i = 0; i < 6; ++i) {
    vtkXMLDataElement* e = collection->GetNestedElement(i);
    const std::size_t k = static_cast<std::size_t>(i / 2);
    EXPECT_EQ(std::stod(e->GetAttribute("timestep")), times[k]);
    EXPECT_STREQ(e->GetAttribute("file"),
                 fmt::format("{}_{:06}.vtu", i % 2 ? "membrane" : "fluid", k * 10).c_str());
    EXPECT_STREQ(e->GetAttribute("part"), i % 2 ? "1" : "0");
  }
  EXPECT_EQ(read_vtu(dir.path() / "fluid_000010.vtu")->GetNumberOfCells(), t.num_leaves());

  // A restart continues the series from the checkpoint's time.
  PvdSeries again = PvdSeries::load(dir.path() / "series.pvd");
  EXPECT_EQ(again.entries(), series.entries());
  again.truncate_after(0.1);
  EXPECT_EQ(PvdSeries::load(dir.path() / "series.pvd").entries().size(), 4u);
}

// Series written before issue 15 named files relative to the run's working directory
// ("out/case/fluid_000000.vtu"); loading one (a restart) names them relative to the .pvd's
// folder, where ParaView looks and where the snapshots are.
TEST(io_pvd_series, LoadNormalisesWorkingDirectoryPaths) {
  const ScratchDir dir("pvd_old");
  std::ofstream(dir.path() / "fluid_000000.vtu") << "x";
  std::ofstream(dir.path() / "membrane_000000.vtu") << "x";
  std::ofstream(dir.path() / "series.pvd")
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n"
         "    <DataSet timestep=\"0\" group=\"\" part=\"0\" file=\"out/relaxation_quick/fluid_000000.vtu\"/>\n"
         "    <DataSet timestep=\"0\" group=\"\" part=\"1\" file=\"membrane_000000.vtu\"/>\n"
         "  </Collection>\n</VTKFile>\n";
  PvdSeries series = PvdSeries::load(dir.path() / "series.pvd");
  ASSERT_EQ(series.entries().size(), 2u);
  EXPECT_EQ(series.entries()[0].file, "fluid_000000.vtu");
  EXPECT_EQ(series.entries()[1].file, "membrane_000000.vtu");
  series.truncate_after(1.0);  // a restart rewrites the file in the new style
  EXPECT_EQ(PvdSeries::load(dir.path() / "series.pvd").entries()[0].file, "fluid_000000.vtu");
}

}  // namespace
}  // namespace capsflow::io
