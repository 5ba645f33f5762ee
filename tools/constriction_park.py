#!/usr/bin/python3
"""A capsule through a square channel's constriction against Park & Dimitrakopoulos (2013).

Usage:
  constriction_park.py CAPSFLOW CASE OUT [--levels 5,6] [--nodes 642,2562] [--tolerance 0.03]
                       [--plot FILE] [--reuse] [--set k=v ...]

CASE is their configuration (cases/constriction_park_stokes.toml: Skalak, C = 1, Ca = 0.1, a
capsule of radius a = Hc inflated 5%, a channel 4 Hc square whose constriction |x| < Hc
closes y to |y| < Hc). For each adapt.max_level in --levels, with the membrane's nodes in
--nodes (about one node a cell), the run's capsules.csv gives the capsule's extents Lx, Ly,
Lz against its centroid x; over 2a and against x / Hc they are compared with the published
curves (tests/data/park_dimitrakopoulos_constriction.csv: the length along the channel, the
width across in the closing direction, y here, and the spanwise width, z) over the range
they cover, and the capsule's velocity with Huet & Wachs's Basilisk run of the same case
(tests/data/huet_wachs_constriction.csv, time and x in units of Hc / V and Hc; the case's
mean inflow velocity V is taken to be 1, as in the shipped case). Prints a
table per level; exits 1 unless the finest run's lengths all lie within --tolerance of the
published curves (the largest difference over each curve).

--reuse reads OUT/level_N/capsules.csv where it exists instead of running again.
"""
import argparse
import csv
import os
import sys
import time
import tomllib

import numpy as np

import level_runs

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "tests", "data")


def case_scales(case):
    """(Hc, a): the constriction's half-height (its slabs' faces nearest y = 0) and the
    capsule's radius as it starts (the stress-free radius times the inflation)."""
    with open(case, "rb") as f:
        c = tomllib.load(f)
    faces = []
    for s in c.get("solid", []):
        if s["shape"] != "box":
            continue
        if s["lo"][1] > 0:
            faces.append(s["lo"][1])
        elif s["hi"][1] < 0:
            faces.append(-s["hi"][1])
    if not faces:
        sys.exit("constriction_park: the case has no box slab closing y")
    cap = c["capsule"][0]
    inflation = cap.get("inflation", 1.0) if cap.get("shape") == "inflated" else 1.0
    return min(faces), cap["radius"] * inflation


def published():
    rows = {}
    with open(os.path.join(DATA, "park_dimitrakopoulos_constriction.csv")) as f:
        for r in csv.DictReader(line for line in f if not line.startswith("#")):
            rows.setdefault(r["quantity"], []).append((float(r["x_over_Hc"]), float(r["L_over_2a"])))
    return {k: np.array(v) for k, v in rows.items()}


def basilisk():
    with open(os.path.join(DATA, "huet_wachs_constriction.csv")) as f:
        rows = [r for r in csv.DictReader(line for line in f if not line.startswith("#"))]
    return np.array([float(r["t"]) for r in rows]), np.array([float(r["x_c"]) for r in rows])


def run_level(args, level, nodes, out):
    """The run at that level into out, unless --reuse finds its capsules.csv; its wall time."""
    if args.reuse and os.path.exists(f"{out}/capsules.csv"):
        return None
    start = time.monotonic()
    level_runs.run(args, level, nodes, out)
    return time.monotonic() - start


def capsule_path(out):
    with open(f"{out}/capsules.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["capsule"] == "0"]
    return {k: np.array([float(r[k]) for r in rows]) for k in ("t", "x", "Lx", "Ly", "Lz", "volume_rel")}


def velocity(t, x):
    """Centred differences of x(t): the velocity at the samples' midpoints."""
    return 0.5 * (x[1:] + x[:-1]), np.diff(x) / np.diff(t)


def main():
    p = argparse.ArgumentParser()
    level_runs.add_arguments(p, tolerance=0.03)
    p.add_argument("--plot")
    p.add_argument("--reuse", action="store_true")
    a = p.parse_args()
    hc, radius = case_scales(a.case)
    runs = level_runs.levels_and_nodes(a, "constriction_park")
    curves = published()
    columns = {"length": "Lx", "constricted": "Ly", "spanwise": "Lz"}
    t_ref, x_ref = basilisk()
    xm_ref, u_ref = velocity(t_ref, x_ref)
    print(f"Hc = {hc}, a = {radius}: lengths over 2a against x_c / Hc; velocity against Huet & Wachs")
    print("| max level | nodes | wall s | length: max diff | constricted | spanwise | min / max constricted | "
          "velocity: max rel diff | volume drift |")
    print("|---|---|---|---|---|---|---|---|---|")
    results = []
    for level, n in runs:
        out = f"{a.out}/level_{level}"
        wall = run_level(a, level, n, out)
        c = capsule_path(out)
        xs = c["x"] / hc
        diffs = {}
        for name, column in columns.items():
            ref = curves[name]
            inside = (ref[:, 0] >= xs[0]) & (ref[:, 0] <= xs[-1])
            if inside.sum() < 0.9 * len(ref):
                sys.exit(f"constriction_park: the run at level {level} covers x_c / Hc = {xs[0]:.2f}..{xs[-1]:.2f}, "
                         f"not the published {ref[0, 0]:.2f}..{ref[-1, 0]:.2f}")
            ours = np.interp(ref[inside, 0], xs, c[column] / (2 * radius))
            diffs[name] = float(np.max(np.abs(ours - ref[inside, 1])))
        xm, u = velocity(c["t"] / hc, c["x"] / hc)
        covered = (xm_ref >= xm[0]) & (xm_ref <= xm[-1])
        u_diff = float(np.max(np.abs(np.interp(xm_ref[covered], xm, u) - u_ref[covered]) / u_ref[covered]))
        ly = c["Ly"] / (2 * radius)
        drift = float(np.max(np.abs(c["volume_rel"] - c["volume_rel"][0]) / (1 + c["volume_rel"][0])))
        wall_text = f"{wall:.0f}" if wall is not None else "(reused)"
        print(f"| {level} | {n} | {wall_text} | {diffs['length']:.4f} | {diffs['constricted']:.4f} | "
              f"{diffs['spanwise']:.4f} | {ly.min():.4f} / {ly.max():.4f} | {u_diff:.4f} | {drift:.2e} |")
        results.append((level, c, diffs))
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(7, 4.5))
        styles = ["-", "--", ":", "-."]
        for (name, column), marker, colour in zip(columns.items(), "os^", ("C0", "C1", "C2")):
            ref = curves[name]
            ax.plot(ref[:, 0], ref[:, 1], marker, mfc="none", color=colour, label=f"Park & Dimitrakopoulos: {name}")
            for k, (level, c, _) in enumerate(reversed(results)):  # the finest solid
                ax.plot(c["x"] / hc, c[column] / (2 * radius), styles[k % 4], color=colour,
                        label=f"capsflow, level {level}: {name}")
        ax.set_xlabel("x_c / Hc")
        ax.set_ylabel("L / 2a")
        ax.set_xlim(-4, 6)
        ax.grid(True)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=120)
    finest = results[-1][2]
    worst = max(finest.values())
    if worst > a.tolerance:
        print(f"constriction_park: the finest run's lengths differ from the published curves by {worst:.4f} "
              f"(tolerance {a.tolerance})")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
