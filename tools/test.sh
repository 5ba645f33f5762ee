#!/usr/bin/env bash
# Installs the dependencies, builds capsflow (Release) and runs the test suite; then the
# same suite in the checked configuration (assertions, AddressSanitizer, UBSan:
# tools/test_checked.sh). Both must pass.
# The README's test command and CI (.ci/run) both call this script.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
launcher=()  # ccache, where installed, makes a rebuild of unchanged files free
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "${launcher[@]}"
cmake --build build -j "$(nproc)"
# Tests run side by side, one OpenMP thread each (set per test in tests/CMakeLists.txt);
# the validations labelled "long" (minutes each) run with: ctest --test-dir build -L long
ctest --test-dir build --output-on-failure -j "$(nproc)" --label-exclude long
bash tools/test_checked.sh
