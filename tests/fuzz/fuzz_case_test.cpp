// Fuzzing the case-file parser and --set (issue 14): seeded random mutations of the
// shipped cases (cases/*.toml) and random overrides of the known keys. Every input must
// end in a valid case or in one error line (io::CaseError or std::invalid_argument, which
// capsflow run turns into exit status 2) — never a crash, a hang, another exception or a
// multi-line message. In-process for speed (parse, then the checks capsflow run makes
// before any work: the tree's options, the case written back as case.toml reading back
// the same), then a sample of the refused inputs through the binary: exit 2, one stderr
// line, nothing written to --out. The default suite runs a few thousand inputs; the
// `fuzz` label runs CAPSFLOW_FUZZ_SCALE times more.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>

#include "fuzz_support.hpp"
#include "io/case_config.hpp"
#include "mutator.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::fuzz {
namespace {

struct Case {
  std::string name, text;
};

std::vector<Case> shipped_cases() {
  std::vector<Case> out;
  for (const auto& e : fs::directory_iterator(CAPSFLOW_CASES_DIR))
    if (e.path().extension() == ".toml") out.push_back({e.path().filename().string(), slurp(e.path())});
  std::sort(out.begin(), out.end(), [](const Case& a, const Case& b) { return a.name < b.name; });
  return out;
}

// Every dotted key of the shipped cases, as to_toml writes them out (defaults included),
// and the keys inside the boundary tables.
std::vector<std::string> known_keys(const std::vector<Case>& cases) {
  std::set<std::string> keys;
  for (const Case& c : cases) {
    std::string section;
    const std::string text = io::to_toml(io::parse_case_text(c.text, c.name));
    std::size_t start = 0;
    while (start < text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      const std::string line = text.substr(start, end - start);
      start = end + 1;
      if (line.starts_with("[[")) section = line.substr(2, line.size() - 4) + "[0]";
      else if (line.starts_with("[")) section = line.substr(1, line.size() - 2);
      else if (const std::size_t eq = line.find(" = "); eq != std::string::npos)
        keys.insert((section.empty() ? "" : section + ".") + line.substr(0, eq));
    }
  }
  for (const char* side : {"x_lo", "x_hi", "y_lo", "y_hi", "z_lo", "z_hi"})
    for (const char* k : {"type", "velocity", "profile", "mean_velocity", "radius", "centre"})
      keys.insert(std::string("fluid.boundary.") + side + "." + k);
  keys.insert("capsule[1].radius");
  keys.insert("capsule[2].centre");
  return {keys.begin(), keys.end()};
}

struct Input {
  std::string text;
  std::vector<std::string> sets;
};

// What capsflow run checks before any work, in-process. Returns "" for a valid case, the
// error line for a refused one; anything else escapes as an exception.
std::string check(const Input& in) {
  try {
    const io::CaseConfig c = io::parse_case_text(in.text, "fuzz.toml", in.sets);
    if (c.dimension == 2) tree::validate(io::tree_options<2>(c));
    else tree::validate(io::tree_options<3>(c));
    // capsflow run writes the case it ran as case.toml: it must read back the same.
    if (io::parse_case_text(io::to_toml(c), "fuzz.toml") != c)
      return "\n(accepted, but to_toml does not read back the same case)";
    return "";
  } catch (const io::CaseError& e) {
    return e.what();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
}

// A program cannot receive a NUL byte, or an argument above 128 KiB (execv fails): such
// inputs are tried in-process only.
bool passable(const Input& in) {
  return std::all_of(in.sets.begin(), in.sets.end(),
                     [](const std::string& s) { return s.find('\0') == std::string::npos && s.size() < 100'000; });
}

void keep_reproducer(const fs::path& dir, std::size_t i, const Input& in) {
  std::ofstream(dir / ("input_" + std::to_string(i) + ".toml"), std::ios::binary) << in.text;
  std::ofstream sets(dir / ("input_" + std::to_string(i) + ".sets"), std::ios::binary);
  for (const std::string& s : in.sets) sets << s << '\n';
}

TEST(FuzzCase, ParserAndOverridesRefuseOrAccept) {
  const std::vector<Case> cases = shipped_cases();
  ASSERT_GE(cases.size(), 3u);
  const std::vector<std::string> keys = known_keys(cases);
  const std::uint64_t s = seed(20261123);
  Mutator m(s);
  const fs::path dir = scratch("case");
  const std::size_t n = scaled(4000), through_binary = scaled(12);
  Tally tally, binary;
  std::vector<Input> refused, valid;
  for (std::size_t i = 0; i < n; ++i) {
    const Case& base = m.pick(cases);
    Input in{base.text, {}};
    const bool mutate_text = m.chance(0.7);
    if (mutate_text) in.text = m.mutate(in.text);
    if (!mutate_text || m.chance(0.3))
      for (std::size_t k = 1 + m.below(3); k > 0; --k) in.sets.push_back(m.set_argument(keys));
    ++tally.inputs;
    std::string outcome;
    const auto start = std::chrono::steady_clock::now();
    try {
      outcome = check(in);
    } catch (const std::exception& e) {
      outcome = std::string("\n(another exception: ") + typeid(e).name() + ": " + e.what() + ")";
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (seconds > 2.0) outcome = "\n(took " + std::to_string(seconds) + " s)";
    if (outcome.size() > 2000) outcome = "\n(an error line of " + std::to_string(outcome.size()) + " characters)";
    if (outcome.empty()) {
      ++tally.accepted;
      if (valid.size() < 64 * through_binary && passable(in)) valid.push_back(std::move(in));
    } else if (outcome.find('\n') != std::string::npos) {
      keep_reproducer(dir, i, in);
      tally.findings.push_back("input " + std::to_string(i) + ": " + outcome);
    } else {
      tally.reject(outcome);
      if (refused.size() < 64 * through_binary && passable(in)) refused.push_back(std::move(in));
    }
  }
  tally.print("case files and --set, in-process");
  for (const std::string& f : tally.findings) ADD_FAILURE() << "seed " << s << ", " << f << " (reproducer in " << dir << ")";
  EXPECT_GT(tally.accepted, 0u);
  EXPECT_GT(tally.rejected, n / 4);

  // A spread of the refused inputs through the binary.
  for (std::size_t k = 0; k < through_binary && !refused.empty(); ++k) {
    const Input& in = refused[k * refused.size() / through_binary];
    const fs::path run = scratch("case_binary");
    std::ofstream(run / "case.toml", std::ios::binary) << in.text;
    fs::create_directories(run / "out");
    std::ofstream(run / "out" / "marker.txt") << "keep";
    std::vector<std::string> args{"run", (run / "case.toml").string(), "--quiet", "--out", (run / "out").string()};
    for (const std::string& set : in.sets) args.push_back("--set=" + set);
    const Exit r = run_capsflow(args, run);
    ++binary.inputs;
    std::string problem = refusal_problem(r);
    if (problem.empty() && std::distance(fs::directory_iterator(run / "out"), fs::directory_iterator{}) != 1)
      problem = "wrote into --out";
    if (problem.empty()) binary.reject(r.err);
    else binary.findings.push_back(problem);
    EXPECT_EQ(problem, "") << "through the binary, case " << run / "case.toml";
  }
  binary.print("case files and --set, through the binary");

#if !defined(__SANITIZE_ADDRESS__)  // (ASan needs terabytes of address space: no cap)
  // A few accepted inputs through the binary for a few seconds each, with a capped address
  // space: a run may finish (0), refuse (2, one line), fail (3) or still be running; it
  // must not die of a signal or exit otherwise.
  Tally running;
  const std::size_t through_binary_valid = scaled(2);
  for (std::size_t k = 0; k < through_binary_valid && !valid.empty(); ++k) {
    const Input& in = valid[k * valid.size() / through_binary_valid];
    const fs::path run = scratch("case_binary_valid");
    std::ofstream(run / "case.toml", std::ios::binary) << in.text;
    std::vector<std::string> args{"run", (run / "case.toml").string(), "--quiet", "--out", (run / "out").string()};
    for (const std::string& set : in.sets) args.push_back("--set=" + set);
    const Exit r = run_capsflow(args, run, std::chrono::seconds(3), rlim_t{4} << 30);
    ++running.inputs;
    std::string problem;
    if (r.signal && !r.timed_out) problem = "killed by signal " + std::to_string(r.signal) + ": " + r.err;
    else if (!r.timed_out && r.status != 0 && r.status != 2 && r.status != 3) problem = "exit status " + std::to_string(r.status);
    else if (r.status == 2) problem = refusal_problem(r);
    if (problem.empty()) ++running.accepted;
    else running.findings.push_back(problem);
    EXPECT_EQ(problem, "") << "an accepted case through the binary: " << run / "case.toml";
    if (problem.empty()) fs::remove_all(run);
  }
  running.print("accepted case files and --set, run for up to 3 s through the binary");
#endif
  if (!HasFailure())  // (a failure keeps its reproducers)
    for (const char* d : {"case", "case_binary", "case_binary_valid"}) fs::remove_all(dir.parent_path() / d);
  std::error_code ignored;
  fs::remove(dir.parent_path(), ignored);  // once empty
}

}  // namespace
}  // namespace capsflow::fuzz
