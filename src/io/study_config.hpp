#pragma once
// A convergence study, as a study file describes it (docs/studies.md): a base case, a ladder
// of overrides whose members are run one by one, and what to compute and check from them.
// Parsing is strict like a case file's: an unknown key, a wrong type or an impossible value
// is one CaseError line naming the study file and the key.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace capsflow::io {

// One [[ladder]] table: every combination of its values is a member. Keys are dotted case
// keys as --set takes them ("time.dt", "capsule[0].nodes"); values are kept as TOML text.
struct StudyLadder {
  std::vector<std::pair<std::string, std::vector<std::string>>> axes;
};

// [expect]: what the study must show, checked after it ran (exit status 1 when not).
struct StudyExpect {
  // Criterion -> the smallest observed order allowed on any segment of any series.
  std::vector<std::pair<std::string, double>> min_order;
  // Criterion -> the largest value allowed for any member (errors against the reference,
  // or the criterion itself for vmax, area_rel and volume_rel, in absolute value).
  std::vector<std::pair<std::string, double>> max_value;
  double min_cells_ratio = 0.0;  // uniform cells / adaptive cells at equal error, each pair
  double min_wall_ratio = 0.0;   // the same with wall time
};

struct StudyConfig {
  std::filesystem::path file;            // the study file as named
  std::string name;                      // default: the file's stem
  std::filesystem::path base;            // the base case, relative paths from the study file's folder
  std::vector<std::string> set;          // --set overrides for every member
  std::vector<StudyLadder> ladders;      // members: the union of each ladder's combinations
  std::string x;                         // the ladder key on the order plots' x axis
  std::string reference = "finest";      // "finest" (per series) or a member's name
  std::string error = "N_inf";           // error on the cells / wall-time plots: N_inf, D12 or vmax
  std::vector<double> d12_times;         // D12 and D12_bbox reported at these times (t_end always)
  std::vector<std::string> plot_members; // members on the D12(t) plot (empty: all)
  StudyExpect expect;
};

// The criteria a study computes; [expect] and `error` name them.
inline constexpr const char* kStudyCriteria[] = {"N_inf", "vmax", "area_rel", "volume_rel", "D12"};

// Reads and checks a study file (not the members' cases: see app/study/members.hpp).
// Throws CaseError.
[[nodiscard]] StudyConfig parse_study(const std::filesystem::path& path);

}  // namespace capsflow::io
