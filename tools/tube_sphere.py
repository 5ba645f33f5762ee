#!/usr/bin/python3
"""A stiff capsule on the axis of a circular tube against Haberman & Sayre's rigid sphere.

Usage:
  tube_sphere.py CAPSFLOW CASE OUT [--levels 5,6] [--nodes 642,2562] [--window 0.4 0.7] [--tolerance 0.01] [--set k=v ...]

A rigid sphere of radius a, neutrally buoyant and free, on the axis of a tube of radius R
carrying Poiseuille flow of mean velocity V (Stokes flow) moves at

    U / V = 2 (1 - 2/3 lam^2 - 0.20217 lam^5) / (1 - 0.75857 lam^5),   lam = a / R

(Haberman & Sayre 1958, David Taylor Model Basin report 1143; the "lag coefficient" of
hindered transport in pores). Its lam^2 term is Faxen's law, u(0) + a^2/6 lap u.
A capsule whose membrane is stiff (small Ca) is that sphere.

CASE is such a capsule in an embedded tube (cases/tube_sphere_stokes.toml: lam = 0.5, Ca =
0.001). For each adapt.max_level in --levels (the tube's wall refined to it too) with the
membrane's nodes in --nodes (about one node a cell: denser nodes than the grid's cells carry
modes the flow cannot see, and the membrane's energy then grows without end while the
capsule keeps slowing; docs/walls.md) the run's capsule velocity is the slope of its
centroid's x over the window of time, against the case's own mean velocity and the tube
radius and capsule radius read from it. Each halving of the spacing must divide the error
by at least --min-reduction, and the two finest runs' first-order extrapolation (the
membrane's effective radius exceeds a by a fraction of a cell) must lie within the
tolerance of the reference. Prints a table; exits 1 otherwise.
"""
import argparse
import csv
import sys
import tomllib

import numpy as np

import level_runs


def haberman_sayre(lam):
    """U / V for a free rigid sphere on the axis of Poiseuille flow of mean velocity V."""
    return 2.0 * (1.0 - 2.0 / 3.0 * lam**2 - 0.20217 * lam**5) / (1.0 - 0.75857 * lam**5)


def case_geometry(case):
    with open(case, "rb") as f:
        c = tomllib.load(f)
    tube = next(s for s in c["solid"] if s["shape"] == "cylinder")
    inflow = c["fluid"]["boundary"]["x_lo"]
    return c["capsule"][0]["radius"] / tube["radius"], inflow.get("mean_velocity", 1.0)


def velocity(out, window):
    """Least-squares slope of the capsule centroid's x over the window of time."""
    with open(f"{out}/capsules.csv") as f:
        rows = [r for r in csv.DictReader(f) if window[0] <= float(r["t"]) <= window[1]]
    if len(rows) < 3:
        sys.exit(f"tube_sphere: fewer than 3 rows of {out}/capsules.csv in the window {window}")
    t = np.array([float(r["t"]) for r in rows])
    x = np.array([float(r["x"]) for r in rows])
    return float(np.polyfit(t, x, 1)[0]), float(rows[-1]["D12"])


def main():
    p = argparse.ArgumentParser()
    level_runs.add_arguments(p, tolerance=0.01)
    p.add_argument("--window", type=float, nargs=2, default=[0.4, 0.7])
    p.add_argument("--min-reduction", type=float, default=1.5)
    a = p.parse_args()
    lam, mean = case_geometry(a.case)
    reference = haberman_sayre(lam)
    runs = level_runs.levels_and_nodes(a, "tube_sphere")
    levels = [level for level, _ in runs]
    print(f"a/R = {lam}, Haberman & Sayre U/V = {reference:.5f}")
    print("| max level | nodes | U/V | error | D12 at the window's end |")
    print("|---|---|---|---|---|")
    errors = []
    for level, n in runs:
        out = f"{a.out}/level{level}"
        level_runs.run(a, level, n, out, [f"adapt.wall_level={level}", f"time.t_end={a.window[1]}",
                                          "output.vtu=false", "output.checkpoint=false"])
        u, d12 = velocity(out, a.window)
        errors.append(u / mean / reference - 1.0)
        print(f"| {level} | {n} | {u / mean:.5f} | {errors[-1]:+.2%} | {d12:.1e} |")
    failed = False
    for (l0, e0), (l1, e1) in zip(zip(levels, errors), zip(levels[1:], errors[1:])):
        ratio = abs(e0) / abs(e1) if e1 != 0.0 else float("inf")
        print(f"levels {l0} -> {l1}: the error falls {ratio:.2f}-fold (order {np.log2(ratio):.2f})")
        if ratio < a.min_reduction:
            print(f"FAIL: less than {a.min_reduction}-fold")
            failed = True
    if len(errors) >= 2:
        extrapolated = 2.0 * errors[-1] - errors[-2]
        print(f"first-order extrapolation of the two finest: {extrapolated:+.2%} (tolerance {a.tolerance:.0%})")
        if abs(extrapolated) > a.tolerance:
            print("FAIL: the extrapolated velocity is off the reference")
            failed = True
    elif abs(errors[0]) > a.tolerance:
        print("FAIL: the velocity is off the reference")
        failed = True
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
