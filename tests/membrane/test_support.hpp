#pragma once
// Helpers shared by the membrane tests: reference CSV reading, observed convergence orders,
// random rigid motions.
#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace capsflow::membrane::test {

// A CSV with '#' comment lines and one header row; columns by name.
class ReferenceTable {
 public:
  explicit ReferenceTable(const std::string& file) {
    const std::string path = std::string(CAPSFLOW_REFERENCE_DIR) + "/" + file;
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open reference file " + path);
    std::string line;
    std::vector<std::string> names;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::stringstream row(line);
      std::string cell;
      if (names.empty()) {
        while (std::getline(row, cell, ',')) names.push_back(cell);
        continue;
      }
      for (std::size_t k = 0; std::getline(row, cell, ','); ++k) columns_[names.at(k)].push_back(std::stod(cell));
    }
  }
  [[nodiscard]] const std::vector<double>& column(const std::string& name) const { return columns_.at(name); }
  [[nodiscard]] std::size_t rows() const { return columns_.begin()->second.size(); }
  // Row whose `key` column equals value (to 1e-12).
  [[nodiscard]] std::size_t row_of(const std::string& key, double value) const {
    const auto& c = column(key);
    for (std::size_t i = 0; i < c.size(); ++i)
      if (std::abs(c[i] - value) < 1e-12) return i;
    throw std::runtime_error("no row with " + key + " = " + std::to_string(value));
  }

 private:
  std::map<std::string, std::vector<double>> columns_;
};

// Observed order between two meshes whose sizes differ by a factor 2.
[[nodiscard]] inline double observed_order(double coarse_error, double fine_error) {
  return std::log2(coarse_error / fine_error);
}

[[nodiscard]] inline Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

}  // namespace capsflow::membrane::test
