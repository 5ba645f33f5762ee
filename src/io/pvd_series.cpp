#include "io/pvd_series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "io/atomic_write.hpp"

namespace capsflow::io {

namespace {

std::string xml_escape(std::string_view s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string xml_unescape(std::string_view s) {
  std::string out(s);
  for (const auto& [from, to] : {std::pair{"&lt;", "<"}, {"&gt;", ">"}, {"&quot;", "\""},
                                 {"&apos;", "'"}, {"&amp;", "&"}}) {
    std::string::size_type at = 0;
    const std::string f = from;
    while ((at = out.find(f, at)) != std::string::npos) {
      out.replace(at, f.size(), to);
      at += 1;
    }
  }
  return out;
}

// The value of attribute `name` in one <DataSet .../> line, or nullopt.
bool attribute(const std::string& line, std::string_view name, std::string& value) {
  const std::string key = fmt::format(" {}=\"", name);
  const std::size_t at = line.find(key);
  if (at == std::string::npos) return false;
  const std::size_t begin = at + key.size();
  const std::size_t end = line.find('"', begin);
  if (end == std::string::npos) return false;
  value = xml_unescape(std::string_view(line).substr(begin, end - begin));
  return true;
}

}  // namespace

PvdSeries PvdSeries::load(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read the series", path.string()));
  PvdSeries series(path);
  bool collection = false;
  std::string line;
  while (std::getline(in, line)) {
    if (line.find("<Collection>") != std::string::npos) collection = true;
    if (line.find("<DataSet ") == std::string::npos) continue;
    std::string time, part, file;
    if (!attribute(line, "timestep", time) || !attribute(line, "file", file))
      throw std::runtime_error(fmt::format("{}: a DataSet without timestep or file", path.string()));
    PvdEntry e{.file = file};
    try {
      e.time = std::stod(time);
      e.part = attribute(line, "part", part) ? std::stoi(part) : 0;
    } catch (const std::exception&) {
      throw std::runtime_error(fmt::format("{}: bad number in \"{}\"", path.string(), line));
    }
    series.entries_.push_back(std::move(e));
  }
  if (!collection) throw std::runtime_error(fmt::format("{}: not a .pvd collection", path.string()));
  // Older series named files relative to the run's working directory; ParaView resolves
  // against the .pvd's folder, where the snapshots are.
  const std::filesystem::path folder = path.parent_path();
  for (PvdEntry& e : series.entries_) {
    const std::filesystem::path file(e.file);
    std::error_code ec;
    if (file.is_absolute() || std::filesystem::exists(folder / file, ec)) continue;
    if (std::filesystem::exists(folder / file.filename(), ec)) e.file = file.filename().generic_string();
  }
  return series;
}

void PvdSeries::add(double time, const std::filesystem::path& file, int part) {
  std::filesystem::path rel = file;
  if (rel.is_absolute())
    rel = std::filesystem::proximate(file, std::filesystem::absolute(path_).parent_path());
  entries_.push_back({.time = time, .part = part, .file = rel.generic_string()});
  rewrite();
}

void PvdSeries::truncate_after(double time) {
  std::erase_if(entries_, [&](const PvdEntry& e) { return e.time > time; });
  rewrite();
}

void PvdSeries::rewrite() const {
  std::string xml =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
      "  <Collection>\n";
  for (const PvdEntry& e : entries_)  // shortest round-trip digits: times read back exactly
    xml += fmt::format("    <DataSet timestep=\"{}\" group=\"\" part=\"{}\" file=\"{}\"/>\n", e.time,
                       e.part, xml_escape(e.file));
  xml += "  </Collection>\n</VTKFile>\n";
  atomic_write_text(path_, xml);
}

}  // namespace capsflow::io
