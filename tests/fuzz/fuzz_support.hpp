#pragma once
// Shared by the fuzz tests: how many inputs (CAPSFLOW_FUZZ_SCALE multiplies the default
// counts; the `fuzz` CTest label runs with a large scale), the seed (CAPSFLOW_FUZZ_SEED),
// a tally of outcomes for the closing summary, and running the capsflow binary with a
// time limit on argument vectors (random bytes need no shell quoting).
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace capsflow::fuzz {

namespace fs = std::filesystem;

inline std::size_t scaled(std::size_t n) {
  const char* s = std::getenv("CAPSFLOW_FUZZ_SCALE");
  const long k = s ? std::atol(s) : 1;
  return n * static_cast<std::size_t>(k > 0 ? k : 1);
}

inline std::uint64_t seed(std::uint64_t fallback) {
  const char* s = std::getenv("CAPSFLOW_FUZZ_SEED");
  return s ? std::strtoull(s, nullptr, 10) : fallback;
}

// What the inputs led to: counts, the distinct error messages (and their reasons: the text
// after the last ": ", which drops file names and values), the findings.
struct Tally {
  std::size_t inputs = 0, accepted = 0, rejected = 0;
  std::set<std::string> messages, reasons;
  std::vector<std::string> findings;

  void reject(const std::string& message) {
    ++rejected;
    messages.insert(message);
    const std::size_t at = message.rfind(": ");
    reasons.insert(at == std::string::npos ? message : message.substr(at + 2));
  }
  void print(const char* what) const {
    std::printf("[fuzz] %s: %zu inputs, %zu accepted, %zu rejected with %zu distinct messages (%zu distinct "
                "reasons), %zu findings\n",
                what, inputs, accepted, rejected, messages.size(), reasons.size(), findings.size());
  }
};

inline fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("capsflow_fuzz_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Exit {
  int status = -1;   // exit status, or -1
  int signal = 0;    // the signal that ended it, or 0
  bool timed_out = false;
  std::string err;
};

// Runs CAPSFLOW_BINARY with `args`, stdout to /dev/null, stderr captured; kills it after
// `limit`. `memory` > 0 caps its address space (bytes), so an accepted input that asks for
// a huge tree fails inside the child instead of swapping the machine.
inline Exit run_capsflow(const std::vector<std::string>& args, const fs::path& dir,
                         std::chrono::seconds limit = std::chrono::seconds(30), rlim_t memory = 0) {
  const fs::path err = dir / "stderr.txt";
  std::fflush(nullptr);  // the child must not print our buffered output again
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (memory > 0) {
      const rlimit cap{memory, memory};
      ::setrlimit(RLIMIT_AS, &cap);
    }
    std::FILE* e = std::freopen(err.c_str(), "w", stderr);
    std::FILE* o = std::freopen("/dev/null", "w", stdout);
    (void)e;
    (void)o;
    std::vector<char*> argv{const_cast<char*>(CAPSFLOW_BINARY)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(CAPSFLOW_BINARY, argv.data());
    ::_exit(127);
  }
  Exit r;
  const auto start = std::chrono::steady_clock::now();
  int raw = 0;
  while (::waitpid(pid, &raw, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - start > limit) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &raw, 0);
      r.timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (WIFEXITED(raw)) r.status = WEXITSTATUS(raw);
  if (WIFSIGNALED(raw)) r.signal = WTERMSIG(raw);
  r.err = slurp(err);
  return r;
}

// "" when the run refused its input as promised (exit 2, one line on stderr), else what
// went wrong.
inline std::string refusal_problem(const Exit& r) {
  if (r.timed_out) return "timed out";
  if (r.signal) return "killed by signal " + std::to_string(r.signal);
  if (r.status != 2) return "exit status " + std::to_string(r.status) + ": " + r.err;
  std::size_t lines = 0;
  for (const char c : r.err) lines += c == '\n';
  if (lines != 1 || r.err.back() != '\n') return "stderr is not one line: " + r.err;
  return "";
}

}  // namespace capsflow::fuzz
