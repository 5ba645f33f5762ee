#pragma once
// What a study computes from its members' outputs (diagnostics.csv, membrane_final.csv) and
// writes next to them: study.csv (one row per member), orders.csv (the observed order on
// each segment of each series), equal_error.csv (uniform against adaptive at equal error).
#include <filesystem>
#include <string>
#include <vector>

#include "app/study/members.hpp"
#include "app/study/runner.hpp"
#include "io/study_config.hpp"

namespace capsflow::app::study {

struct MemberResult {
  bool available = false;  // the member finished and its outputs were read
  std::string problem;     // why not, when not
  double t_end = 0, N_inf = 0, vmax = 0, area_rel = 0, volume_rel = 0, D12 = 0, D12_bbox = 0;
  double D12_err = 0, vmax_err = 0;  // |value - the reference's| at t_end
  double cells_mean = 0, cells_final = 0, steps = 0, wall_s = 0;
  std::vector<double> d12_at, d12_bbox_at;  // at the study's d12_times (NaN where not reached)
  std::vector<double> nodes;                // final node positions, 3 per node
};

// Reads every member's outputs; errors are taken against each member's reference.
[[nodiscard]] std::vector<MemberResult> read_results(const io::StudyConfig& study, const std::vector<Member>& members,
                                                     const RunnerOptions& runner);

// A criterion of [expect] and orders.csv for one member: N_inf and D12 against the
// reference, vmax, area_rel and volume_rel in absolute value.
[[nodiscard]] double criterion(const MemberResult& r, const std::string& name);

// Writes study.csv, orders.csv and equal_error.csv into `dir`; returns the lines of [expect]
// that fail (empty: all hold).
std::vector<std::string> write_results(const io::StudyConfig& study, const std::vector<Member>& members,
                                       const std::vector<MemberOutcome>& outcomes,
                                       const std::vector<MemberResult>& results, const std::filesystem::path& dir);

}  // namespace capsflow::app::study
