#include "io/csv_table.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace capsflow::io {

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out(1);
  for (const char c : line) {
    if (c == ',') out.emplace_back();
    else if (c != '\r') out.back() += c;
  }
  return out;
}

}  // namespace

std::size_t CsvTable::column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return i;
  throw std::runtime_error(fmt::format("no column {}", name));
}

CsvTable read_csv_table(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read", path.string()));
  CsvTable t;
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}: empty, no header", path.string()));
  t.columns = split(line);
  for (long number = 2; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    const std::vector<std::string> cells = split(line);
    if (cells.size() != t.columns.size())
      throw std::runtime_error(fmt::format("{}: line {} has {} entries, the header {}", path.string(), number,
                                           cells.size(), t.columns.size()));
    std::vector<double> row;
    for (const std::string& c : cells) {
      char* end = nullptr;
      const double v = std::strtod(c.c_str(), &end);
      if (c.empty() || *end != '\0')
        throw std::runtime_error(fmt::format("{}: line {}: \"{}\" is not a number", path.string(), number, c));
      row.push_back(v);
    }
    t.rows.push_back(std::move(row));
  }
  return t;
}

}  // namespace capsflow::io
