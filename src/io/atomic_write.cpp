#include "io/atomic_write.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <stdexcept>
#include <system_error>

namespace capsflow::io {

// Hidden, unique per process and call, so concurrent writers never share a temporary and a
// directory listing (or a ParaView file dialog) does not show half-written files.
std::filesystem::path temporary_path_for(const std::filesystem::path& target) {
  static std::atomic<unsigned> counter{0};
  const std::string name = fmt::format(".{}.tmp.{}.{}", target.filename().string(),
                                       static_cast<long>(::getpid()), counter++);
  return target.parent_path() / name;
}

void commit_temporary(const std::filesystem::path& tmp, const std::filesystem::path& target) {
  std::error_code ec;
  if (!std::filesystem::exists(tmp, ec))
    throw std::runtime_error(fmt::format("{}: the writer produced no file", target.string()));
  std::filesystem::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw std::runtime_error(fmt::format("{}: cannot rename the temporary file into place: {}",
                                         target.string(), ec.message()));
  }
}

void atomic_write(const std::filesystem::path& target,
                  const std::function<void(const std::filesystem::path&)>& write) {
  const std::filesystem::path tmp = temporary_path_for(target);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw;
  }
  commit_temporary(tmp, target);
}

void atomic_write_text(const std::filesystem::path& target, std::string_view content) {
  atomic_write(target, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot open for writing", target.string()));
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.close();
    if (!out) throw std::runtime_error(fmt::format("{}: write failed", target.string()));
  });
}

}  // namespace capsflow::io
