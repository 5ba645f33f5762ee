#include "io/toml_reader.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <sstream>

namespace capsflow::io::detail {

namespace {

std::string_view type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a float";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date/time";
  }
}

// Levenshtein distance, for "did you mean" hints on unknown keys.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                        std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (same ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// Element conversions shared by scalars and arrays; false when the type does not fit.
bool convert(const toml::node& n, double& out) {
  if (const auto* f = n.as_floating_point()) {
    out = f->get();
    return true;
  }
  if (const auto* i = n.as_integer()) {
    out = static_cast<double>(i->get());
    return true;
  }
  return false;
}
bool convert(const toml::node& n, bool& out) {
  if (const auto* b = n.as_boolean()) {
    out = b->get();
    return true;
  }
  return false;
}
bool convert(const toml::node& n, std::string& out) {
  if (const auto* s = n.as_string()) {
    out = s->get();
    return true;
  }
  return false;
}
bool convert(const toml::node& n, int& out) {
  if (const auto* i = n.as_integer()) {
    const std::int64_t v = i->get();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) return false;
    out = static_cast<int>(v);
    return true;
  }
  return false;
}

// For values that are integers but do not fit an int.
constexpr std::string_view kIntRange = "out of range for a 32-bit integer";

template <class T>
constexpr std::string_view expected_plural() {
  if constexpr (std::is_same_v<T, double>) return "numbers";
  else if constexpr (std::is_same_v<T, int>) return "integers";
  else if constexpr (std::is_same_v<T, bool>) return "booleans (true or false)";
  else return "strings";
}

template <class T>
constexpr std::string_view expected_name() {
  if constexpr (std::is_same_v<T, double>) return "a number";
  else if constexpr (std::is_same_v<T, int>) return "an integer";
  else if constexpr (std::is_same_v<T, bool>) return "a boolean (true or false)";
  else return "a string";
}

}  // namespace

std::string toml_repr(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string: return toml_string(node.as_string()->get());
    case toml::node_type::integer: return fmt::format("{}", node.as_integer()->get());
    case toml::node_type::floating_point: return toml_number(node.as_floating_point()->get());
    case toml::node_type::boolean: return node.as_boolean()->get() ? "true" : "false";
    case toml::node_type::array: {
      std::string s = "[";
      for (const toml::node& e : *node.as_array()) s += (s.size() > 1 ? ", " : "") + toml_repr(e);
      return s + "]";
    }
    case toml::node_type::table: {
      std::string s = "{";
      for (const auto& [k, v] : *node.as_table())
        s += fmt::format("{} {} = {}", s.size() > 1 ? "," : "", k.str(), toml_repr(v));
      return s + " }";
    }
    default: {
      std::ostringstream os;
      node.visit([&](const auto& v) { os << v; });
      return os.str();
    }
  }
}

std::string TableReader::key_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
}

const toml::node* TableReader::node(std::string_view key) {
  known_.emplace_back(key);
  return table_.get(key);
}

void TableReader::wrong_type(std::string_view key, const toml::node& n,
                             std::string_view expected) const {
  source_.fail(key_path(key), toml_repr(n), fmt::format("expected {}, got {}", expected, type_name(n)));
}

void TableReader::missing(std::string_view key, std::string_view why) const {
  source_.fail(key_path(key), fmt::format("missing ({})", why));
}

template <class T>
bool TableReader::read_scalar(std::string_view key, T& out) {
  const toml::node* n = node(key);
  if (!n) return false;
  if (!convert(*n, out)) {
    if constexpr (std::is_same_v<T, int>)
      if (n->is_integer()) source_.fail(key_path(key), toml_repr(*n), kIntRange);
    wrong_type(key, *n, expected_name<T>());
  }
  return true;
}

bool TableReader::read(std::string_view key, double& out) { return read_scalar(key, out); }
bool TableReader::read(std::string_view key, int& out) { return read_scalar(key, out); }
bool TableReader::read(std::string_view key, bool& out) { return read_scalar(key, out); }
bool TableReader::read(std::string_view key, std::string& out) { return read_scalar(key, out); }

template <class T, std::size_t N>
bool TableReader::read_array(std::string_view key, std::array<T, N>& out, int n) {
  const toml::node* nd = node(key);
  if (!nd) return false;
  const toml::array* a = nd->as_array();
  if (!a) wrong_type(key, *nd, fmt::format("an array of {} {}", n, expected_plural<T>()));
  if (static_cast<int>(a->size()) != n)
    source_.fail(key_path(key), toml_repr(*nd),
                 fmt::format("expected {} entries (one per direction), got {}", n, a->size()));
  std::array<T, N> values = out;
  for (int i = 0; i < n; ++i) {
    const toml::node& entry = *a->get(static_cast<std::size_t>(i));
    if (convert(entry, values[i])) continue;
    if constexpr (std::is_same_v<T, int>)
      if (entry.is_integer()) source_.fail(key_path(key), toml_repr(*nd), fmt::format("entry {} is {}", i, kIntRange));
    source_.fail(key_path(key), toml_repr(*nd),
                 fmt::format("entry {} is {}, expected {}", i, type_name(entry), expected_name<T>()));
  }
  out = values;
  return true;
}

bool TableReader::read(std::string_view key, std::array<double, 3>& out, int n) {
  return read_array(key, out, n);
}
bool TableReader::read(std::string_view key, std::array<int, 3>& out, int n) {
  return read_array(key, out, n);
}
bool TableReader::read(std::string_view key, std::array<bool, 3>& out, int n) {
  return read_array(key, out, n);
}

const toml::table* TableReader::table(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return nullptr;
  if (!n->is_table()) wrong_type(key, *n, "a table");
  return n->as_table();
}

const toml::array* TableReader::array_of_tables(std::string_view key) {
  const toml::node* n = node(key);
  if (!n) return nullptr;
  const toml::array* a = n->as_array();
  if (!a || (!a->empty() && !a->is_array_of_tables()))  // capsule = [] means none
    wrong_type(key, *n, fmt::format("an array of tables ([[{}]])", key));
  return a;
}

void TableReader::finish() const {
  for (const auto& [k, v] : table_) {
    const std::string_view key = k.str();
    if (std::find(known_.begin(), known_.end(), key) != known_.end()) continue;
    std::string hint;
    std::size_t best = 3;  // only close misspellings earn a hint
    for (const std::string& candidate : known_) {
      const std::size_t d = edit_distance(key, candidate);
      if (d < best) {
        best = d;
        hint = fmt::format(" (did you mean {}?)", key_path(candidate));
      }
    }
    source_.fail(key_path(key), "unknown key" + hint);
  }
}

}  // namespace capsflow::io::detail
