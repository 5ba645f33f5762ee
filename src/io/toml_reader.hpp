#pragma once
// Strict, typed reading of one TOML table (internal to the case parser).
//
// Every key a section knows is asked for through a TableReader, present or not; finish()
// then reports any key that nobody asked for as unknown (with the nearest known key as a
// hint). Numbers: an integer is accepted where a float is expected, never the reverse.
// Arrays must have exactly the expected number of entries (the case's dimension).
#include <toml++/toml.h>

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "io/case_names.hpp"
#include "io/case_source.hpp"

namespace capsflow::io::detail {

// A node as it would appear in a case file, for messages.
[[nodiscard]] std::string toml_repr(const toml::node& node);

class TableReader {
 public:
  TableReader(const toml::table& table, std::string path, const CaseSource& source)
      : table_(table), path_(std::move(path)), source_(source) {}

  // Each read leaves `out` unchanged and returns false when the key is absent.
  bool read(std::string_view key, double& out);
  bool read(std::string_view key, int& out);
  bool read(std::string_view key, bool& out);
  bool read(std::string_view key, std::string& out);
  bool read(std::string_view key, std::array<double, 3>& out, int n);
  bool read(std::string_view key, std::array<int, 3>& out, int n);
  bool read(std::string_view key, std::array<bool, 3>& out, int n);

  template <class E, std::size_t N>
  bool read(std::string_view key, E& out, const NameTable<E, N>& names) {
    std::string s;
    if (!read(key, s)) return false;
    for (const auto& [e, name] : names)
      if (name == s) {
        out = e;
        return true;
      }
    std::string choices;
    for (const auto& [e, name] : names)
      choices += (choices.empty() ? "" : ", ") + toml_string(name);
    source_.fail(key_path(key), toml_string(s), "expected one of " + choices);
  }

  // The node of a key (marks it known), or nullptr when absent.
  const toml::node* node(std::string_view key);
  // A sub-table (standard or inline), or nullptr when absent; a non-table is an error.
  const toml::table* table(std::string_view key);
  // An array of tables ([[key]]), or nullptr when absent.
  const toml::array* array_of_tables(std::string_view key);

  bool has(std::string_view key) const { return table_.contains(key); }
  [[noreturn]] void missing(std::string_view key, std::string_view why) const;
  [[nodiscard]] std::string key_path(std::string_view key) const;
  const CaseSource& source() const { return source_; }

  // Throws for the first key that no read asked for.
  void finish() const;

 private:
  template <class T>
  bool read_scalar(std::string_view key, T& out);
  template <class T, std::size_t N>
  bool read_array(std::string_view key, std::array<T, N>& out, int n);
  [[noreturn]] void wrong_type(std::string_view key, const toml::node& n,
                               std::string_view expected) const;

  const toml::table& table_;
  std::string path_;
  const CaseSource& source_;
  std::vector<std::string> known_;
};

}  // namespace capsflow::io::detail
