#pragma once
// The members of a study: every combination of each [[ladder]]'s values, as --set overrides
// of the base case, each case parsed and checked before anything runs.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "io/case_config.hpp"
#include "io/study_config.hpp"

namespace capsflow::app::study {

struct Member {
  std::string name;                                         // "dt=0.0005+nodes=642": its folder and legend
  std::vector<std::pair<std::string, std::string>> values;  // ladder key -> TOML text, in ladder[0]'s order
  std::filesystem::path config_file;                        // the base case
  std::vector<std::string> overrides;                       // the study's `set`, then key=value per ladder key
  io::CaseConfig config;                                    // the case the member runs
  double x = 0.0;                                           // the study's x value as a number
  double h = 0.0;                                           // the step or spacing x stands for (order fits)
  std::string series;                                       // the other ladder values ("" when x is alone)
  std::size_t reference = 0;                                // index of the member its errors are taken against
};

// The short name of a ladder key in member names: its last segment ("time.dt" -> "dt",
// "capsule[0].nodes" -> "nodes", "adapt.enabled" -> "adapt").
[[nodiscard]] std::string key_label(const std::string& key);

// The step or spacing a ladder value stands for, smaller being finer: dt and tolerances as
// they are, max_level L as 2^-L, nodes N as N^-1/2 (the node spacing), anything else 1/x.
[[nodiscard]] double spacing(const std::string& key, double x);

// Throws io::CaseError (one line: the study file, the member, the case's own message) for a
// member whose case does not parse or validate, duplicate members, a reference or plot
// member that does not exist, or a D12 time beyond a member's t_end.
[[nodiscard]] std::vector<Member> expand_members(const io::StudyConfig& study);

}  // namespace capsflow::app::study
