#include "io/diagnostics_csv.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "io/atomic_write.hpp"

namespace capsflow::io {

namespace {

std::FILE* open_or_throw(const std::filesystem::path& path, const char* mode) {
  std::FILE* f = std::fopen(path.c_str(), mode);
  if (!f) throw std::runtime_error(fmt::format("{}: cannot open: {}", path.string(), std::strerror(errno)));
  return f;
}

}  // namespace

std::string DiagnosticsCsv::header(const std::vector<std::string>& columns) {
  if (columns.empty()) throw std::invalid_argument("DiagnosticsCsv: no columns");
  std::string h;
  for (const std::string& c : columns) {
    if (c.empty() || c.find_first_of(",\"\n\r") != std::string::npos)
      throw std::invalid_argument(fmt::format("DiagnosticsCsv: bad column name \"{}\"", c));
    h += (h.empty() ? "" : ",") + c;
  }
  return h;
}

DiagnosticsCsv::DiagnosticsCsv(std::filesystem::path path, std::vector<std::string> columns, std::FILE* file)
    : path_(std::move(path)), columns_(std::move(columns)), file_(file) {}

DiagnosticsCsv::DiagnosticsCsv(std::filesystem::path path, std::vector<std::string> columns)
    : path_(std::move(path)), columns_(std::move(columns)) {
  const std::string h = header(columns_);
  file_.reset(open_or_throw(path_, "w"));
  std::fputs((h + "\n").c_str(), file_.get());
  std::fflush(file_.get());
}

DiagnosticsCsv DiagnosticsCsv::resume(std::filesystem::path path, std::vector<std::string> columns,
                                      double last_step) {
  const std::string h = header(columns);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read the diagnostics to resume", path.string()));
  std::string line, kept;
  if (!std::getline(in, line) || line != h)
    throw std::runtime_error(fmt::format("{}: header \"{}\" differs from \"{}\"", path.string(), line, h));
  kept = h + "\n";
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    double step = 0.0;
    try {
      step = std::stod(line.substr(0, line.find(',')));
    } catch (const std::exception&) {
      throw std::runtime_error(fmt::format("{}: bad row \"{}\"", path.string(), line));
    }
    if (step <= last_step) kept += line + "\n";
  }
  in.close();
  atomic_write_text(path, kept);
  return DiagnosticsCsv(std::move(path), std::move(columns), open_or_throw(path, "a"));
}

void DiagnosticsCsv::row(std::span<const double> values) {
  if (values.size() != columns_.size())
    throw std::invalid_argument(fmt::format("{}: a row of {} values for {} columns", path_.string(),
                                            values.size(), columns_.size()));
  line_.clear();
  for (std::size_t i = 0; i < values.size(); ++i) fmt::format_to(std::back_inserter(line_), "{}{}", i ? "," : "", values[i]);
  line_ += '\n';
  if (std::fputs(line_.c_str(), file_.get()) < 0 || std::fflush(file_.get()) != 0)
    throw std::runtime_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(errno)));
}

void write_nodes_csv(const std::filesystem::path& path, std::span<const double> positions) {
  if (positions.size() % 3 != 0)
    throw std::invalid_argument(fmt::format("write_nodes_csv: {} coordinates is not 3 per node", positions.size()));
  std::string text = "id,x,y,z\n";
  for (std::size_t i = 0; i < positions.size() / 3; ++i)
    fmt::format_to(std::back_inserter(text), "{},{},{},{}\n", i, positions[3 * i], positions[3 * i + 1],
                   positions[3 * i + 2]);
  atomic_write_text(path, text);
}

}  // namespace capsflow::io
