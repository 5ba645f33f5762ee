#pragma once
// Reading back the numeric CSV files a run writes (diagnostics.csv, membrane_final.csv):
// a header row of names, then rows of numbers ("nan" and "inf" included).
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace capsflow::io {

struct CsvTable {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;  // each with columns.size() entries

  // The index of a column; throws std::runtime_error naming it when absent.
  [[nodiscard]] std::size_t column(std::string_view name) const;
};

// Throws std::runtime_error naming the file and the line for a missing file, a row with the
// wrong number of entries or an entry that is not a number.
[[nodiscard]] CsvTable read_csv_table(const std::filesystem::path& path);

}  // namespace capsflow::io
