#pragma once
// diagnostics.csv: a header row, then one row per call, flushed at once so a killed run
// keeps every row it computed. Numbers are written with the shortest digits that read back
// to the same double (integers such as step and cells appear without a decimal point), so
// a restarted run can be compared with an uninterrupted one to the last digit.
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace capsflow::io {

// The columns DESIGN.md promises users and scripts ("What the user sees"), in order; a run
// may append more after them.
[[nodiscard]] inline std::vector<std::string> standard_diagnostics_columns() {
  return {"step", "t", "dt", "cells", "max_level", "D12", "D12_bbox", "area_rel", "volume_rel",
          "vmax", "mg_cycles", "wall_s"};
}

class DiagnosticsCsv {
 public:
  // Creates (or truncates) the file and writes the header. Throws std::invalid_argument for
  // an empty column list or a column name with a comma, quote or newline, and
  // std::runtime_error naming the file if it cannot be opened.
  DiagnosticsCsv(std::filesystem::path path, std::vector<std::string> columns);

  // Continues a file written by an earlier run: its header must equal `columns`; rows
  // whose first column (the step) is greater than `last_step` are dropped (they were
  // written after the checkpoint the run restarts from); new rows are appended.
  [[nodiscard]] static DiagnosticsCsv resume(std::filesystem::path path, std::vector<std::string> columns,
                                             double last_step);

  // One row; throws std::invalid_argument if the count differs from the columns.
  void row(std::span<const double> values);
  void row(std::initializer_list<double> values) { row(std::span<const double>(values.begin(), values.size())); }

  [[nodiscard]] const std::vector<std::string>& columns() const { return columns_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  DiagnosticsCsv(std::filesystem::path path, std::vector<std::string> columns, std::FILE* file);
  static std::string header(const std::vector<std::string>& columns);

  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::unique_ptr<std::FILE, Closer> file_;
  std::string line_;  // reused buffer
};

// membrane_final.csv: "id,x,y,z" then one row per node (positions: 3 per node), with the
// same round-trip digits, written atomically.
void write_nodes_csv(const std::filesystem::path& path, std::span<const double> positions);

}  // namespace capsflow::io
