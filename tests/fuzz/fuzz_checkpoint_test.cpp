// Fuzzing the checkpoint reader (issue 14): a checkpoint truncated or corrupted at random
// offsets (bit flips, overwritten ranges, zeroed ranges) must end in a CheckpointError, or
// — when the damage hit bytes nobody reads — in a restart identical to the undamaged one;
// never a crash, another exception or a silently different state. In-process with
// read_checkpoint into a fresh tree, then a few through `capsflow run --restart`.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "../app/small_cavity.hpp"
#include "fuzz_support.hpp"
#include "io/checkpoint.hpp"
#include "mutator.hpp"

namespace capsflow::fuzz {
namespace {

constexpr tree::TreeOptions<2> kOptions{.roots = {2, 1}, .root_size = 1.0, .origin = {0.0, 0.0},
                                        .periodic = {true, false}, .max_level = 6};

tree::Tree<2> bare_tree() {
  tree::Tree<2> t(kOptions);
  (void)t.add_field({.name = "p"});
  (void)t.add_field({.name = "u", .prolongation = tree::Prolongation::limited});
  return t;
}

// A restored run, compared bit for bit.
struct State {
  std::vector<std::uint64_t> cells;  // level, coordinates and field bits of each leaf
  io::CheckpointScalars scalars;
  std::vector<io::ExtraArray> extras;
  bool operator==(const State&) const = default;
};

State state_of(const tree::Tree<2>& t, io::RestoredState r) {
  State s{.cells = {}, .scalars = r.scalars, .extras = std::move(r.extras)};
  for (const tree::Index c : t.leaves()) {
    s.cells.push_back(static_cast<std::uint64_t>(t.level_of(c)));
    for (const auto x : t.coords(c)) s.cells.push_back(static_cast<std::uint64_t>(x));
    for (tree::FieldId f = 0; f < t.num_fields(); ++f) s.cells.push_back(std::bit_cast<std::uint64_t>(t.values(f)[c]));
  }
  return s;
}

std::string corrupt(Mutator& m, std::string bytes) {
  switch (m.below(4)) {
    case 0: return bytes.substr(0, m.below(bytes.size()));  // truncated
    case 1:                                                   // bit flips
      for (std::size_t k = 1 + m.below(3); k > 0; --k) bytes[m.below(bytes.size())] ^= static_cast<char>(1u << m.below(8));
      return bytes;
    case 2: {  // a range overwritten with random bytes
      const std::size_t at = m.below(bytes.size()), n = std::min(bytes.size() - at, 1 + m.below(64));
      return bytes.replace(at, n, m.random_bytes(n));
    }
    default: {  // a range zeroed
      const std::size_t at = m.below(bytes.size()), n = std::min(bytes.size() - at, 1 + m.below(512));
      return bytes.replace(at, n, std::string(n, '\0'));
    }
  }
}

TEST(FuzzCheckpoint, CorruptionIsRefusedOrHarmless) {
  const fs::path dir = scratch("checkpoint");
  const fs::path good = dir / "good.h5", bad = dir / "bad.h5";
  {
    tree::Tree<2> t = bare_tree();
    (void)t.refine_to([](const tree::Box<2>& b) { return b.lo[0] < 0.6 && b.hi[0] > 0.4 && b.lo[1] < 0.3 ? 6 : 2; });
    for (const tree::Index c : t.leaves()) {
      t.values(0)[c] = std::sin(3.0 * c) + 1e-3 * c;
      t.values(1)[c] = std::cos(7.0 * c) / (1.0 + c);
    }
    const std::vector<io::ExtraArray> extras{{.name = "capsule_0_positions", .shape = {4, 3},
                                              .values = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}}};
    io::write_checkpoint(good, t, {.time = 0.25, .step = 25, .dt = 0.01}, extras);
  }
  const io::CheckpointExpectations expect{.t_end = 1.0, .capsule_nodes = std::vector<std::size_t>{4}};
  tree::Tree<2> reference_tree = bare_tree();
  const State reference = state_of(reference_tree, io::read_checkpoint(good, reference_tree, expect));
  const std::string bytes = slurp(good);

  const std::uint64_t s = seed(20261124);
  Mutator m(s);
  Tally tally;
  std::size_t harmless = 0;
  const std::size_t n = scaled(400);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string damaged = corrupt(m, bytes);
    if (damaged == bytes) continue;
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << damaged;
    ++tally.inputs;
    tree::Tree<2> t = bare_tree();
    std::string finding;
    try {
      const State got = state_of(t, io::read_checkpoint(bad, t, expect));
      if (got == reference) ++harmless, ++tally.accepted;
      else finding = "read without error into another state";
    } catch (const io::CheckpointError& e) {
      const std::string what = e.what();
      if (what.find('\n') != std::string::npos || what.find(bad.string() + ": ") != 0) finding = "message: " + what;
      else if (t.depth() != 0) finding = "refused after changing the tree: " + what;
      else tally.reject(what);
    } catch (const std::exception& e) {
      finding = std::string("another exception: ") + typeid(e).name() + ": " + e.what();
    }
    if (!finding.empty()) {
      const fs::path keep = dir / ("finding_" + std::to_string(i) + ".h5");
      fs::copy_file(bad, keep, fs::copy_options::overwrite_existing);
      tally.findings.push_back(finding);
      ADD_FAILURE() << "seed " << s << ", input " << i << ": " << finding << " (file " << keep << ")";
    }
  }
  tally.print("damaged checkpoints, in-process");
  std::printf("[fuzz] %zu of them damaged bytes nobody reads (restored exactly)\n", harmless);
  EXPECT_GT(tally.rejected, tally.inputs / 2);
  if (!HasFailure()) fs::remove_all(dir);  // (a failure keeps the damaged files)
}

// Through the binary: a small cavity run with its final checkpoint, damaged copies
// restarted into fresh folders. Exit 2 with one line, or exit 0 with the diagnostics of
// the undamaged restart (wall-clock column aside).
const std::string kCavity = test_cases::small_cavity("[output]\ncheckpoint = true\nvtu = false\n");

// Every line without the field of the header's wall_s column (found by name: columns are
// appended after it).
std::string without_wall_clock(const std::string& csv) {
  std::string out, line;
  std::istringstream in(csv);
  int wall = -1;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
    if (wall < 0)
      wall = static_cast<int>(std::find(fields.begin(), fields.end(), "wall_s") - fields.begin());
    for (std::size_t k = 0; k < fields.size(); ++k)
      if (static_cast<int>(k) != wall) out += fields[k] + ",";
    out += "\n";
  }
  return out;
}

TEST(FuzzCheckpoint, DamagedRestartsThroughTheBinary) {
  const fs::path dir = scratch("checkpoint_binary");
  std::ofstream(dir / "case.toml") << kCavity;
  const std::vector<std::string> run{"run", (dir / "case.toml").string(), "--quiet", "--set", "time.t_end=0.04"};
  const Exit first = run_capsflow({"run", (dir / "case.toml").string(), "--quiet", "--out", (dir / "first").string()}, dir);
  ASSERT_EQ(first.status, 0) << first.err;
  const fs::path checkpoint = dir / "first" / "checkpoint_000002.h5";
  // Each restart continues in a copy of the first run's folder from the copy's own checkpoint,
  // as a user continues a run (a restart into a folder that holds another run is refused).
  auto restart = [&](const std::string* damaged, const std::string& out) {
    fs::copy(dir / "first", dir / out, fs::copy_options::recursive);
    const fs::path file = dir / out / checkpoint.filename();
    if (damaged) std::ofstream(file, std::ios::binary | std::ios::trunc) << *damaged;
    std::vector<std::string> args = run;
    for (const std::string& a : {std::string("--out"), (dir / out).string(), std::string("--restart"), file.string()})
      args.push_back(a);
    return run_capsflow(args, dir);
  };
  const Exit clean_run = restart(nullptr, "clean");
  ASSERT_EQ(clean_run.status, 0) << clean_run.err;
  const std::string clean = without_wall_clock(slurp(dir / "clean" / "diagnostics.csv"));

  const std::string bytes = slurp(checkpoint);
  Mutator m(seed(20261125));
  Tally tally;
  for (std::size_t i = 0; i < scaled(6); ++i) {
    const std::string damaged = corrupt(m, bytes);
    const std::string out = "out_" + std::to_string(i);
    const Exit r = restart(&damaged, out);
    ++tally.inputs;
    std::string problem;
    if (r.status == 0) {
      if (without_wall_clock(slurp(dir / out / "diagnostics.csv")) != clean) problem = "exit 0 with other diagnostics";
      else ++tally.accepted;
    } else {
      problem = refusal_problem(r);
      if (problem.empty()) tally.reject(r.err);
    }
    if (!problem.empty()) tally.findings.push_back(problem);
    EXPECT_EQ(problem, "") << "damaged copy " << i;
  }
  tally.print("damaged checkpoints, through the binary");
  if (!HasFailure()) fs::remove_all(dir);
  std::error_code ignored;
  fs::remove(dir.parent_path(), ignored);  // once empty
}

}  // namespace
}  // namespace capsflow::fuzz
