#include "app/study/plots.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "app/study/spawn.hpp"

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
    return run_to_end({p, "-c", "import numpy, matplotlib"}, {.output = "/dev/null", .env_defaults = {}}) == 0;
  });
  if (python == pythons.end()) {
    std::fprintf(stderr, "capsflow: warning: python3 with numpy and matplotlib is needed for the plots (or set "
                         "CAPSFLOW_PYTHON); no plots, the CSV files are in %s\n", dir.c_str());
    return false;
  }
  if (run_to_end({*python, script.string(), dir.string()}) != 0) {
    std::fprintf(stderr, "capsflow: warning: %s failed; the CSV files are in %s\n", script.c_str(), dir.c_str());
    return false;
  }
  return true;
}

}  // namespace capsflow::app::study
