#!/usr/bin/env bash
# The main job: installs the dependencies, builds capsflow, runs the quick version of the
# seed paper's case (a capsule pre-deformed into an ellipsoid relaxing in a square channel,
# Stokes flow; about a minute on one core) and plots its Taylor parameter D12(t) and its
# energy budget.
# Leaves out/relaxation_quick/: series.pvd with fluid_*.vtu and membrane_*.vtu (open
# series.pvd in ParaView), diagnostics.csv, capsules.csv, membrane_final.csv, relaxation.png
# and energy.png (the energy budget).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" --target capsflow
./build/src/app/capsflow run cases/relaxation_quick.toml --force --out out/relaxation_quick  # --force: a rerun replaces the last one
/usr/bin/python3 tools/plot_relaxation.py out/relaxation_quick
/usr/bin/python3 tools/plot_energy.py out/relaxation_quick
