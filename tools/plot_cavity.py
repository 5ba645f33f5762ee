#!/usr/bin/env python3
"""Centreline velocities of a finished cavity run against Ghia, Ghia & Shin (1982).

usage: plot_cavity.py RUN_DIR [--re 100] [--reference DIR]
Reads RUN_DIR/cells_final.csv (written with output.cells_csv = true) and writes
RUN_DIR/centrelines.png; prints the largest deviation from Ghia's points.
"""
import argparse
import os
import sys

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read_cells(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    h = 0.5 ** data["level"]  # unit square: root size 1
    return data, h


def centreline(data, h, along, value):
    """Values on the line {other coordinate} = 0.5, linear between cell centres."""
    across = "x" if along == "y" else "y"
    touching = np.abs(data[across] - 0.5) <= 0.5 * h + 1e-12
    # A cell on each side of the line with the same centre along it (same level): their
    # mean is the value on the line. Where the levels differ the pair is skipped.
    pos = np.round(data[along][touching], 12)
    vals = data[value][touching]
    keys, inverse, counts = np.unique(pos, return_inverse=True, return_counts=True)
    mean = np.bincount(inverse, weights=vals) / counts
    return keys[counts == 2], mean[counts == 2]


def read_ghia(path):
    """(exact coordinate, value) columns of a ghia_re*_{u,v}.csv table."""
    rows = [line.split(",") for line in open(path) if line[0].isdigit()]
    table = np.array(rows, dtype=float)
    return table[:, 1], table[:, 3]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("run_dir")
    parser.add_argument("--re", type=int, default=100)
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument("--reference", default=os.path.join(here, "..", "tests", "data"))
    args = parser.parse_args()
    cells = os.path.join(args.run_dir, "cells_final.csv")
    if not os.path.exists(cells):
        sys.exit(f"plot_cavity.py: {cells} not found (run the case with output.cells_csv = true)")
    data, h = read_cells(cells)
    y, u = centreline(data, h, "y", "ux")
    x, v = centreline(data, h, "x", "uy")
    gy, gu = read_ghia(os.path.join(args.reference, f"ghia_re{args.re}_u.csv"))
    gx, gv = read_ghia(os.path.join(args.reference, f"ghia_re{args.re}_v.csv"))
    # Ghia's points sampled from ours (walls: no-slip values), for the printed deviation.
    du = np.max(np.abs(np.interp(gy, np.r_[0, y, 1], np.r_[0, u, 1]) - gu))
    dv = np.max(np.abs(np.interp(gx, np.r_[0, x, 1], np.r_[0, v, 0]) - gv))
    print(f"max deviation from Ghia et al. at Re = {args.re}: u {du:.4f}, v {dv:.4f}")

    fig, ax = plt.subplots(1, 2, figsize=(10, 4.5))
    ax[0].plot(u, y, "-", label="capsflow")
    ax[0].plot(gu, gy, "o", mfc="none", label="Ghia et al. 1982")
    ax[0].set(xlabel="u(0.5, y)", ylabel="y", title="vertical centreline")
    ax[1].plot(x, v, "-", label="capsflow")
    ax[1].plot(gx, gv, "o", mfc="none", label="Ghia et al. 1982")
    ax[1].set(xlabel="x", ylabel="v(x, 0.5)", title="horizontal centreline")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend()
    fig.suptitle(f"Lid-driven cavity, Re = {args.re}")
    fig.tight_layout()
    out = os.path.join(args.run_dir, "centrelines.png")
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
