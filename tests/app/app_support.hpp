#pragma once
// Running the capsflow binary from tests: exit status, stderr, a scratch directory.
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace capsflow::app::testing {

namespace fs = std::filesystem;

struct Result {
  int status = -1;
  std::string err;
};

inline fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("capsflow_app_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Lines in a captured stderr (each ends in a newline).
inline long lines(const std::string& s) { return std::count(s.begin(), s.end(), '\n'); }

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs `capsflow ARGS` with one OpenMP thread; stdout is discarded.
inline Result capsflow(const std::string& args, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "OMP_NUM_THREADS=1 " + std::string(CAPSFLOW_BINARY) + " " + args + " > /dev/null 2> " + err.string();
  const int raw = std::system(cmd.c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(err)};
}

inline fs::path write(const fs::path& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

}  // namespace capsflow::app::testing
