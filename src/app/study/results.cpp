#include "app/study/results.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "app/study/orders.hpp"
#include "io/atomic_write.hpp"
#include "io/csv_table.hpp"
#include "membrane/diagnostics.hpp"

namespace capsflow::app::study {

namespace {

namespace fs = std::filesystem;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// The value of a diagnostics column at time t, linear between the rows around it; NaN
// outside the rows' span.
double at_time(const io::CsvTable& d, std::size_t t_col, std::size_t col, double t) {
  const auto& rows = d.rows;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double ti = rows[i][t_col];
    if (std::abs(ti - t) <= 1e-9 * std::max(1.0, std::abs(t))) return rows[i][col];
    if (i > 0 && rows[i - 1][t_col] < t && t < ti) {
      const double s = (t - rows[i - 1][t_col]) / (ti - rows[i - 1][t_col]);
      return (1 - s) * rows[i - 1][col] + s * rows[i][col];
    }
  }
  return kNan;
}

MemberResult read_member(const io::StudyConfig& study, const fs::path& dir) {
  MemberResult r;
  const io::CsvTable d = io::read_csv_table(dir / "diagnostics.csv");
  if (d.rows.empty()) throw std::runtime_error(fmt::format("{}: no rows", (dir / "diagnostics.csv").string()));
  const auto& last = d.rows.back();
  auto col = [&](const char* name) { return d.column(name); };
  r.t_end = last[col("t")];
  r.vmax = last[col("vmax")];
  r.area_rel = last[col("area_rel")];
  r.volume_rel = last[col("volume_rel")];
  r.D12 = last[col("D12")];
  r.D12_bbox = last[col("D12_bbox")];
  r.cells_final = last[col("cells")];
  r.steps = last[col("step")];
  r.wall_s = last[col("wall_s")];
  for (const auto& row : d.rows) r.cells_mean += row[col("cells")];
  r.cells_mean /= double(d.rows.size());
  for (const double t : study.d12_times) {
    r.d12_at.push_back(at_time(d, col("t"), col("D12"), t));
    r.d12_bbox_at.push_back(at_time(d, col("t"), col("D12_bbox"), t));
  }
  if (fs::exists(dir / "membrane_final.csv")) {
    const io::CsvTable n = io::read_csv_table(dir / "membrane_final.csv");
    for (const auto& row : n.rows)
      for (const char* c : {"x", "y", "z"}) r.nodes.push_back(row[n.column(c)]);
  }
  r.available = true;
  return r;
}

// N_inf (membrane/diagnostics.hpp) between two members' final nodes; NaN without capsules
// or between different meshes.
double node_error(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.empty() || a.size() != b.size()) return kNan;
  const auto n = static_cast<Eigen::Index>(a.size() / 3);
  return membrane::max_node_distance(Eigen::Map<const Eigen::Matrix3Xd>(a.data(), 3, n),
                                     Eigen::Map<const Eigen::Matrix3Xd>(b.data(), 3, n));
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string num(double v) { return fmt::format("{}", v); }

const char* state_name(MemberState s) {
  switch (s) {
    case MemberState::skipped: return "skipped";
    case MemberState::ran: return "ran";
    case MemberState::failed: return "failed";
    case MemberState::interrupted: return "interrupted";
    case MemberState::not_run: break;
  }
  return "not_run";
}

// Members whose errors are not their own reference's zero (N_inf, D12) or all (the others).
bool in_orders(const std::vector<Member>& members, std::size_t i, const std::string& criterion_name) {
  return (criterion_name != "N_inf" && criterion_name != "D12") || members[i].reference != i;
}

// The error a study compares costs at (its `error` key).
double error_of(const io::StudyConfig& s, const MemberResult& r) {
  if (s.error == "D12") return r.D12_err;
  if (s.error == "vmax") return r.vmax_err;
  return r.N_inf;
}

// The ladder values of a member other than x and adapt.enabled: uniform and adaptive
// members that agree on them are compared at equal error.
std::string counterpart_key(const io::StudyConfig& s, const Member& m) {
  std::string k;
  for (const auto& [key, v] : m.values)
    if (key != s.x && key != "adapt.enabled") k += key + "=" + v + ";";
  return k;
}

struct Writer {
  const io::StudyConfig& s;
  const std::vector<Member>& members;
  const std::vector<MemberOutcome>& outcomes;
  const std::vector<MemberResult>& results;
  std::vector<std::string> failures;

  std::string study_csv() const {
    std::string text = "member,status";
    for (const auto& [key, v] : members.front().values) text += fmt::format(",{}", csv_field(key));
    text += ",series,reference,plotted,dt,max_level,dx,adapt,nodes,t_end,N_inf,vmax,area_rel,volume_rel,D12,D12_bbox,D12_err,vmax_err";
    for (const double t : s.d12_times) text += fmt::format(",D12@{0},D12_bbox@{0}", num(t));
    text += ",cells_mean,cells_final,steps,wall_s,run_s,cpu_s\n";
    for (std::size_t i = 0; i < members.size(); ++i) {
      const Member& m = members[i];
      const MemberResult& r = results[i];
      const auto& c = m.config;
      text += fmt::format("{},{}", csv_field(m.name), state_name(outcomes[i].state));
      for (const auto& [key, v] : m.values) text += fmt::format(",{}", csv_field(v));
      const bool plotted = s.plot_members.empty() ||
                           std::find(s.plot_members.begin(), s.plot_members.end(), m.name) != s.plot_members.end();
      text += fmt::format(",{},{},{},{},{},{},{},{}", csv_field(m.series), csv_field(members[m.reference].name),
                          plotted ? 1 : 0, num(c.time.dt), c.adapt.max_level,
                          num(std::ldexp(c.domain.root_size, -c.adapt.max_level)), c.adapt.enabled ? "on" : "off",
                          c.capsules.empty() ? 0 : c.capsules.front().nodes);
      if (!r.available) {
        // Empty criteria, D12 times and costs; the process times of a failed run.
        text += fmt::format("{}{},{}\n", std::string(9 + 2 * s.d12_times.size() + 5, ','), num(outcomes[i].run_s),
                            num(outcomes[i].cpu_s));
        continue;
      }
      for (const double v : {r.t_end, r.N_inf, r.vmax, r.area_rel, r.volume_rel, r.D12, r.D12_bbox, r.D12_err, r.vmax_err})
        text += fmt::format(",{}", v);
      for (std::size_t k = 0; k < s.d12_times.size(); ++k) text += fmt::format(",{},{}", r.d12_at[k], r.d12_bbox_at[k]);
      for (const double v : {r.cells_mean, r.cells_final, r.steps, r.wall_s, outcomes[i].run_s, outcomes[i].cpu_s})
        text += fmt::format(",{}", v);
      text += "\n";
    }
    return text;
  }

  // Members of each series, in member order.
  std::map<std::string, std::vector<std::size_t>> series() const {
    std::map<std::string, std::vector<std::size_t>> out;
    for (std::size_t i = 0; i < members.size(); ++i) out[members[i].series].push_back(i);
    return out;
  }

  double x_at(const std::vector<std::size_t>& group, double h) const {
    for (const std::size_t i : group)
      if (members[i].h == h) return members[i].x;
    return kNan;
  }

  std::string orders_csv() {
    std::string text = "series,criterion,x_coarse,x_fine,h_coarse,h_fine,e_coarse,e_fine,order\n";
    const auto limit = [&](const std::string& c) -> const double* {
      for (const auto& [name, v] : s.expect.min_order)
        if (name == c) return &v;
      return nullptr;
    };
    for (const auto& [name, group] : series()) {
      for (const char* c : io::kStudyCriteria) {
        std::vector<std::pair<double, double>> points;
        for (const std::size_t i : group)
          if (results[i].available && in_orders(members, i, c)) points.emplace_back(members[i].h, criterion(results[i], c));
        for (const Segment& seg : observed_orders(points)) {
          text += fmt::format("{},{},{},{},{},{},{},{},{}\n", csv_field(name), c, num(x_at(group, seg.h_coarse)),
                              num(x_at(group, seg.h_fine)), num(seg.h_coarse), num(seg.h_fine), num(seg.e_coarse),
                              num(seg.e_fine), num(seg.order));
          if (const double* min = limit(c); min && !(seg.order >= *min))
            failures.push_back(fmt::format("order of {} in series \"{}\" from {} = {} to {}: {:.3f}, expected >= {}", c,
                                           name, key_label(s.x), num(x_at(group, seg.h_coarse)),
                                           num(x_at(group, seg.h_fine)), seg.order, *min));
        }
        if (limit(c) && points.size() < 2)
          failures.push_back(fmt::format("order of {} in series \"{}\": fewer than two members with an error", c, name));
      }
    }
    return text;
  }

  std::string equal_error_csv() {
    std::string text = fmt::format(
        "uniform_member,{0},cells_uniform,cells_adaptive,cells_ratio,wall_uniform,wall_adaptive,wall_ratio,cpu_uniform,"
        "cpu_adaptive,cpu_ratio\n",
        s.error);
    bool any = false;
    for (std::size_t u = 0; u < members.size(); ++u) {
      if (members[u].config.adapt.enabled || !results[u].available || members[u].reference == u) continue;
      std::vector<std::pair<double, double>> cells, wall, cpu;
      for (std::size_t a = 0; a < members.size(); ++a)
        if (members[a].config.adapt.enabled && results[a].available && members[a].reference != a &&
            counterpart_key(s, members[a]) == counterpart_key(s, members[u])) {
          cells.emplace_back(error_of(s, results[a]), results[a].cells_mean);
          wall.emplace_back(error_of(s, results[a]), results[a].wall_s);
          cpu.emplace_back(error_of(s, results[a]), outcomes[a].cpu_s);
        }
      if (cells.empty()) continue;
      const double e = error_of(s, results[u]);
      const double ca = cost_at_error(cells, e), wa = cost_at_error(wall, e), pa = cost_at_error(cpu, e);
      const double cu = results[u].cells_mean, wu = results[u].wall_s, pu = outcomes[u].cpu_s;
      text += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(members[u].name), num(e), num(cu), num(ca),
                          num(cu / ca), num(wu), num(wa), num(wu / wa), num(pu), num(pa), num(pu / pa));
      if (!std::isfinite(ca)) continue;
      any = true;
      if (s.expect.min_cells_ratio > 0 && !(cu / ca >= s.expect.min_cells_ratio))
        failures.push_back(fmt::format("{}: uniform / adaptive cells at equal {} = {:.2f}, expected >= {}",
                                       members[u].name, s.error, cu / ca, s.expect.min_cells_ratio));
      if (s.expect.min_wall_ratio > 0 && !(wu / wa >= s.expect.min_wall_ratio))
        failures.push_back(fmt::format("{}: uniform / adaptive wall time at equal {} = {:.2f}, expected >= {}",
                                       members[u].name, s.error, wu / wa, s.expect.min_wall_ratio));
    }
    if (!any && (s.expect.min_cells_ratio > 0 || s.expect.min_wall_ratio > 0))
      failures.push_back("no uniform member's error lies within the range of its adaptive counterparts'");
    return text;
  }

  void check_values() {
    for (const auto& [c, max] : s.expect.max_value)
      for (std::size_t i = 0; i < members.size(); ++i) {
        if (!in_orders(members, i, c)) continue;
        const double v = results[i].available ? criterion(results[i], c) : kNan;
        if (!(v <= max))
          failures.push_back(fmt::format("{} of member {} = {:.4g}, expected <= {}", c, members[i].name, v, max));
      }
  }
};

}  // namespace

double criterion(const MemberResult& r, const std::string& name) {
  if (name == "N_inf") return r.N_inf;
  if (name == "vmax") return std::abs(r.vmax);
  if (name == "area_rel") return std::abs(r.area_rel);
  if (name == "volume_rel") return std::abs(r.volume_rel);
  return r.D12_err;
}

std::vector<MemberResult> read_results(const io::StudyConfig& study, const std::vector<Member>& members,
                                       const RunnerOptions& runner) {
  std::vector<MemberResult> out(members.size());
  for (std::size_t i = 0; i < members.size(); ++i) {
    const fs::path dir = member_dir(runner, members[i]);
    if (!fs::exists(dir / "study_done.txt")) {
      out[i].problem = "did not finish";
      continue;
    }
    try {
      out[i] = read_member(study, dir);
    } catch (const std::runtime_error& e) {
      out[i].problem = e.what();
    }
  }
  for (std::size_t i = 0; i < members.size(); ++i) {
    MemberResult& r = out[i];
    const MemberResult& ref = out[members[i].reference];
    if (!r.available) continue;
    r.N_inf = ref.available ? node_error(r.nodes, ref.nodes) : kNan;
    r.D12_err = ref.available ? std::abs(r.D12 - ref.D12) : kNan;
    r.vmax_err = ref.available ? std::abs(r.vmax - ref.vmax) : kNan;
  }
  return out;
}

std::vector<std::string> write_results(const io::StudyConfig& study, const std::vector<Member>& members,
                                       const std::vector<MemberOutcome>& outcomes,
                                       const std::vector<MemberResult>& results, const fs::path& dir) {
  Writer w{study, members, outcomes, results, {}};
  io::atomic_write_text(dir / "study.csv", w.study_csv());
  io::atomic_write_text(dir / "orders.csv", w.orders_csv());
  io::atomic_write_text(dir / "equal_error.csv", w.equal_error_csv());
  w.check_values();
  return w.failures;
}

}  // namespace capsflow::app::study
