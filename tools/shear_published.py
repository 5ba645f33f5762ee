#!/usr/bin/python3
"""A neo-Hookean capsule in simple shear at finite deformation against published D12(t).

Usage:
  shear_published.py CAPSFLOW CASE OUT [--capillaries 0.025,0.05,0.1,0.2] [--lambdas 1]
                     [--levels 6] [--nodes 642] [--tolerance 0.08] [--plot FILE] [--reuse]
                     [--set k=v ...]

CASE is the published configuration (cases/shear_neo_hookean_stokes.toml: an initially
spherical capsule, shear rate 1, radius 1). --capillaries are in the papers' convention,
Ca = mu gamma a / Es with Es = 3 Gs (capsflow's capsule Ca is on Gs: three times theirs). For
each level, capillary number and viscosity ratio the run's D12(t) (capsules.csv, the inertia
ellipsoid's axes in the shear plane, as the papers measure it) is compared with the curves of
tests/data/neo_hookean_shear_published.csv, all at lambda = 1: Pozrikidis (1995) and Eggleton
& Popel (1998) over the transient they show, Ramanujan & Pozrikidis (1998) and Doddi & Bagchi
(2008) to steady state. The steady D12 is the run's mean over its last unit of strain, each
published one its curve's last point where that lies at a strain of 3 or more. Viscosity
ratios other than 1 have no published curve here: their rows give the run's values only.
Prints a table; exits 1 unless, at lambda = 1 and the finest level, every steady D12 lies
within --tolerance (relative) of the published steady values' mean.

--reuse reads OUT/level_N/Ca_X_lambda_Y/capsules.csv where it exists instead of running again.
"""
import argparse
import csv
import os
import sys
import time

import numpy as np

import level_runs

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "tests", "data")
SOURCES = {"pozrikidis1995": "Pozrikidis 1995", "eggleton_popel1998": "Eggleton & Popel 1998",
           "ramanujan_pozrikidis1998": "Ramanujan & Pozrikidis 1998", "doddi_bagchi2008": "Doddi & Bagchi 2008"}
STEADY_FROM = 3.0  # the strain after which a published curve's last point counts as steady


def published():
    """{(source, Ca_Es): array of (t, D12)}."""
    curves = {}
    with open(os.path.join(DATA, "neo_hookean_shear_published.csv")) as f:
        for r in csv.DictReader(line for line in f if not line.startswith("#")):
            curves.setdefault((r["source"], float(r["Ca_Es"])), []).append((float(r["t"]), float(r["D12"])))
    return {k: np.array(v) for k, v in curves.items()}


def read_capsule(out):
    with open(f"{out}/capsules.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["capsule"] == "0"]
    return {k: np.array([float(r[k]) for r in rows]) for k in ("t", "D12", "inclination", "omega_z", "volume_rel")}


def run_once(args, level, nodes, ca_es, lam):
    """The run (or the reused one): its capsule rows and wall time (None when reused)."""
    out = f"{args.out}/level_{level}/Ca_{ca_es:g}_lambda_{lam:g}"
    wall = None
    if not (args.reuse and os.path.exists(f"{out}/capsules.csv")):
        start = time.monotonic()
        level_runs.run(args, level, nodes, out,
                       [f"capsule[0].Ca={3 * ca_es:.10g}", f"capsule[0].viscosity_ratio={lam:g}"])
        wall = time.monotonic() - start
    return read_capsule(out), wall


def compare(c, curves, ca_es):
    """(steady D12 of the run, {source: steady D12}, {source: max |D12 run - published|} over
    each curve's span within the run)."""
    late = c["t"] >= c["t"][-1] - 1.0
    steady = float(np.mean(c["D12"][late]))
    published_steady, worst = {}, {}
    for (source, ca), curve in curves.items():
        if ca != ca_es:
            continue
        inside = (curve[:, 0] >= c["t"][0]) & (curve[:, 0] <= c["t"][-1])  # the rows start at the first diagnostics step
        worst[source] = float(np.max(np.abs(np.interp(curve[inside, 0], c["t"], c["D12"]) - curve[inside, 1])))
        if curve[-1, 0] >= STEADY_FROM:
            published_steady[source] = float(curve[-1, 1])
    return steady, published_steady, worst


def plot(path, results, curves):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 5))
    markers = dict(zip(SOURCES, "s^od"))
    labelled = set()
    for (source, ca), curve in sorted(curves.items()):
        label = SOURCES[source] if source not in labelled else None
        labelled.add(source)
        ax.plot(curve[:, 0], curve[:, 1], markers[source], mfc="none", ms=4, color="0.4", label=label)
    for (level, ca_es, lam), c in results.items():
        style = "-" if lam == 1 else "--"
        ax.plot(c["t"], c["D12"], style, label=f"capsflow level {level}, Ca = {ca_es:g}, lambda = {lam:g}")
    ax.set_xlabel("shear strain gamma t")
    ax.set_ylabel("D12")
    ax.set_xlim(0, 8.5)
    ax.grid(True)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    p = argparse.ArgumentParser()
    level_runs.add_arguments(p, tolerance=0.08)
    p.set_defaults(levels="6", nodes="642")
    p.add_argument("--capillaries", default="0.025,0.05,0.1,0.2")
    p.add_argument("--lambdas", default="1")
    p.add_argument("--plot")
    p.add_argument("--reuse", action="store_true")
    a = p.parse_args()
    sys.stdout.reconfigure(line_buffering=True)  # each run's row as it ends, under ctest too
    try:
        capillaries = [float(x) for x in a.capillaries.split(",")]
        lambdas = [float(x) for x in a.lambdas.split(",")]
    except ValueError:
        print("shear_published: --capillaries and --lambdas are numbers separated by commas", file=sys.stderr)
        return 2
    runs = level_runs.levels_and_nodes(a, "shear_published")
    curves = published()
    known = sorted({ca for _, ca in curves})
    if any(ca not in known for ca in capillaries):
        print(f"shear_published: the published curves are at Ca = {', '.join(f'{x:g}' for x in known)} "
              "(mu gamma a / Es)", file=sys.stderr)
        return 2
    print("D12 in simple shear; Ca = mu gamma a / Es (Es = 3 Gs); steady: the run's mean over its last "
          "unit of strain against the published curves' last points")
    print("| level | nodes | Ca | lambda | wall s | steady D12 | published steady | rel. diff to their mean | "
          "max diff over the curves | inclination / pi | omega_z | volume drift |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    results, worst = {}, 0.0
    for level, nodes in runs:
        for ca_es in capillaries:
            for lam in lambdas:
                c, wall = run_once(a, level, nodes, ca_es, lam)
                results[(level, ca_es, lam)] = c
                steady, theirs, diffs = compare(c, curves, ca_es)
                late = c["t"] >= c["t"][-1] - 1.0
                drift = float(np.max(np.abs(c["volume_rel"] - c["volume_rel"][0])))
                published_text, rel_text, diff_text = "-", "-", "-"
                if lam == 1 and theirs:
                    mean = float(np.mean(list(theirs.values())))
                    rel = steady / mean - 1.0
                    if level == runs[-1][0]:
                        worst = max(worst, abs(rel))
                    published_text = ", ".join(f"{v:.3f} ({SOURCES[s].split()[0]})" for s, v in theirs.items())
                    rel_text = f"{rel:+.3f}"
                    diff_text = ", ".join(f"{v:.3f} ({SOURCES[s].split()[0]})" for s, v in diffs.items())
                wall_text = f"{wall:.0f}" if wall is not None else "(reused)"
                print(f"| {level} | {nodes} | {ca_es:g} | {lam:g} | {wall_text} | {steady:.4f} | {published_text} | "
                      f"{rel_text} | {diff_text} | {np.mean(c['inclination'][late]):.4f} | "
                      f"{np.mean(c['omega_z'][late]):.4f} | {drift:.1e} |")
    if a.plot:
        plot(a.plot, results, curves)
    if worst > a.tolerance:
        print(f"shear_published: a steady D12 differs from the published mean by {worst:.3f} (tolerance {a.tolerance})")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
