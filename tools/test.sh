#!/usr/bin/env bash
# Installs the dependencies, builds capsflow (Release) and runs the test suite.
# The README's test command and CI (.ci/run) both call this script.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"
# Tests run side by side, one OpenMP thread each (set per test in tests/CMakeLists.txt);
# the validations labelled "long" (minutes each) run with: ctest --test-dir build -L long
ctest --test-dir build --output-on-failure -j "$(nproc)" --label-exclude long
