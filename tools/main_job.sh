#!/usr/bin/env bash
# The main job: installs the dependencies, builds capsflow, runs the 2D lid-driven cavity
# at Re = 100 (adaptive, about 10 s) and plots its centrelines against Ghia et al. (1982).
# Leaves out/cavity_2d/: series.pvd + fluid_*.vtu (open series.pvd in ParaView),
# diagnostics.csv, cells_final.csv and centrelines.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" --target capsflow
./build/src/app/capsflow run cases/cavity_2d.toml --out out/cavity_2d
/usr/bin/python3 tools/plot_cavity.py out/cavity_2d --re 100
