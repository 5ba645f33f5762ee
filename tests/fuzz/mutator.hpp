#pragma once
// Seeded random mutations of text inputs (case files, --set arguments) for the fuzz tests:
// byte flips, deletions, insertions of random bytes or TOML-ish tokens, duplicated lines,
// swapped and replaced values. The same seed gives the same inputs, so a finding is
// reproduced by its seed and index.
#include <cstdint>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace capsflow::fuzz {

class Mutator {
 public:
  explicit Mutator(std::uint64_t seed) : rng_(seed) {}

  std::size_t below(std::size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }
  bool chance(double p) { return std::bernoulli_distribution(p)(rng_); }
  template <class T>
  const T& pick(const std::vector<T>& v) { return v[below(v.size())]; }

  // A value to put where a number, a string or a table was: wrong types, huge, negative,
  // tiny, NaN, unicode, control characters, empty, broken syntax.
  std::string value() {
    static const std::vector<std::string> pool{
        "\"text\"", "true", "false", "[1, 2]", "[1, 2, 3]", "[]", "{ a = 1 }", "{}", "1979-05-27", "07:32:00",
        "1979-05-27T07:32:00Z", "0", "-0", "-0.0", "1", "-1", "2", "3", "7", "12", "31", "64", "1000",
        "2147483647", "2147483648", "-2147483649", "9223372036854775807", "-9223372036854775808",
        "99999999999999999999", "1e308", "1.7976931348623157e308", "-1e308", "1e-320", "4.9e-324", "1e400",
        "inf", "+inf", "-inf", "nan", "-nan", "+nan", "0.5", "-0.5", "1e-12", "\"\"", "\"\xc3\xa9t\xc3\xa9\"",
        "\"\xe6\x97\xa5\xe6\x9c\xac\"", "\xc3\xbcn\xc3\xaf" "code", "\"\\u0000\"", "\"a\\u007fb\"", "\"\\u001b[31m\"", "\"\\uD800\"", "\"a\\nb\"",
        "\"\xf0\x9f\x92\xa5\"", "wall", "periodic", "skalak", "ellipsoid", "peskin4", "square_duct", "\"../..\"",
        "\"/proc/x\"", "[[1]]", "[nan, nan, nan]", "[1e308, 1e308, 1e308]", "[-1, -1, -1]", "[1000, 1000, 1000]",
        "[true, false]", "{ type = \"wall\" }", "{ type = \"periodic\" }", "{ type = \"inflow\" }",
        "{ type = \"moving_wall\", velocity = [1.0, 1.0] }", "'", "\"", "[", "{", "=", "0x10", "0o7", "0b11",
        "1_000", "1__0", "+1", "01", ".5", "5.", "1e", "--1", "\xff\xfe", "\x01"};
    if (chance(0.15)) return random_bytes(1 + below(6));
    if (chance(0.01)) return std::string(1 + below(200000), "a[{\"1"[below(5)]);  // huge
    return pick(pool);
  }

  std::string random_bytes(std::size_t n) {
    std::string s;
    for (std::size_t i = 0; i < n; ++i) s += static_cast<char>(below(256));
    return s;
  }

  // One to four mutations of a case file.
  std::string mutate(std::string text) {
    const std::size_t count = 1 + below(4);
    for (std::size_t i = 0; i < count; ++i) text = mutate_once(std::move(text));
    return text;
  }

  // A --set argument: usually a known key with a random value, sometimes an unknown,
  // mangled or empty key, sometimes no '='.
  std::string set_argument(const std::vector<std::string>& keys) {
    std::string key = pick(keys);
    switch (below(10)) {
      case 0: key += "x"; break;
      case 1: key = mutate_once(key); break;
      case 2: key = key.substr(0, below(key.size() + 1)); break;
      case 3: return key;  // no '='
      default: break;
    }
    return key + "=" + value();
  }

 private:
  static std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::size_t start = 0;
    while (start <= text.size()) {
      const std::size_t end = text.find('\n', start);
      out.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
      if (end == std::string::npos) break;
      start = end + 1;
    }
    return out;
  }
  static std::string join(const std::vector<std::string>& ls) {
    std::string s;
    for (std::size_t i = 0; i < ls.size(); ++i) s += (i ? "\n" : "") + ls[i];
    return s;
  }

  std::string mutate_once(std::string text) {
    static const std::vector<std::string> tokens{
        "=", "[", "]", "{", "}", "\"", "'", ",", ".", "\n", "#", "[[capsule]]\n", "[time]\n", "[domain]\n",
        "[fluid.boundary]\n", "x = 1\n", "nan", "1e999", "-", "\\", "\t", "\r", "\xff", "\xc3\xa9", "\xe2\x80\x8b",
        std::string(1, '\0'), "999999999", "0", "-1", "dimension = 2\n", "dimension = 3\n"};
    switch (below(7)) {
      case 0:  // flip a bit
        if (!text.empty()) text[below(text.size())] ^= static_cast<char>(1u << below(8));
        return text;
      case 1: {  // delete a range
        const std::size_t at = below(text.size() + 1);
        return text.erase(at, 1 + below(20));
      }
      case 2:  // insert random bytes
        return text.insert(below(text.size() + 1), random_bytes(1 + below(4)));
      case 3:  // insert a token
        return text.insert(below(text.size() + 1), pick(tokens));
      case 4: {  // duplicate a line
        auto ls = lines(text);
        const std::size_t i = below(ls.size());
        ls.insert(ls.begin() + static_cast<std::ptrdiff_t>(below(ls.size() + 1)), ls[i]);
        return join(ls);
      }
      case 5: {  // swap the values of two "key = value" lines
        auto ls = lines(text);
        const std::size_t a = below(ls.size()), b = below(ls.size());
        const std::size_t ea = ls[a].find(" = "), eb = ls[b].find(" = ");
        if (ea == std::string::npos || eb == std::string::npos) return text;
        const std::string va = ls[a].substr(ea + 3), vb = ls[b].substr(eb + 3);
        ls[a] = ls[a].substr(0, ea + 3) + vb;
        ls[b] = ls[b].substr(0, eb + 3) + va;
        return join(ls);
      }
      default: {  // replace a value
        auto ls = lines(text);
        const std::size_t a = below(ls.size());
        const std::size_t e = ls[a].find(" = ");
        if (e == std::string::npos) return text;
        ls[a] = ls[a].substr(0, e + 3) + value();
        return join(ls);
      }
    }
  }

  std::mt19937_64 rng_;
};

}  // namespace capsflow::fuzz
