// capsflow study (issue 18), end to end on a tiny study: a 2D cavity on three levels (a
// second in all), and the order and equal-error arithmetic on synthetic errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>

#include <cmath>

#include "app/study/members.hpp"
#include "app/study/orders.hpp"
#include "app_support.hpp"
#include "io/csv_table.hpp"
#include "small_cavity.hpp"

namespace capsflow::app {
namespace {

using namespace testing;
using ::testing::HasSubstr;

// The small cavity to t = 0.02 in steps of 0.002, no snapshots; members vary max_level.
fs::path tiny_study(const fs::path& dir, const std::string& extra = "") {
  write(dir, "cavity.toml", test_cases::small_cavity("[output]\nvtu = false\n"));
  return write(dir, "tiny.toml", R"(base = "cavity.toml"
set = ["time.dt=0.002"]
x = "adapt.max_level"
error = "vmax"
[[ladder]]
"adapt.max_level" = [3, 4, 5]
)" + extra);
}

Result study(const fs::path& file, const fs::path& dir) {
  return capsflow("study " + file.string() + " --quiet --no-plots --out " + (dir / "out").string(), dir);
}

std::size_t row_of(const io::CsvTable& t, const std::string& text, const std::string& member) {
  // The member names are not numbers: find the row by the order of members in the text.
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  for (std::size_t i = 0; std::getline(in, line); ++i)
    if (line.starts_with(member + ",")) return i;
  ADD_FAILURE() << member << " not in study.csv";
  return t.rows.size();
}

// study.csv with its text columns (member, status, series, reference, adapt) blanked so
// that the numeric reader takes it.
io::CsvTable numeric_study_csv(const fs::path& out, std::string& text) {
  text = slurp(out / "study.csv");
  std::string blanked;
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  blanked += line + "\n";
  while (std::getline(in, line)) {
    std::vector<std::string> cells{""};
    for (const char c : line) {
      if (c == ',') cells.emplace_back();
      else cells.back() += c;
    }
    for (const int k : {0, 1, 3, 4, 9}) cells[static_cast<std::size_t>(k)].assign(1, '0');
    for (std::size_t k = 0; k < cells.size(); ++k) {
      if (k > 0) blanked += ',';
      blanked += cells[k].empty() ? std::string("nan") : cells[k];
    }
    blanked += '\n';
  }
  write(out, "study_numeric.csv", blanked);
  return io::read_csv_table(out / "study_numeric.csv");
}

// Every study in cases/studies/ parses, and so does every member's case.
TEST(Study, EveryReadyStudyExpands) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(std::string(CAPSFLOW_CASES_DIR) + "/studies")) {
    if (entry.path().extension() != ".toml") continue;
    std::vector<study::Member> members;
    EXPECT_NO_THROW(members = study::expand_members(io::parse_study(entry.path()))) << entry.path();
    EXPECT_GE(members.size(), 2u) << entry.path();
    ++count;
  }
  EXPECT_GE(count, 5);
  // The seed's time-step study: 4 time steps x 2 meshes, each mesh's reference its dt = 1e-4.
  const auto seed = study::expand_members(io::parse_study(std::string(CAPSFLOW_CASES_DIR) + "/studies/seed_dt.toml"));
  ASSERT_EQ(seed.size(), 8u);
  for (const auto& m : seed) {
    EXPECT_EQ(seed[m.reference].config.time.dt, 1e-4) << m.name;
    EXPECT_EQ(seed[m.reference].config.capsules[0].nodes, m.config.capsules[0].nodes) << m.name;
  }
  EXPECT_EQ(seed.front().name, "nodes=10242+dt=0.001");
}

TEST(Study, OrdersFromSyntheticErrors) {
  // e = 3 h^2 given in no particular order: every segment has order 2, coarse to fine.
  const auto segs = study::observed_orders({{0.25, 3 * 0.0625}, {1.0, 3.0}, {0.5, 0.75}});
  ASSERT_EQ(segs.size(), 2u);
  EXPECT_EQ(segs[0].h_coarse, 1.0);
  EXPECT_EQ(segs[1].h_fine, 0.25);
  for (const auto& s : segs) EXPECT_NEAR(s.order, 2.0, 1e-12);
  // Ratios that are not powers of two (dt = 1e-3, 5e-4, 2e-4, 1e-4), e = h^1.3 then h^0.7.
  const double h[] = {1e-3, 5e-4, 2e-4};
  const auto mixed = study::observed_orders({{h[0], std::pow(h[0], 1.3)}, {h[1], std::pow(h[1], 1.3)},
                                              {h[2], std::pow(h[1], 1.3) * std::pow(h[2] / h[1], 0.7)}});
  EXPECT_NEAR(mixed[0].order, 1.3, 1e-12);
  EXPECT_NEAR(mixed[1].order, 0.7, 1e-12);
  // A zero error (the reference itself) or a NaN gives no order.
  EXPECT_TRUE(std::isnan(study::observed_orders({{1.0, 1.0}, {0.5, 0.0}})[0].order));
  EXPECT_TRUE(std::isnan(study::observed_orders({{1.0, NAN}, {0.5, 1.0}})[0].order));
  // Cost at equal error: exact on a power law, NaN outside the range.
  const std::vector<std::pair<double, double>> cells{{1e-2, 1e3}, {1e-3, 1e5}, {1e-4, 1e7}};
  EXPECT_NEAR(study::cost_at_error(cells, std::sqrt(1e-2 * 1e-3)), 1e4, 1e-8);
  EXPECT_NEAR(study::cost_at_error(cells, 1e-3), 1e5, 1e-8);
  EXPECT_TRUE(std::isnan(study::cost_at_error(cells, 1e-1)));
  EXPECT_TRUE(std::isnan(study::cost_at_error({{1e-2, 1e3}}, 1e-2)));
}

// Every member in study.csv, the reference the finest, and the orders in orders.csv those
// of the members' own vmax values.
TEST(Study, TinyStudyReportsEveryMemberAndItsOrders) {
  const fs::path dir = scratch("study_tiny");
  const auto r = study(tiny_study(dir), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  std::string text;
  const io::CsvTable t = numeric_study_csv(dir / "out", text);
  ASSERT_EQ(t.rows.size(), 3u) << text;
  for (const char* m : {"max_level=3", "max_level=4", "max_level=5"}) {
    EXPECT_THAT(text, HasSubstr(std::string(m) + ",ran,")) << text;
    EXPECT_TRUE(fs::exists(dir / "out" / "members" / m / "diagnostics.csv")) << m;
  }
  std::vector<double> vmax;
  for (const std::string level : {"3", "4", "5"}) {
    const std::string m = "max_level=" + level;
    const auto& row = t.rows[row_of(t, text, m)];
    vmax.push_back(row[t.column("vmax")]);
    EXPECT_EQ(row[t.column("steps")], 10);
    EXPECT_NEAR(row[t.column("t_end")], 0.02, 1e-12);
    EXPECT_GT(row[t.column("cells_mean")], 0);
    EXPECT_GT(row[t.column("cpu_s")], 0);
    // The reference (max_level=5) has no error against itself.
    EXPECT_THAT(text, HasSubstr(m + ",ran," + level + ",,max_level=5,1,0.002," + level + ","));
  }
  EXPECT_EQ(t.rows[row_of(t, text, "max_level=5")][t.column("vmax_err")], 0.0);
  // Orders of vmax (h = 2^-level), coarse to fine, from the values above.
  const std::string orders = slurp(dir / "out" / "orders.csv");
  std::istringstream in(orders);
  std::string line;
  std::vector<double> found;
  while (std::getline(in, line))
    if (line.starts_with(",vmax,")) found.push_back(std::stod(line.substr(line.rfind(',') + 1)));
  ASSERT_EQ(found.size(), 2u) << orders;
  EXPECT_NEAR(found[0], std::log2(vmax[0] / vmax[1]), 1e-9);
  EXPECT_NEAR(found[1], std::log2(vmax[1] / vmax[2]), 1e-9);
}

// A member that did not finish (no study_done.txt: killed while it ran) runs again; the
// finished ones are skipped, their files untouched; a changed study reruns what it changes.
TEST(Study, InterruptedStudyResumesWithoutRerunningFinishedMembers) {
  const fs::path dir = scratch("study_resume");
  const fs::path file = tiny_study(dir);
  ASSERT_EQ(study(file, dir).status, 0);
  const fs::path members = dir / "out" / "members";
  const auto stamp = [&](const char* m) { return fs::last_write_time(members / m / "diagnostics.csv"); };
  const auto t3 = stamp("max_level=3"), t5 = stamp("max_level=5");
  fs::remove(members / "max_level=4" / "study_done.txt");
  write(members / "max_level=4", "diagnostics.csv", "step,t\n1,0.002\n");  // cut short
  const auto again = study(file, dir);
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(stamp("max_level=3"), t3);
  EXPECT_EQ(stamp("max_level=5"), t5);
  const std::string text = slurp(dir / "out" / "study.csv");
  EXPECT_THAT(text, HasSubstr("max_level=3,skipped,"));
  EXPECT_THAT(text, HasSubstr("max_level=4,ran,"));
  EXPECT_THAT(text, HasSubstr("max_level=5,skipped,"));
  EXPECT_TRUE(fs::exists(members / "max_level=4" / "study_done.txt"));
  EXPECT_EQ(io::read_csv_table(members / "max_level=4" / "diagnostics.csv").rows.size(), 10u);

  // Another dt is another case: every member runs again.
  write(dir, "tiny.toml", slurp(file).replace(slurp(file).find("0.002"), 5, "0.004"));
  ASSERT_EQ(study(file, dir).status, 0);
  EXPECT_NE(stamp("max_level=3"), t3);
  EXPECT_THAT(slurp(dir / "out" / "study.csv"), Not(HasSubstr("skipped")));
}

// --jobs 3 runs the members side by side, with the same results as one after another.
TEST(Study, JobsGiveTheSameResults) {
  const fs::path dir = scratch("study_jobs");
  const fs::path file = tiny_study(dir);
  ASSERT_EQ(study(file, dir).status, 0);
  const auto side_by_side = capsflow("study " + file.string() + " --quiet --no-plots --jobs 3 --out " +
                                         (dir / "jobs").string(), dir);
  ASSERT_EQ(side_by_side.status, 0) << side_by_side.err;
  for (const char* m : {"max_level=3", "max_level=4", "max_level=5"}) {
    const auto a = io::read_csv_table(dir / "out" / "members" / m / "diagnostics.csv");
    const auto b = io::read_csv_table(dir / "jobs" / "members" / m / "diagnostics.csv");
    ASSERT_EQ(a.rows.size(), b.rows.size()) << m;
    EXPECT_EQ(a.rows.back()[a.column("vmax")], b.rows.back()[b.column("vmax")]) << m;
  }
  EXPECT_EQ(slurp(dir / "out" / "orders.csv"), slurp(dir / "jobs" / "orders.csv"));
}

// The plots and the CSV of the data behind each (when python3 has numpy and matplotlib).
TEST(Study, PlotsComeWithTheirData) {
  const fs::path dir = scratch("study_plots");
  const auto r = capsflow("study " + tiny_study(dir).string() + " --quiet --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  if (r.err.find("warning: python3") != std::string::npos) GTEST_SKIP() << r.err;
  EXPECT_EQ(r.err, "");
  for (const char* f : {"error_vs_dx.png", "error_vs_dx.csv", "error_vs_cost.png", "error_vs_cost.csv"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  const std::string data = slurp(dir / "out" / "error_vs_dx.csv");
  EXPECT_EQ(lines(data), 4) << data;
  EXPECT_THAT(data, HasSubstr(",max_level=4,0.0625,"));
  EXPECT_EQ(lines(slurp(dir / "out" / "error_vs_cost.csv")), 3);  // the reference has no error
}

// SIGTERM to a running study: the running member stops (its own checkpoint), no other
// starts, exit status 143; the same command then runs only what did not finish.
TEST(Study, SignalStopsTheStudyAndTheNextRunResumes) {
  const fs::path dir = scratch("study_signal");
  write(dir, "cavity.toml", test_cases::small_cavity("[output]\nvtu = false\n"));
  const fs::path file = write(dir, "slow.toml", R"(base = "cavity.toml"
set = ["time.dt=0.0005", "time.t_end=0.05", "adapt.enabled=false"]
[[ladder]]
"adapt.max_level" = [3, 7, 4]
)");
  const fs::path members = dir / "out" / "members";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int err = ::open((dir / "stderr.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(err, STDERR_FILENO);
    setenv("OMP_NUM_THREADS", "1", 1);
    execl(CAPSFLOW_BINARY, CAPSFLOW_BINARY, "study", file.c_str(), "--quiet", "--no-plots", "--out",
          (dir / "out").c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Once the first member is done and the second (100 steps on 16k cells) has written a row,
  // stop the study.
  for (int i = 0; i < 3000 && !(fs::exists(members / "max_level=3" / "study_done.txt") &&
                                fs::exists(members / "max_level=7" / "diagnostics.csv"));
       ++i)
    usleep(10000);
  kill(pid, SIGTERM);
  int raw = 0;
  ASSERT_EQ(waitpid(pid, &raw, 0), pid);
  ASSERT_TRUE(WIFEXITED(raw));
  EXPECT_EQ(WEXITSTATUS(raw), 143) << slurp(dir / "stderr.txt");
  EXPECT_THAT(slurp(dir / "stderr.txt"), HasSubstr("run the same command again to resume"));
  EXPECT_FALSE(fs::exists(members / "max_level=7" / "study_done.txt"));
  EXPECT_FALSE(fs::exists(members / "max_level=4"));  // never started
  const std::string text = slurp(dir / "out" / "study.csv");
  EXPECT_THAT(text, HasSubstr("max_level=3,ran,"));
  EXPECT_THAT(text, HasSubstr("max_level=7,interrupted,"));
  EXPECT_THAT(text, HasSubstr("max_level=4,not_run,"));

  const auto stamp = fs::last_write_time(members / "max_level=3" / "diagnostics.csv");
  const auto again = capsflow("study " + file.string() + " --quiet --no-plots --out " + (dir / "out").string(), dir);
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(fs::last_write_time(members / "max_level=3" / "diagnostics.csv"), stamp);
  const std::string resumed = slurp(dir / "out" / "study.csv");
  EXPECT_THAT(resumed, HasSubstr("max_level=3,skipped,"));
  EXPECT_THAT(resumed, HasSubstr("max_level=7,ran,"));
  EXPECT_THAT(resumed, HasSubstr("max_level=4,ran,"));
}

// [expect] lines that do not hold: exit status 1, each named.
TEST(Study, FailedExpectationExitsOne) {
  const fs::path dir = scratch("study_expect");
  const auto r = study(tiny_study(dir, "[expect]\nmin_order = { vmax = 50.0 }\nmax_value = { vmax = 1e-9 }\n"), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("study expectation failed: order of vmax in series \"\" from max_level = 3 to 4"));
  EXPECT_THAT(r.err, HasSubstr("study expectation failed: vmax of member max_level=3 = "));
}

// A bad study file: one line naming the file and the key, exit status 2, nothing run.
TEST(Study, BadStudyFileIsOneLineAndExitTwo) {
  const fs::path dir = scratch("study_bad");
  tiny_study(dir);
  const std::pair<std::string, std::string> cases[] = {
      {"base = \"cavity.toml\"\nrefrence = \"finest\"\n[[ladder]]\n\"time.dt\" = [0.01]\n",
       "bad.toml: refrence: unknown key (did you mean reference?)"},
      {"[[ladder]]\n\"time.dt\" = [0.01]\n", "bad.toml: base: missing"},
      {"base = \"cavity.toml\"\n", "bad.toml: ladder: missing"},
      {"base = \"cavity.toml\"\n[[ladder]]\n\"time.dt\" = 0.01\n", "bad.toml: ladder.time.dt = 0.01: expected a non-empty array"},
      {"base = \"cavity.toml\"\n[[ladder]]\n\"time.dtt\" = [0.01]\n",
       "bad.toml: member dtt=0.01: " },
      {"base = \"cavity.toml\"\n[[ladder]]\n\"time.dt\" = [-0.01]\n", "time.dt = -0.01 (from --set): must be > 0"},
      {"base = \"missing.toml\"\n[[ladder]]\n\"time.dt\" = [0.01]\n", "missing.toml: cannot read the case file"},
      {"base = \"cavity.toml\"\nx = \"time.t_end\"\n[[ladder]]\n\"time.dt\" = [0.01]\n",
       "bad.toml: x = \"time.t_end\": must be one of the ladder's keys"},
      {"base = \"cavity.toml\"\nreference = \"dt=1\"\n[[ladder]]\n\"time.dt\" = [0.01]\n",
       "reference = \"dt=1\": no member has that name"},
      {"base = \"cavity.toml\"\n[[ladder]]\n\"time.dt\" = [0.01]\n[expect]\nmin_order = { Ninf = 1 }\n",
       "bad.toml: expect.min_order.Ninf: unknown criterion"},
      {"base = \"cavity.toml\"\n[[ladder]\n", "bad.toml: line 2"},
  };
  for (const auto& [text, expected] : cases) {
    write(dir, "bad.toml", text);
    const auto r = capsflow("study " + (dir / "bad.toml").string() + " --quiet --no-plots --out " +
                                (dir / "out_bad").string(), dir);
    EXPECT_EQ(r.status, 2) << text << r.err;
    EXPECT_EQ(lines(r.err), 1) << r.err;
    EXPECT_THAT(r.err, HasSubstr(expected)) << text;
    EXPECT_FALSE(fs::exists(dir / "out_bad")) << text;
  }
  const auto none = capsflow("study " + (dir / "nothing.toml").string(), dir);
  EXPECT_EQ(none.status, 2);
  EXPECT_THAT(none.err, HasSubstr("nothing.toml: cannot read the study file: no such file"));
}

}  // namespace
}  // namespace capsflow::app
