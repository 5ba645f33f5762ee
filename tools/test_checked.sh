#!/usr/bin/env bash
# Builds the checked configuration in build-checked and runs the default suite there:
# CAPSFLOW_ASSERT on (CAPSFLOW_CHECKED), AddressSanitizer and UBSan (CAPSFLOW_ASAN),
# optimised (-O1) with debug information and frame pointers, so that the membrane and
# coupling tests take seconds rather than the minutes of a Debug ASan build. No
# benchmarks. tools/test.sh runs it after the Release suite; a developer can run it alone
# (after tools/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
# RelWithDebInfo with its flags replaced: no -DNDEBUG, so the standard assert() stays on too.
cmake -S . -B build-checked -G Ninja "${launcher[@]}" \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g -fno-omit-frame-pointer" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g -fno-omit-frame-pointer" \
  -DCAPSFLOW_CHECKED=ON -DCAPSFLOW_ASAN=ON -DCAPSFLOW_BUILD_BENCH=OFF
cmake --build build-checked -j "$(nproc)"
# A sanitizer report stops the test that made it (UBSan too: -fno-sanitize-recover).
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
ctest --test-dir build-checked --output-on-failure -j "$(nproc)" --label-exclude long
