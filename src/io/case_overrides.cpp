#include "io/case_overrides.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <system_error>
#include <optional>
#include <string_view>
#include <vector>

namespace capsflow::io::detail {

namespace {

struct Segment {
  std::string name;
  std::optional<std::size_t> index;  // capsule[0]
};

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool bare_word(std::string_view s) {
  if (s.empty()) return false;
  for (const char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
  return true;
}

class Override {
 public:
  Override(std::string_view arg, const CaseSource& source) : arg_(arg), source_(source) {}

  [[noreturn]] void fail(std::string_view reason) const {
    source_.fail_file(fmt::format("--set {}: {}", arg_, reason));
  }

  void apply(toml::table& root, std::vector<std::string>& overridden) const {
    const std::size_t eq = arg_.find('=');
    if (eq == std::string_view::npos) fail("expected key=value");
    const std::string_view key = trim(arg_.substr(0, eq));
    const std::vector<Segment> path = split(key);
    toml::table value_doc = parse_value(trim(arg_.substr(eq + 1)));

    toml::table* t = &root;
    for (std::size_t i = 0; i + 1 < path.size(); ++i) t = descend(*t, path[i]);
    const Segment& last = path.back();
    if (last.index) fail("give a key inside the array element, e.g. capsule[0].radius=1");
    t->insert_or_assign(last.name, std::move(*value_doc.get("v")));
    overridden.emplace_back(key);
  }

 private:
  std::vector<Segment> split(std::string_view key) const {
    std::vector<Segment> out;
    std::size_t start = 0;
    while (true) {
      const std::size_t dot = key.find('.', start);
      std::string_view part = key.substr(start, dot == std::string_view::npos ? key.npos : dot - start);
      Segment seg;
      if (const std::size_t open = part.find('['); open != std::string_view::npos) {
        if (part.back() != ']') fail(fmt::format("bad index in key \"{}\"", key));
        const std::string_view digits = part.substr(open + 1, part.size() - open - 2);
        if (digits.empty() || !std::all_of(digits.begin(), digits.end(),
                                           [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
          fail(fmt::format("bad index in key \"{}\"", key));
        std::size_t index = 0;
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
        if (ec != std::errc() || end != digits.data() + digits.size())
          fail(fmt::format("index {} in key \"{}\" is out of range", digits, key));
        seg.index = index;
        part = part.substr(0, open);
      }
      if (!bare_word(part)) fail(fmt::format("bad key \"{}\"", key));
      seg.name = part;
      out.push_back(std::move(seg));
      if (dot == std::string_view::npos) break;
      start = dot + 1;
    }
    return out;
  }

  toml::table parse_value(std::string_view value) const {
    try {
      const std::string doc = fmt::format("v = {}", value);
      return toml::parse(std::string_view(doc), std::string_view("--set"));
    } catch (const toml::parse_error& e) {
      // Shells eat quotes: --set capsule[0].law=skalak means the string "skalak".
      if (bare_word(value)) {
        toml::table t;
        t.insert("v", std::string(value));
        return t;
      }
      fail(fmt::format("the value is not valid TOML ({})", e.description()));
    }
  }

  toml::table* descend(toml::table& t, const Segment& seg) const {
    toml::node* n = t.get(seg.name);
    if (!n) {
      if (seg.index) fail(fmt::format("there is no [[{}]] to index", seg.name));
      n = &t.insert(seg.name, toml::table{}).first->second;
    }
    if (seg.index) {
      toml::array* a = n->as_array();
      if (!a || !a->is_array_of_tables()) fail(fmt::format("{} is not an array of tables", seg.name));
      if (*seg.index >= a->size())
        fail(fmt::format("{}[{}] does not exist (the case has {})", seg.name, *seg.index, a->size()));
      n = a->get(*seg.index);
    }
    toml::table* sub = n->as_table();
    if (!sub) fail(fmt::format("{} is not a table", seg.name));
    return sub;
  }

  std::string_view arg_;
  const CaseSource& source_;
};

}  // namespace

void apply_overrides(toml::table& root, std::span<const std::string> overrides, CaseSource& source) {
  for (const std::string& arg : overrides) Override(arg, source).apply(root, source.overridden);
}

}  // namespace capsflow::io::detail
