#pragma once
// A run, as a case file describes it: plain structs with the documented defaults
// (docs/case-file.md lists every key, its default and its unit). Strings of the file
// become the enums below once, at parse time; nothing downstream compares strings.
//
// Vectors are std::array<.., 3> whatever the dimension: a 2D case reads and writes only
// the first two entries and leaves the third at its default, so one struct serves both.
// Boundary sides are numbered like the tree's: 2d for the low side of direction d, 2d+1
// for the high side (x_lo, x_hi, y_lo, y_hi, z_lo, z_hi).
#include <array>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "io/errors.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::io {

enum class BoundaryType : unsigned char { wall, moving_wall, inflow, outflow, periodic };
enum class InflowProfile : unsigned char { uniform, square_duct, parabolic, pipe };
enum class MembraneLaw : unsigned char { skalak, neo_hookean };
enum class InitialShape : unsigned char { sphere, ellipsoid, inflated };
enum class KernelType : unsigned char { cosine, hat, peskin4 };
enum class NodeScheme : unsigned char { euler, ab2, midpoint, bdf2 };
enum class Coupling : unsigned char { explicit_forces, implicit_forces, automatic };
enum class SolidShape : unsigned char { box, sphere, cylinder, tube, stl };
enum class SolidCombine : unsigned char { unite, subtract, intersect };
enum class SolidFill : unsigned char { inside, outside };

// The spelling of each enum value in a case file.
[[nodiscard]] std::string_view to_string(BoundaryType v);
[[nodiscard]] std::string_view to_string(InflowProfile v);
[[nodiscard]] std::string_view to_string(MembraneLaw v);
[[nodiscard]] std::string_view to_string(InitialShape v);
[[nodiscard]] std::string_view to_string(KernelType v);
[[nodiscard]] std::string_view to_string(NodeScheme v);
[[nodiscard]] std::string_view to_string(Coupling v);
[[nodiscard]] std::string_view to_string(SolidShape v);
[[nodiscard]] std::string_view to_string(SolidCombine v);
[[nodiscard]] std::string_view to_string(SolidFill v);

struct DomainConfig {
  std::array<int, 3> roots{1, 1, 1};     // root cubes per direction
  double root_size = 1.0;                // side of a root cube (units of l)
  std::array<double, 3> origin{};        // lower corner of the brick
  std::array<bool, 3> periodic{};        // periodic directions
  bool operator==(const DomainConfig&) const = default;
};

struct BoundaryConfig {
  BoundaryType type = BoundaryType::wall;
  std::array<double, 3> velocity{};                 // moving_wall: wall velocity (tangential)
  InflowProfile profile = InflowProfile::uniform;   // inflow
  double mean_velocity = 1.0;                       // inflow: mean normal velocity into the domain
  // inflow with profile = "pipe": Poiseuille flow in a circular pipe of this radius whose axis
  // is the side's normal through `centre` (a point of the side; default its centre).
  double radius = 0.0;
  std::array<double, 3> centre{};
  bool operator==(const BoundaryConfig&) const = default;
};

struct MultigridConfig {
  double tolerance = 1e-3;  // residual (max norm) that ends the cycles
  int max_cycles = 50;
  // A solve that stops at max_cycles above its tolerance: false counts it (the diagnostics'
  // mg_unconverged, a warning on stderr the first time), true also stops the run (exit 3).
  bool fail_on_unconverged = false;
  bool operator==(const MultigridConfig&) const = default;
};

struct FluidConfig {
  double Re = 1.0;              // Reynolds number rho V l / mu
  bool stokes = false;          // true: drop the advection term
  bool crank_nicolson = false;  // viscosity by Crank-Nicolson (else backward Euler)
  // The projected faces carried between steps, and each step's force in its viscous solve
  // (fluid::FlowOptions::carry_faces, current_force_in_viscous): with crank_nicolson and
  // time.node_scheme = "midpoint" the coupled step is second order in time.
  bool carry_faces = false;
  // The viscous solve sees this step's body force, not the last step's (Basilisk's lag):
  // fluid::FlowOptions::current_force_in_viscous. carry_faces and the implicit coupling imply it.
  bool current_force_in_viscous = false;
  // BDF2 steps (time.node_scheme = "bdf2"): at most this many GMRES iterations on the step's
  // pressure, which then stays consistent at steps above the viscous times
  // (fluid::FlowOptions::pressure_iterations); 0: one projection.
  int pressure_iterations = 0;
  std::array<BoundaryConfig, 6> boundary{};
  MultigridConfig multigrid{};
  bool operator==(const FluidConfig&) const = default;
};

struct AdaptConfig {
  bool enabled = true;               // false: uniform grid at max_level
  int min_level = 2;
  int max_level = 6;                 // also the tree's deepest level
  double velocity_tolerance = 1e-2;  // wavelet tolerance on each velocity component
  // > 0: the tolerance tightens to this fraction of max |u| when that is smaller (flows
  // that decay, like a relaxing capsule); 0: velocity_tolerance alone.
  double velocity_tolerance_relative = 0.0;
  int wall_level = 0;                // level forced along walls, the no-slip sides (0: off)
  int membrane_band = 4;             // cells of max_level forced around membrane nodes
  // N ranks: the partition weight of a max-level leaf in a membrane's band, that of a fluid
  // leaf being 1 (spreading and interpolation make it several fluid cells' work).
  int membrane_weight = 3;
  int interval = 1;                  // steps between adaptations
  // > interval: with capsules, an adaptation may wait up to this many steps while the
  // membrane nodes barely move (ibm::CapsuleCoupling::may_wait); 0: every interval.
  int max_interval = 0;
  // The same in time (> 0: replaces interval and max_interval, which must stay 1 and 0):
  // adaptations at the same instants whatever dt (fluid::AdaptationOptions).
  double interval_time = 0.0;
  double max_interval_time = 0.0;
  bool operator==(const AdaptConfig&) const = default;
};

struct CapsuleConfig {
  MembraneLaw law = MembraneLaw::skalak;
  double Ca = 0.1;                          // capillary number mu V / G_s
  double C = 1.0;                           // Skalak area-dilatation parameter
  int nodes = 2562;                         // icosphere nodes: 642, 2562, 10242, 40962
  int element_order = 1;                    // 1: P1 triangles, 2: P2 (6-node) triangles
  double radius = 1.0;                      // stress-free sphere radius a
  std::array<double, 3> centre{};
  InitialShape shape = InitialShape::sphere;
  std::array<double, 3> axes_factors{1.0, 1.0, 1.0};  // ellipsoid semi-axes / radius
  double inflation = 1.0;                   // inflated: initial radius / radius
  KernelType spread_kernel = KernelType::cosine;
  KernelType interp_kernel = KernelType::cosine;
  bool staggered = true;  // spread to and interpolate from the MAC faces (else cell centres)
  // staggered only: the kernels' divergence-free forms (ibm::DivergenceFree), one cell wider
  bool divergence_free = true;
  // The inner fluid: viscosity and density inside / outside the capsule (issue 29).
  double viscosity_ratio = 1.0;
  double density_ratio = 1.0;
  bool operator==(const CapsuleConfig&) const = default;
};

// One [[solid]] table: a shape, which side of it is solid, and how it combines with the
// solid of the tables before it (issue "Walls of any shape"; docs/case-file.md, "Solids").
// Each shape reads its own keys; the others keep their defaults.
struct SolidConfig {
  SolidShape shape = SolidShape::box;
  SolidCombine combine = SolidCombine::unite;  // with the tables above ("union" in the file)
  SolidFill fill = SolidFill::inside;          // the solid is the shape's inside or its outside
  std::array<double, 3> lo{}, hi{};            // box: its corners
  std::array<double, 3> centre{};              // sphere, cylinder, tube
  double radius = 0.0;                         // sphere, cylinder
  std::array<double, 3> axis{1.0, 0.0, 0.0};   // cylinder, tube: the direction of the axis
  double half_length = 0.0;                    // cylinder: 0 infinite; tube: the blend's half-length
  bool rounded_ends = false;                   // cylinder: hemispherical ends
  double far_radius = 0.0;                     // tube: the radius away from the throat
  double throat_radius = 0.0;                  // tube: the radius at its centre
  std::string file;                            // stl: the surface (absolute once parsed)
  double scale = 1.0;                          // stl: x -> scale x + translate
  std::array<double, 3> translate{};           // stl
  // A wall sliding along itself (the solid stays in place): sphere, cylinder and tube turn
  // about their centre and axis; an infinite cylinder may also slide along its axis.
  std::array<double, 3> angular_velocity{};    // sphere, cylinder, tube (parallel to the axis)
  double axial_velocity = 0.0;                 // infinite cylinder
  bool operator==(const SolidConfig&) const = default;
};

struct TimeConfig {
  double dt = 1e-3;     // time step (fixed), or the first step when cfl > 0
  double t_end = 1.0;
  double cfl = 0.0;     // 0: fixed dt; > 0: dt = cfl h_min / |u|_max, capped by dt_max
  double dt_max = 0.0;  // cap of the adaptive dt (0: dt)
  NodeScheme node_scheme = NodeScheme::euler;  // how membrane nodes move (ibm::NodeScheme)
  // The membrane forces in time (ibm::CapsuleCoupling::ImplicitOptions): "explicit" at X(t),
  // "implicit" linearised at X(t + dt); the implicit solve's tolerance and most flow steps.
  Coupling coupling = Coupling::explicit_forces;
  // > 0: the step chosen by accuracy (app/step_control.hpp), the membrane nodes' error per
  // unit time it allows (l/V per unit time: velocity units); 0: off.
  double tolerance = 0.0;
  double implicit_tolerance = 1e-3;
  int implicit_max_iterations = 40;
  bool operator==(const TimeConfig&) const = default;
};

struct OutputConfig {
  int interval = 100;              // steps between snapshots (.vtu)
  int diagnostics_interval = 1;    // steps between rows of diagnostics.csv
  bool vtu = true;                 // write .vtu snapshots and series.pvd
  bool checkpoint = false;         // write HDF5 checkpoints
  int checkpoint_interval = 0;     // steps between checkpoints (0: only at the end)
  bool cells_csv = false;          // write cells_final.csv: every leaf's centre, level, u, p
  std::string directory;           // default out/<name>
  bool operator==(const OutputConfig&) const = default;
};

struct CaseConfig {
  std::string name;  // default: the case file's stem
  int dimension = 3;
  DomainConfig domain{};
  FluidConfig fluid{};
  AdaptConfig adapt{};
  std::vector<CapsuleConfig> capsules;  // [[capsule]] tables
  std::vector<SolidConfig> solids;      // [[solid]] tables, combined in order
  TimeConfig time{};
  OutputConfig output{};
  bool operator==(const CaseConfig&) const = default;
};

// Reads a case file, applies `overrides` ("key=value", dotted keys, value in TOML syntax,
// e.g. "fluid.Re=10", "capsule[0].radius=0.8", "domain.roots=[4,1,1]"; a bare word is a
// string), fills defaults and validates everything. Throws CaseError, one line naming the
// file, the key and the reason.
[[nodiscard]] CaseConfig parse_case(const std::filesystem::path& path,
                                    std::span<const std::string> overrides = {});

// The same from text; `source` names it in messages and gives the default name (its stem).
[[nodiscard]] CaseConfig parse_case_text(std::string_view text, std::string_view source,
                                         std::span<const std::string> overrides = {});

// The value checks of parse_case, for a config built or changed in code. Throws CaseError
// naming `source` and the dotted key.
void validate_case(const CaseConfig& config, std::string_view source);

// The case as TOML with every key written out (defaults included): parse_case_text of the
// result gives back `config`.
[[nodiscard]] std::string to_toml(const CaseConfig& config);

// The deepest max_level a tree on these roots allows (the Morton key limit).
[[nodiscard]] int max_tree_level(const CaseConfig& config);

// The forest the case describes (roots, size, origin, periodicity, max_level).
template <int D>
[[nodiscard]] tree::TreeOptions<D> tree_options(const CaseConfig& config);

extern template tree::TreeOptions<2> tree_options<2>(const CaseConfig&);
extern template tree::TreeOptions<3> tree_options<3>(const CaseConfig&);

}  // namespace capsflow::io
