#pragma once
// CAPSFLOW_ASSERT(cond, msg): an invariant, checked in Debug and checked builds
// (CAPSFLOW_CHECKED=ON; CMake defines CAPSFLOW_ASSERTIONS=1 for both) and compiled out in
// Release: the condition and the message are then an unevaluated operand of sizeof, so
// they cost nothing at run time yet still compile (an assertion cannot rot in Release,
// and variables it names do not trigger unused warnings).
//
// On failure it prints file:line, the condition and the message to stderr and aborts:
// a broken invariant means a bug, so no caller may catch it (exceptions are for input the
// user can fix). `msg` is anything convertible to std::string_view (a literal or a
// fmt::format result); it is evaluated only on failure, so it may be costly.
//
// Full passes over the tree (balance after adapt, say) go inside the condition: the
// checked build runs them, Release never does.
//
// A macro because only a macro can skip evaluating its argument and knows __FILE__ and
// __LINE__ of the call; everything else is in the function below.
#include <cstdio>
#include <cstdlib>
#include <string_view>

namespace capsflow {

// Whether assertions are compiled in (for tests that check an assertion fires).
#ifdef CAPSFLOW_ASSERTIONS
inline constexpr bool kAssertions = true;
#else
inline constexpr bool kAssertions = false;
#endif

namespace detail {

[[noreturn]] inline void assertion_failed(const char* file, int line, const char* condition,
                                          std::string_view message) noexcept {
  std::fprintf(stderr, "%s:%d: capsflow assertion failed: %s\n  %.*s\n", file, line, condition,
               static_cast<int>(message.size()), message.data());
  std::fflush(stderr);
  std::abort();
}

}  // namespace detail
}  // namespace capsflow

#ifdef CAPSFLOW_ASSERTIONS
#define CAPSFLOW_ASSERT(cond, msg) \
  (static_cast<bool>(cond) ? void(0) : ::capsflow::detail::assertion_failed(__FILE__, __LINE__, #cond, (msg)))
#else
#define CAPSFLOW_ASSERT(cond, msg) \
  static_cast<void>(sizeof(static_cast<bool>(cond) ? 0 : (static_cast<void>(msg), 0)))
#endif
