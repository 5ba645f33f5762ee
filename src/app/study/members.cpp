#include "app/study/members.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <ranges>

namespace capsflow::app::study {

namespace {

// A value as it reads in a name: strings without their quotes.
std::string shown(const std::string& toml_text) {
  if (toml_text.size() >= 2 && toml_text.front() == '"' && toml_text.back() == '"')
    return toml_text.substr(1, toml_text.size() - 2);
  return toml_text;
}

double as_number(const std::string& toml_text) {
  if (toml_text == "true") return 1.0;
  if (toml_text == "false") return 0.0;
  char* end = nullptr;
  const double v = std::strtod(toml_text.c_str(), &end);
  return end != toml_text.c_str() && *end == '\0' ? v : std::nan("");
}

bool smaller_is_finer(const std::string& label) {
  for (const char* k : {"dt", "dt_max", "cfl", "tolerance", "velocity_tolerance", "velocity_tolerance_relative"})
    if (label == k) return true;
  return false;
}

[[noreturn]] void fail(const io::StudyConfig& s, const std::string& what) {
  throw io::CaseError(fmt::format("{}: {}", s.file.string(), what));
}

// Every combination of one ladder's values, the first key varying slowest.
void combine(const io::StudyLadder& ladder, const std::vector<std::string>& order,
             std::vector<std::vector<std::pair<std::string, std::string>>>& out) {
  std::vector<std::vector<std::pair<std::string, std::string>>> combos{{}};
  for (const std::string& key : order) {
    const auto axis = std::find_if(ladder.axes.begin(), ladder.axes.end(), [&](const auto& a) { return a.first == key; });
    std::vector<std::vector<std::pair<std::string, std::string>>> next;
    for (const auto& c : combos)
      for (const std::string& v : axis->second) {
        next.push_back(c);
        next.back().emplace_back(key, v);
      }
    combos = std::move(next);
  }
  out.insert(out.end(), combos.begin(), combos.end());
}

void assign_references(const io::StudyConfig& s, std::vector<Member>& members) {
  if (s.reference != "finest") {
    const auto it = std::find_if(members.begin(), members.end(), [&](const Member& m) { return m.name == s.reference; });
    if (it == members.end()) fail(s, fmt::format("reference = \"{}\": no member has that name", s.reference));
    for (Member& m : members) m.reference = static_cast<std::size_t>(it - members.begin());
    return;
  }
  std::map<std::string, std::size_t> finest;  // series -> member with the smallest h
  for (std::size_t i = 0; i < members.size(); ++i) {
    const auto [it, fresh] = finest.emplace(members[i].series, i);
    if (!fresh && members[i].h < members[it->second].h) it->second = i;
  }
  for (Member& m : members) m.reference = finest[m.series];
}

}  // namespace

std::string key_label(const std::string& key) {
  std::vector<std::string> parts{""};
  for (const char c : key) {
    if (c == '.') parts.emplace_back();
    else parts.back() += c;
  }
  for (std::string& p : parts) p = p.substr(0, p.find('['));
  if (parts.back() == "enabled" && parts.size() > 1) return parts[parts.size() - 2];
  return parts.back();
}

double spacing(const std::string& key, double x) {
  const std::string label = key_label(key);
  if (smaller_is_finer(label)) return x;
  if (label == "max_level") return std::ldexp(1.0, -static_cast<int>(std::lround(x)));
  if (label == "nodes") return 1.0 / std::sqrt(x);
  return 1.0 / x;
}

std::vector<Member> expand_members(const io::StudyConfig& s) {
  std::vector<std::string> order;
  for (const auto& [key, values] : s.ladders.front().axes) order.push_back(key);
  std::vector<std::vector<std::pair<std::string, std::string>>> combos;
  for (const io::StudyLadder& l : s.ladders) combine(l, order, combos);

  std::vector<Member> members;
  for (const auto& values : combos) {
    Member m;
    m.values = values;
    m.config_file = s.base;
    m.overrides = s.set;
    std::vector<std::string> name_parts, series_parts;
    for (const auto& [key, v] : values) {
      m.overrides.push_back(key + "=" + v);
      // Two keys with the same last segment keep their full names.
      const bool clash = std::count_if(order.begin(), order.end(), [&](const std::string& k) {
                           return key_label(k) == key_label(key);
                         }) > 1;
      const std::string part = (clash ? key : key_label(key)) + "=" + shown(v);
      name_parts.push_back(part);
      if (key == s.x) m.x = as_number(v);
      else series_parts.push_back(part);
    }
    m.name = fmt::format("{}", fmt::join(name_parts, "+"));
    m.series = fmt::format("{}", fmt::join(series_parts, "+"));
    if (!std::isfinite(m.x)) fail(s, fmt::format("member {}: x = \"{}\" must take numbers", m.name, s.x));
    m.h = spacing(s.x, m.x);
    if (std::any_of(members.begin(), members.end(), [&](const Member& o) { return o.name == m.name; }))
      fail(s, fmt::format("member {} appears twice in the ladders", m.name));
    try {
      m.config = io::parse_case(s.base, m.overrides);
    } catch (const io::CaseError& e) {
      fail(s, fmt::format("member {}: {}", m.name, e.what()));
    }
    for (const double t : s.d12_times)
      if (t > m.config.time.t_end * (1 + 1e-12))
        fail(s, fmt::format("d12_times: {} is after member {}'s t_end = {}", t, m.name, m.config.time.t_end));
    members.push_back(std::move(m));
  }
  for (const std::string& p : s.plot_members)
    if (std::none_of(members.begin(), members.end(), [&](const Member& m) { return m.name == p; }))
      fail(s, fmt::format("plot_members: \"{}\" is not a member (members: {})", p,
                          fmt::join(members | std::views::transform(&Member::name), ", ")));
  assign_references(s, members);
  return members;
}

}  // namespace capsflow::app::study
