#include "app/study/runner.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "app/interrupt.hpp"
#include "app/progress.hpp"
#include "app/study/spawn.hpp"
#include "io/atomic_write.hpp"

namespace capsflow::app::study {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kDone = "study_done.txt";  // written after a member's run exits 0

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Whether the member's earlier run is complete and of the same case; its times from kDone
// ("run_s X cpu_s Y") into `out`.
bool finished_before(const Member& m, const fs::path& dir, MemberOutcome& out) {
  if (!fs::exists(dir / kDone) || slurp(dir / "case.toml") != io::to_toml(m.config)) return false;
  std::istringstream in(slurp(dir / kDone));
  std::string word;
  double seconds = 0.0;
  while (in >> word >> seconds) {
    if (word == "run_s") out.run_s = seconds;
    if (word == "cpu_s") out.cpu_s = seconds;
  }
  return true;
}

// A rough cost of a member, for the study's ETA: steps times the cells of its finest grid
// (a quarter of them when adaptive) plus the membrane nodes.
double weight(const Member& m) {
  const auto& c = m.config;
  double cells = std::ldexp(1.0, c.dimension * c.adapt.max_level);
  for (int d = 0; d < c.dimension; ++d) cells *= c.domain.roots[d];
  if (c.adapt.enabled) cells *= 0.25;
  double nodes = 0.0;
  for (const auto& cap : c.capsules) nodes += cap.nodes;
  return (c.time.t_end / c.time.dt) * (cells + 20.0 * nodes);
}

// The time the member's diagnostics.csv has reached (its last row), 0 before any row.
double reached(const fs::path& dir) {
  std::ifstream in(dir / "diagnostics.csv", std::ios::ate);
  if (!in) return 0.0;
  const std::streamoff size = in.tellg();
  in.seekg(std::max<std::streamoff>(0, size - 4096));
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  const std::size_t comma = last.find(',');
  if (comma == std::string::npos) return 0.0;
  return std::strtod(last.c_str() + comma + 1, nullptr);  // the second column, t
}

std::string last_line(const fs::path& log) {
  std::istringstream in(slurp(log));
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty() && line.find_first_not_of(" \r") != std::string::npos) last = line;
  const std::size_t cr = last.rfind('\r');
  if (cr != std::string::npos) last = last.substr(cr + 1);
  constexpr std::string_view prefix = "capsflow: ";  // the member's own report
  return last.starts_with(prefix) ? last.substr(prefix.size()) : last;
}

pid_t launch(const RunnerOptions& o, const Member& m, const fs::path& dir) {
  std::vector<std::string> args{o.executable.string(), "run", m.config_file.string(), "--quiet", "--force",
                                "--out", dir.string()};
  for (const std::string& s : m.overrides) {
    args.emplace_back("--set");
    args.push_back(s);
  }
  SpawnOptions spawn_options{.output = dir / "run.log", .env_defaults = {}};
  // Members side by side share the cores, unless the user said otherwise.
  if (o.jobs > 1) {
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency() / static_cast<unsigned>(o.jobs));
    spawn_options.env_defaults.emplace_back("OMP_NUM_THREADS", std::to_string(threads));
  }
  return spawn(std::move(args), spawn_options);
}

class Runner {
 public:
  Runner(const std::vector<Member>& members, const RunnerOptions& o)
      : members_(members), o_(o), outcomes_(members.size()), progress_(o.quiet), start_(Clock::now()) {}

  std::vector<MemberOutcome> run() {
    std::vector<std::size_t> pending;
    for (std::size_t i = 0; i < members_.size(); ++i) {
      MemberOutcome before{.state = MemberState::skipped};
      if (!o_.rerun && finished_before(members_[i], member_dir(o_, members_[i]), before)) outcomes_[i] = before;
      else {
        pending.push_back(i);
        total_weight_ += weight(members_[i]);
      }
    }
    std::size_t next = 0;
    while (next < pending.size() || !running_.empty()) {
      while (interrupt_signal() == 0 && next < pending.size() && static_cast<int>(running_.size()) < o_.jobs)
        start(pending[next++]);
      if (interrupt_signal() != 0) {
        if (!forwarded_)
          for (const Running& r : running_) kill(r.pid, interrupt_signal());
        forwarded_ = true;
        if (running_.empty()) break;  // the members not started stay not_run
      }
      reap();
      show(false);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    show(true);
    progress_.finish();
    return outcomes_;
  }

 private:
  struct Running {
    std::size_t index;
    pid_t pid;
    Clock::time_point start;
  };

  void start(std::size_t i) {
    const fs::path dir = member_dir(o_, members_[i]);
    std::error_code ec;
    // The folder is the study's: what an unfinished or older run left (checkpoints, snapshots) goes.
    fs::remove_all(dir, ec);
    if (!ec) fs::create_directories(dir, ec);
    const pid_t pid = ec ? -1 : launch(o_, members_[i], dir);
    if (pid < 0) {
      outcomes_[i] = {.state = MemberState::failed, .exit_status = -1,
                      .message = ec ? fmt::format("{}: {}", dir.string(), ec.message()) : "fork failed"};
      progress_.finish();
      std::fprintf(stderr, "capsflow: study member %s not started: %s\n", members_[i].name.c_str(),
                   outcomes_[i].message.c_str());
      return;
    }
    running_.push_back({i, pid, Clock::now()});
  }

  void reap() {
    for (auto it = running_.begin(); it != running_.end();) {
      int raw = 0;
      rusage usage{};
      if (wait4(it->pid, &raw, WNOHANG, &usage) != it->pid) {
        ++it;
        continue;
      }
      const Member& m = members_[it->index];
      const fs::path dir = member_dir(o_, m);
      MemberOutcome& out = outcomes_[it->index];
      out.run_s = std::chrono::duration<double>(Clock::now() - it->start).count();
      out.cpu_s = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                  1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
      out.exit_status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
      if (out.exit_status == 0) {
        out.state = MemberState::ran;
        io::atomic_write_text(dir / kDone, fmt::format("run_s {}\ncpu_s {}\n", out.run_s, out.cpu_s));
      } else {
        out.state = out.exit_status == 130 || out.exit_status == 143 ? MemberState::interrupted : MemberState::failed;
        out.message = last_line(dir / "run.log");
        if (out.state == MemberState::failed) {
          progress_.finish();
          std::fprintf(stderr, "capsflow: study member %s failed (exit status %d): %s (log: %s)\n", m.name.c_str(),
                       out.exit_status, out.message.c_str(), (dir / "run.log").c_str());
        }
      }
      done_weight_ += weight(m);
      ++finished_;
      it = running_.erase(it);
    }
  }

  void show(bool force) {
    double progress_weight = done_weight_;
    std::string now;
    for (const Running& r : running_) {
      const Member& m = members_[r.index];
      const double t = reached(member_dir(o_, m)), t_end = m.config.time.t_end;
      progress_weight += weight(m) * std::min(1.0, t / t_end);
      now += fmt::format("{}member {}/{} {} t {:.4g}/{:.4g}", now.empty() ? "" : "; ", r.index + 1, members_.size(),
                         m.name, t, t_end);
    }
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    const double fraction = total_weight_ > 0 ? progress_weight / total_weight_ : 1.0;
    const std::string eta = fraction > 1e-3 ? hms(elapsed * (1 - fraction) / fraction) : "?";
    std::size_t skipped = 0, failed = 0;
    for (const MemberOutcome& o : outcomes_) {
      skipped += o.state == MemberState::skipped;
      failed += o.state == MemberState::failed;
    }
    progress_.show(fmt::format("study: {}{}{} of {} members done, {} skipped, {} failed  {:.0f}%  elapsed {}  ETA {}",
                               now, now.empty() ? "" : "  |  ", finished_, members_.size() - skipped, skipped, failed,
                               100 * fraction, hms(elapsed), eta),
                   force);
  }

  const std::vector<Member>& members_;
  const RunnerOptions& o_;
  std::vector<MemberOutcome> outcomes_;
  std::vector<Running> running_;
  ProgressLine progress_;
  Clock::time_point start_;
  double total_weight_ = 0.0, done_weight_ = 0.0;
  std::size_t finished_ = 0;
  bool forwarded_ = false;
};

}  // namespace

fs::path member_dir(const RunnerOptions& o, const Member& m) { return o.members_dir / m.name; }

std::vector<MemberOutcome> run_members(const std::vector<Member>& members, const RunnerOptions& o) {
  return Runner(members, o).run();
}

}  // namespace capsflow::app::study
