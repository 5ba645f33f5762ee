// [[solid]] tables: every shape reads back from the case.toml a run writes; an STL path is
// taken relative to the case file; the tables combine in order (union, subtract, intersect,
// the outside of a shape); each bad table is one CaseError line naming the key.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "case_error_of.hpp"
#include "io/case_config.hpp"
#include "io/case_solids.hpp"
#include "scratch_dir.hpp"
#include "stl_files.hpp"

namespace capsflow::io {
namespace {

using ::testing::HasSubstr;

constexpr std::string_view kBase = R"(dimension = 3
[domain]
roots = [4, 1, 1]
root_size = 1.0
periodic = [true, false, false]
[fluid.boundary]
y_lo = { type = "wall" }
y_hi = { type = "wall" }
z_lo = { type = "wall" }
z_hi = { type = "wall" }
)";

using testing::error_of;

double phi(const geometry::SolidPtr& s, double x, double y, double z) { return s->signed_distance({x, y, z}); }

TEST(CaseSolids, EveryShapeReadsBackFromTheWrittenCase) {
  const std::string text = std::string(kBase) + R"(
[[solid]]
shape = "box"
lo = [0.5, 0.0, 0.0]
hi = [1.0, 0.25, 1.0]
[[solid]]
shape = "sphere"
combine = "union"
centre = [2.0, 0.5, 0.5]
radius = 0.2
[[solid]]
shape = "cylinder"
combine = "subtract"
centre = [2.0, 0.5, 0.5]
radius = 0.1
axis = [0.0, 0.0, 1.0]
half_length = 0.3
rounded_ends = true
[[solid]]
shape = "tube"
combine = "union"
centre = [3.0, 0.5, 0.5]
far_radius = 0.45
throat_radius = 0.3
half_length = 0.4
[[solid]]
shape = "cylinder"
combine = "intersect"
fill = "outside"
centre = [0.2, 0.5, 0.5]
radius = 0.05
)";
  const CaseConfig c = parse_case_text(text, "case.toml");
  ASSERT_EQ(c.solids.size(), 5u);
  EXPECT_EQ(c.solids[2].combine, SolidCombine::subtract);
  EXPECT_EQ(c.solids[4].fill, SolidFill::outside);
  EXPECT_EQ(parse_case_text(to_toml(c), "again.toml"), c);
}

TEST(CaseSolids, TablesCombineInOrder) {
  // A box with a spherical hole, then a post kept out of it: the solid is box - ball + post.
  const CaseConfig c = parse_case_text(std::string(kBase) + R"(
[[solid]]
shape = "box"
lo = [0.0, 0.0, 0.0]
hi = [2.0, 1.0, 1.0]
[[solid]]
shape = "sphere"
combine = "subtract"
centre = [1.0, 0.5, 0.5]
radius = 0.3
[[solid]]
shape = "cylinder"
centre = [1.0, 0.5, 0.5]
axis = [0, 0, 1]
radius = 0.05
)",
                                       "case.toml");
  const geometry::SolidPtr s = make_solid(c, "case.toml");
  EXPECT_LT(phi(s, 0.5, 0.5, 0.5), 0.0) << "in the box";
  EXPECT_GT(phi(s, 1.2, 0.5, 0.5), 0.0) << "in the hole";
  EXPECT_LT(phi(s, 1.0, 0.5, 0.6), 0.0) << "on the post";
  EXPECT_GT(phi(s, 3.0, 0.5, 0.5), 0.0) << "past the box";
  // A tube of fluid: the outside of a cylinder along x is solid.
  const CaseConfig t = parse_case_text(std::string(kBase) + R"(
[[solid]]
shape = "cylinder"
fill = "outside"
centre = [0.0, 0.5, 0.5]
radius = 0.4
)",
                                       "case.toml");
  const geometry::SolidPtr tube = make_solid(t, "case.toml");
  EXPECT_NEAR(phi(tube, 1.7, 0.5, 0.5), 0.4, 1e-15);
  EXPECT_NEAR(phi(tube, 1.7, 0.95, 0.5), -0.05, 1e-15);
  EXPECT_EQ(make_solid(parse_case_text(std::string(kBase), "case.toml"), "case.toml"), nullptr);
}

TEST(CaseSolids, TwoDimensionalCasesSeeTheSectionZ0) {
  const CaseConfig c = parse_case_text(R"(dimension = 2
[domain]
roots = [2, 1]
[fluid.boundary]
x_lo = { type = "wall" }
x_hi = { type = "wall" }
y_lo = { type = "wall" }
y_hi = { type = "wall" }
[[solid]]
shape = "box"
lo = [0.5, 0.0]
hi = [1.0, 0.25]
[[solid]]
shape = "sphere"
centre = [1.5, 0.5]
radius = 0.2
)",
                                       "flat.toml");
  const geometry::SolidPtr s = make_solid(c, "flat.toml");
  EXPECT_NEAR(phi(s, 0.75, 0.5, 0.0), 0.25, 1e-12) << "above the rectangle";
  EXPECT_NEAR(phi(s, 0.75, 0.2, 0.0), -0.05, 1e-12) << "inside it, near its top";
  EXPECT_NEAR(phi(s, 1.5, 0.9, 0.0), 0.2, 1e-12) << "above the circle";
}

TEST(CaseSolids, StlPathsAreRelativeToTheCaseFile) {
  ScratchDir dir("case_solids_stl");
  std::filesystem::create_directories(dir.path() / "surfaces");
  stl_files::write_ascii((dir.path() / "surfaces" / "post.stl").string(),
                         stl_files::box_facets({0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}));
  const std::filesystem::path case_file = dir.path() / "case.toml";
  std::ofstream(case_file) << kBase << R"(
[[solid]]
shape = "stl"
file = "surfaces/post.stl"
scale = 0.5
translate = [1.0, 0.25, 0.25]
)";
  const CaseConfig c = parse_case(case_file);
  EXPECT_EQ(std::filesystem::path(c.solids[0].file), dir.path() / "surfaces" / "post.stl");
  const geometry::SolidPtr s = make_solid(c, case_file.string());
  // The unit box scaled by 0.5 and moved: [1, 1.5] x [0.25, 0.75]^2.
  EXPECT_NEAR(phi(s, 1.25, 0.5, 0.5), -0.25, 1e-12);
  EXPECT_NEAR(phi(s, 2.0, 0.5, 0.5), 0.5, 1e-12);
  // The case.toml a run writes elsewhere finds the same file.
  EXPECT_EQ(parse_case_text(to_toml(c), "/elsewhere/case.toml").solids[0].file, c.solids[0].file);
}

TEST(CaseSolids, BadTablesAreOneLineNamingTheKey) {
  auto with = [](std::string_view table) { return std::string(kBase) + "[[solid]]\n" + std::string(table); };
  EXPECT_THAT(error_of(with("radius = 1.0\n")), HasSubstr("solid[0].shape: missing"));
  EXPECT_THAT(error_of(with("shape = \"cone\"\n")), HasSubstr("solid[0].shape = \"cone\": expected one of"));
  EXPECT_THAT(error_of(with("shape = \"box\"\nlo = [0, 0, 0]\nhi = [1, 1, 1]\nradius = 0.3\n")),
              HasSubstr("solid[0].radius = 0.3: only used with shape = \"sphere\" or \"cylinder\" (this solid is \"box\")"));
  EXPECT_THAT(error_of(with("shape = \"sphere\"\ncentre = [1, 0.5, 0.5]\n")), HasSubstr("solid[0].radius: missing"));
  EXPECT_THAT(error_of(with("shape = \"box\"\nlo = [0, 0, 0]\nhi = [1, 0, 1]\n")),
              HasSubstr("solid[0].hi[1] = 0.0: must be > lo[1] = 0.0"));
  EXPECT_THAT(error_of(with("shape = \"sphere\"\ncentre = [1, 0.5, 0.5]\nradius = -1\ncombine = \"subtract\"\n")),
              HasSubstr("solid[0].combine = \"subtract\": the first solid has nothing to combine with"));
  EXPECT_THAT(error_of(with("shape = \"cylinder\"\ncentre = [1, 0.5, 0.5]\nradius = 0.1\naxis = [0, 0, 0]\n")),
              HasSubstr("solid[0].axis: must not be zero"));
  EXPECT_THAT(error_of(with("shape = \"cylinder\"\ncentre = [1, 0.5, 0.5]\nradius = 0.1\nrounded_ends = true\n")),
              HasSubstr("solid[0].rounded_ends = true: an infinite cylinder"));
  EXPECT_THAT(error_of(with("shape = \"tube\"\ncentre = [1, 0.5, 0.5]\nfar_radius = 0.4\nthroat_radius = 0.0\n"
                            "half_length = 1\n")),
              HasSubstr("solid[0].throat_radius = 0.0: must be > 0"));
  EXPECT_THAT(error_of(with("shape = \"stl\"\nfile = \"a.stl\"\nscale = 0\n")), HasSubstr("solid[0].scale = 0.0: must be > 0"));
  EXPECT_THAT(error_of(with("shape = \"sphere\"\ncentre = [1, 0.5, 0.5]\nradius = 0.1\nfill = \"around\"\n")),
              HasSubstr("solid[0].fill = \"around\": expected one of \"inside\", \"outside\""));
  EXPECT_THAT(error_of("dimension = 2\n[domain]\nroots = [1, 1]\n[fluid.boundary]\nx_lo = { type = \"wall\" }\n"
                       "x_hi = { type = \"wall\" }\ny_lo = { type = \"wall\" }\ny_hi = { type = \"wall\" }\n"
                       "[[solid]]\nshape = \"stl\"\nfile = \"a.stl\"\n"),
              HasSubstr("solid[0].shape = \"stl\": STL surfaces need dimension = 3"));
}

// Moving walls: a sphere turning about its centre, a cylinder turning about and sliding along
// its axis; the wall velocity at a point of the wall, written back; motions that are not
// along the wall refused naming the key.
// An inner fluid of another viscosity or density runs beside embedded walls; a ratio that is
// not positive is refused, naming the key.
TEST(CaseSolids, InnerFluidsBesideWalls) {
  const std::string base = std::string(kBase) +
                           "[[solid]]\nshape = \"sphere\"\ncentre = [3.5, 0.5, 0.5]\nradius = 0.2\n"
                           "[[capsule]]\nradius = 0.2\ncentre = [1.5, 0.5, 0.5]\n";
  EXPECT_NO_THROW((void)parse_case_text(base + "viscosity_ratio = 5\n", "case.toml"));
  EXPECT_NO_THROW((void)parse_case_text(base + "density_ratio = 2\nviscosity_ratio = 5\n", "case.toml"));
  EXPECT_THAT(error_of(base + "density_ratio = 0\n"), HasSubstr("capsule[0].density_ratio = 0.0"));
}

TEST(CaseSolids, WallsSlidingAlongThemselves) {
  const std::string text = std::string(kBase) + R"(
[[solid]]
shape = "sphere"
centre = [2.0, 0.5, 0.5]
radius = 0.2
angular_velocity = [0.0, 0.0, 3.0]
[[solid]]
shape = "cylinder"
centre = [0.0, 0.5, 0.5]
axis = [1.0, 0.0, 0.0]
radius = 0.45
fill = "outside"
angular_velocity = [-2.0, 0.0, 0.0]
axial_velocity = 0.5
)";
  const CaseConfig c = parse_case_text(text, "case.toml");
  EXPECT_EQ(parse_case_text(to_toml(c), "case.toml"), c);
  const geometry::SolidPtr s = make_solid(c, "case.toml");
  EXPECT_TRUE(s->moves());
  // On the sphere's wall at (2.2, 0.5, 0.5): omega x r = 3 e_z x 0.2 e_x = 0.6 e_y.
  EXPECT_LT((s->wall_velocity({2.2, 0.5, 0.5}) - Eigen::Vector3d(0.0, 0.6, 0.0)).norm(), 1e-12);
  // On the tube's wall at (1, 0.95, 0.5): 0.5 e_x + (-2 e_x) x (0.45 e_y) = (0.5, 0, -0.9).
  EXPECT_LT((s->wall_velocity({1.0, 0.95, 0.5}) - Eigen::Vector3d(0.5, 0.0, -0.9)).norm(), 1e-12);
  EXPECT_FALSE(make_solid(parse_case_text(std::string(kBase) + "[[solid]]\nshape = \"sphere\"\ncentre = [2, 0.5, 0.5]\n"
                                                                  "radius = 0.2\n", "c"), "c")->moves());

  auto with = [](std::string_view table) { return std::string(kBase) + "[[solid]]\n" + std::string(table); };
  EXPECT_THAT(error_of(with("shape = \"cylinder\"\ncentre = [1, 0.5, 0.5]\nradius = 0.1\nangular_velocity = [0, 1, 0]\n")),
              HasSubstr("solid[0].angular_velocity = [0.0, 1.0, 0.0]: must be parallel to the axis"));
  EXPECT_THAT(error_of(with("shape = \"cylinder\"\ncentre = [1, 0.5, 0.5]\nradius = 0.1\nhalf_length = 0.5\n"
                            "axial_velocity = 1\n")),
              HasSubstr("solid[0].axial_velocity = 1.0: only an infinite cylinder"));
  EXPECT_THAT(error_of(with("shape = \"box\"\nlo = [0, 0, 0]\nhi = [1, 1, 1]\nangular_velocity = [0, 0, 1]\n")),
              HasSubstr("solid[0].angular_velocity = [0, 0, 1]: only used with shape"));
  EXPECT_THAT(error_of(with("shape = \"sphere\"\ncentre = [1, 0.5, 0.5]\nradius = 0.1\naxial_velocity = 1\n")),
              HasSubstr("solid[0].axial_velocity = 1: only used with shape = \"cylinder\""));
  EXPECT_THAT(error_of("dimension = 2\n[domain]\nroots = [1, 1]\n[fluid.boundary]\nx_lo = { type = \"wall\" }\n"
                       "x_hi = { type = \"wall\" }\ny_lo = { type = \"wall\" }\ny_hi = { type = \"wall\" }\n"
                       "[[solid]]\nshape = \"sphere\"\ncentre = [0.5, 0.5]\nradius = 0.1\nangular_velocity = [1, 0, 0]\n"),
              HasSubstr("solid[0].angular_velocity = [1.0, 0.0, 0.0]: a 2D case turns in its plane"));
}

TEST(CaseSolids, BadStlFilesNameTheKeyAndTheFile) {
  ScratchDir dir("case_solids_bad_stl");
  auto message = [&](const std::string& file) {
    const CaseConfig c = parse_case_text(std::string(kBase) + "[[solid]]\nshape = \"stl\"\nfile = \"" + file + "\"\n",
                                         (dir.path() / "case.toml").string());
    try {
      (void)make_solid(c, "case.toml");
    } catch (const CaseError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(message("none.stl"), HasSubstr("case.toml: solid[0].file: " + (dir.path() / "none.stl").string() +
                                             ": no such STL file"));
  std::vector<stl_files::Facet> inward = stl_files::box_facets({0, 0, 0}, {1, 1, 1});
  for (auto& f : inward) std::swap(f[1], f[2]);
  stl_files::write_ascii((dir.path() / "inward.stl").string(), inward);
  EXPECT_THAT(message("inward.stl"), HasSubstr("case.toml: solid[0].file: " + (dir.path() / "inward.stl").string()));
  EXPECT_THAT(message("inward.stl"), HasSubstr("inward"));
}

}  // namespace
}  // namespace capsflow::io
