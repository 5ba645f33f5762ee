#pragma once
// Where a case value came from, and the one-line CaseError that names it (internal).
//   <file>: <dotted key> = <value> [(from --set)]: <reason>
// The value is shown as it would be written in TOML; "(from --set)" marks keys that a
// command-line override set, so a user does not search the file for them.
#include <fmt/format.h>

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "io/errors.hpp"

namespace capsflow::io::detail {

// Keeps what() on one line whatever a library's description contains, and short enough to
// read: a 10 MB key or --set value is echoed by its two ends (the file name comes first,
// the reason last).
inline std::string one_line(std::string_view s) {
  constexpr std::size_t kHead = 400, kTail = 400;
  std::string out(s);
  if (out.size() > kHead + kTail + 100)
    out = fmt::format("{} [... {} characters ...] {}", out.substr(0, kHead), out.size() - kHead - kTail,
                      out.substr(out.size() - kTail));
  for (char& c : out)
    if (c == '\n' || c == '\r') c = ' ';
  return out;
}

// A double as TOML writes it: shortest round-trip digits, always with a '.' or an exponent.
inline std::string toml_number(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".en") == std::string::npos) s += ".0";  // "n": inf, nan
  return s;
}

// The first n components of v as a TOML array of numbers.
inline std::string toml_vector(const std::array<double, 3>& v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + toml_number(v[static_cast<std::size_t>(i)]);
  return s + "]";
}

inline std::string toml_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    // Control characters, DEL included, are not allowed raw in a TOML string.
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) out += fmt::format("\\u{:04x}", static_cast<int>(c));
    else out += c;
  }
  return out + '"';
}

struct CaseSource {
  std::string name;                    // the file as the user named it
  std::vector<std::string> overridden; // dotted keys set by --set

  static bool inside(std::string_view inner, std::string_view outer) {
    return inner.size() > outer.size() && inner.substr(0, outer.size()) == outer &&
           (inner[outer.size()] == '.' || inner[outer.size()] == '[');
  }

  bool from_override(std::string_view key) const {
    for (const std::string& o : overridden) {
      if (key == o) return true;
      // A key inside an overridden table (--set fluid.boundary.x_lo={...}), or a table
      // that an override created (--set solver.tol=1 makes the unknown table "solver").
      if (inside(key, o) || inside(o, key)) return true;
    }
    return false;
  }

  [[noreturn]] void fail(std::string_view key, std::string_view reason) const {
    throw CaseError(one_line(fmt::format("{}: {}{}: {}", name, key,
                                         from_override(key) ? " (from --set)" : "", reason)));
  }
  [[noreturn]] void fail(std::string_view key, std::string_view value,
                         std::string_view reason) const {
    throw CaseError(one_line(fmt::format("{}: {} = {}{}: {}", name, key, value,
                                         from_override(key) ? " (from --set)" : "", reason)));
  }
  [[noreturn]] void fail_file(std::string_view reason) const {
    throw CaseError(one_line(fmt::format("{}: {}", name, reason)));
  }
};

}  // namespace capsflow::io::detail
