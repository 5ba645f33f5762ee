#include "app/study/plots.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace capsflow::app::study {

namespace {

namespace fs = std::filesystem;

// The script next to this binary's sources: CAPSFLOW_TOOLS_DIR in the environment, then the
// build tree (build/src/app/capsflow -> tools/), an installed share/capsflow/tools, then the
// source tree this binary was built from.
fs::path find_script(const fs::path& executable) {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("CAPSFLOW_TOOLS_DIR")) dirs.emplace_back(env);
  const fs::path bin = executable.parent_path();
  dirs.push_back(bin / ".." / ".." / ".." / "tools");
  dirs.push_back(bin / ".." / "share" / "capsflow" / "tools");
  dirs.emplace_back(CAPSFLOW_TOOLS_DIR);
  for (const fs::path& d : dirs) {
    std::error_code ec;
    if (fs::is_regular_file(d / "plot_study.py", ec)) return fs::weakly_canonical(d / "plot_study.py", ec);
  }
  return {};
}

// Exit status of a command (no shell), its stdout and stderr kept or sent to /dev/null.
int run(std::vector<std::string> args, bool silent) {
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    if (silent) {
      if (std::FILE* null = std::fopen("/dev/null", "w")) {
        dup2(fileno(null), STDOUT_FILENO);
        dup2(fileno(null), STDERR_FILENO);
      }
    }
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  int raw = 0;
  while (waitpid(pid, &raw, 0) < 0) {
  }
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

}  // namespace

bool make_plots(const fs::path& dir, const fs::path& executable) {
  const fs::path script = find_script(executable);
  if (script.empty()) {
    std::fprintf(stderr, "capsflow: warning: tools/plot_study.py not found (set CAPSFLOW_TOOLS_DIR); no plots, the "
                         "CSV files are in %s\n", dir.c_str());
    return false;
  }
  // CAPSFLOW_PYTHON, else the first python3 that has numpy and matplotlib: the one on PATH
  // (a pyenv shim, say) may lack them where the system's has them.
  std::vector<std::string> pythons{"python3", "/usr/bin/python3"};
  if (const char* env = std::getenv("CAPSFLOW_PYTHON")) pythons = {env};
  const auto python = std::find_if(pythons.begin(), pythons.end(), [](const std::string& p) {
    return run({p, "-c", "import numpy, matplotlib"}, true) == 0;
  });
  if (python == pythons.end()) {
    std::fprintf(stderr, "capsflow: warning: python3 with numpy and matplotlib is needed for the plots (or set "
                         "CAPSFLOW_PYTHON); no plots, the CSV files are in %s\n", dir.c_str());
    return false;
  }
  if (run({*python, script.string(), dir.string()}, false) != 0) {
    std::fprintf(stderr, "capsflow: warning: %s failed; the CSV files are in %s\n", script.c_str(), dir.c_str());
    return false;
  }
  return true;
}

}  // namespace capsflow::app::study
