#include "app/output_dir.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>

#include <fmt/format.h>

namespace capsflow::app {

namespace {

namespace fs = std::filesystem;

// The first file in `dir` that a run writes and a user would miss if it were overwritten.
std::optional<std::string> run_marker(const fs::path& dir) {
  std::error_code ec;
  for (const char* name : {"diagnostics.csv", "case.toml", "series.pvd"})
    if (fs::exists(dir / name, ec)) return name;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with("checkpoint_") && it->path().extension() == ".h5") return name;
  }
  return std::nullopt;
}

bool same_folder(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  return fs::equivalent(a.empty() ? fs::path(".") : a, b.empty() ? fs::path(".") : b, ec) && !ec;
}

}  // namespace

bool continues_in_place(const fs::path& out, const std::optional<fs::path>& restart) {
  return restart && same_folder(restart->parent_path(), out);
}

bool prepare_output_dir(const fs::path& out, bool force, const std::optional<fs::path>& restart) {
  const std::string name = out.string();
  std::error_code ec;
  const fs::file_status status = fs::status(out, ec);
  if (fs::exists(status) && !fs::is_directory(status))
    throw RequestError(fmt::format("{}: --out is not a folder (it is a file)", name));
  if (fs::is_directory(status) && !force) {
    const auto marker = run_marker(out);
    if (marker && !continues_in_place(out, restart))
      throw RequestError(
          fmt::format("{}: holds another run ({}); choose another --out, or add --force to write over it",
                      name, *marker));
  }
  const bool created = fs::create_directories(out, ec);
  if (ec) throw RequestError(fmt::format("{}: cannot create the output folder: {}", name, ec.message()));
  // Permissions, read-only mounts and full quotas show only when writing: try it now rather
  // than after the grid is built.
  const fs::path probe = out / fmt::format(".capsflow_probe.{}", static_cast<long>(::getpid()));
  bool ok = false;
  {
    std::ofstream f(probe, std::ios::binary | std::ios::trunc);
    ok = f && (f << "probe").flush();
  }
  const int error = errno;
  fs::remove(probe, ec);
  if (!ok)
    throw RequestError(fmt::format("{}: cannot write in the output folder: {}", name, std::strerror(error)));
  return created;
}

void remove_if_created_and_empty(const fs::path& out, bool created) {
  std::error_code ec;
  if (created && fs::is_empty(out, ec) && !ec) fs::remove(out, ec);
}

}  // namespace capsflow::app
