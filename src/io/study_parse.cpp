// Study file -> StudyConfig (docs/studies.md). The same strict reading as case files
// (TableReader: every unknown key is an error); what needs the members' cases (a reference
// that names a member, times beyond t_end) is checked when the members are built.
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>

#include "io/study_config.hpp"
#include "io/toml_reader.hpp"

namespace capsflow::io {

namespace {

using detail::CaseSource;
using detail::TableReader;
using detail::toml_number;
using detail::toml_repr;
using detail::toml_string;

// An array whose entries all satisfy `fits` (absent: false; anything else is an error).
template <class Fits>
const toml::array* read_list(TableReader& r, std::string_view key, std::string_view expected, Fits fits) {
  const toml::node* n = r.node(key);
  if (!n) return nullptr;
  const toml::array* a = n->as_array();
  if (!a || a->empty() || !std::all_of(a->begin(), a->end(), fits))
    r.source().fail(r.key_path(key), toml_repr(*n), fmt::format("expected a non-empty array of {}", expected));
  return a;
}

std::vector<std::string> read_strings(TableReader& r, std::string_view key) {
  std::vector<std::string> out;
  if (const toml::array* a = read_list(r, key, "strings", [](const toml::node& e) { return e.is_string(); }))
    for (const toml::node& e : *a) out.push_back(e.as_string()->get());
  return out;
}

std::vector<double> read_numbers(TableReader& r, std::string_view key) {
  std::vector<double> out;
  if (const toml::array* a = read_list(r, key, "numbers", [](const toml::node& e) { return e.is_number(); }))
    for (const toml::node& e : *a) out.push_back(e.value<double>().value_or(0.0));
  return out;
}

// Ladder keys may be written quoted ("time.dt" = [...]) or as TOML dotted keys (time.dt = [...],
// which nest tables): both flatten to the dotted key --set takes.
void flatten(const toml::table& t, const std::string& prefix, const CaseSource& source, StudyLadder& out) {
  for (const auto& [k, v] : t) {
    const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    if (const toml::table* sub = v.as_table()) {
      flatten(*sub, key, source, out);
      continue;
    }
    const toml::array* a = v.as_array();
    if (!a || a->empty() ||
        !std::all_of(a->begin(), a->end(), [](const toml::node& e) { return e.is_value(); }))
      source.fail("ladder." + key, toml_repr(v), "expected a non-empty array of values (one per member)");
    std::vector<std::string> values;
    for (const toml::node& e : *a) {
      std::string s = toml_repr(e);
      if (std::find(values.begin(), values.end(), s) != values.end())
        source.fail("ladder." + key, toml_repr(v), fmt::format("the value {} appears twice", s));
      values.push_back(std::move(s));
    }
    out.axes.emplace_back(key, std::move(values));
  }
}

std::vector<std::string> keys_of(const StudyLadder& l) {
  std::vector<std::string> keys;
  for (const auto& [k, v] : l.axes) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  return keys;
}

bool known_criterion(std::string_view c) {
  return std::any_of(std::begin(kStudyCriteria), std::end(kStudyCriteria), [&](const char* k) { return c == k; });
}

std::vector<std::pair<std::string, double>> read_criteria(TableReader& r, std::string_view key, bool positive) {
  std::vector<std::pair<std::string, double>> out;
  const toml::table* t = r.table(key);
  if (!t) return out;
  for (const auto& [k, v] : *t) {
    const std::string path = r.key_path(key) + "." + std::string(k.str());
    if (!known_criterion(k.str()))
      r.source().fail(path, "unknown criterion (N_inf, vmax, area_rel, volume_rel or D12)");
    const std::optional<double> value = v.value<double>();
    if (!v.is_number() || !value || !std::isfinite(*value) || (positive && *value <= 0.0))
      r.source().fail(path, toml_repr(v), positive ? "expected a number > 0" : "expected a finite number");
    out.emplace_back(std::string(k.str()), *value);
  }
  return out;
}

void read_ratio(TableReader& r, std::string_view key, double& out) {
  if (r.read(key, out) && !(out > 0.0 && std::isfinite(out)))
    r.source().fail(r.key_path(key), toml_number(out), "must be > 0");
}

StudyExpect parse_expect(TableReader r) {
  StudyExpect e;
  e.min_order = read_criteria(r, "min_order", false);
  e.max_value = read_criteria(r, "max_value", true);
  read_ratio(r, "min_cells_ratio", e.min_cells_ratio);
  read_ratio(r, "min_wall_ratio", e.min_wall_ratio);
  r.finish();
  return e;
}

StudyConfig parse_root(const toml::table& root, const CaseSource& source, const std::filesystem::path& path) {
  StudyConfig s;
  s.file = path;
  s.name = path.stem().string();
  TableReader r(root, "", source);
  std::string base;
  if (!r.read("base", base)) r.missing("base", "the case file the members vary, relative to the study file");
  s.base = std::filesystem::path(base).is_absolute() ? std::filesystem::path(base) : path.parent_path() / base;
  r.read("name", s.name);
  if (s.name.empty() || s.name.find('/') != std::string::npos)
    source.fail("name", toml_string(s.name), "must be a non-empty name without '/'");
  s.set = read_strings(r, "set");
  const toml::array* ladders = r.array_of_tables("ladder");
  if (!ladders || ladders->empty()) r.missing("ladder", "at least one [[ladder]] table of values to vary");
  r.read("x", s.x);
  r.read("reference", s.reference);
  r.read("error", s.error);
  s.d12_times = read_numbers(r, "d12_times");
  s.plot_members = read_strings(r, "plot_members");
  const toml::table* expect = r.table("expect");
  r.finish();

  for (std::size_t i = 0; i < ladders->size(); ++i) {
    StudyLadder l;
    flatten(*ladders->get(i)->as_table(), "", source, l);
    if (l.axes.empty()) source.fail(fmt::format("ladder[{}]", i), "is empty: give at least one key = [values]");
    if (!s.ladders.empty() && keys_of(l) != keys_of(s.ladders.front()))
      source.fail(fmt::format("ladder[{}]", i), "must vary the same keys as ladder[0] (every member has a value for each)");
    s.ladders.push_back(std::move(l));
  }
  const auto& axes = s.ladders.front().axes;
  if (s.x.empty()) s.x = axes.front().first;
  if (std::none_of(axes.begin(), axes.end(), [&](const auto& a) { return a.first == s.x; }))
    source.fail("x", toml_string(s.x), "must be one of the ladder's keys");
  if (s.error != "N_inf" && s.error != "D12" && s.error != "vmax")
    source.fail("error", toml_string(s.error), "expected one of \"N_inf\", \"D12\", \"vmax\"");
  for (const double t : s.d12_times)
    if (!(t > 0.0) || !std::isfinite(t)) source.fail("d12_times", toml_number(t), "times must be > 0");
  if (expect) s.expect = parse_expect(TableReader(*expect, "expect", source));
  return s;
}

}  // namespace

StudyConfig parse_study(const std::filesystem::path& path) {
  const CaseSource source{.name = path.string()};
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) source.fail_file("cannot read the study file: it is a directory");
  if (!std::filesystem::exists(path, ec)) source.fail_file("cannot read the study file: no such file");
  toml::table root;
  try {
    root = toml::parse_file(path.string());
  } catch (const toml::parse_error& e) {
    source.fail_file(fmt::format("line {}, column {}: {}", e.source().begin.line, e.source().begin.column,
                                 e.description()));
  }
  return parse_root(root, source, path);
}

}  // namespace capsflow::io
