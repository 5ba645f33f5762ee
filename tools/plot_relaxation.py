#!/usr/bin/env python3
"""The capsule relaxation of a finished run: D12(t) and D12_bbox(t) (the seed paper's
Taylor parameters), and the relative area and volume changes.

usage: plot_relaxation.py RUN_DIR [RUN_DIR ...]   (one curve per run; the plot goes to the first)
Reads RUN_DIR/diagnostics.csv, writes RUN_DIR/relaxation.png and prints D12 at a few times.
"""
import os
import sys

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read(run):
    path = os.path.join(run, "diagnostics.csv")
    if not os.path.exists(path):
        sys.exit(f"plot_relaxation.py: {path} not found")
    return np.genfromtxt(path, delimiter=",", names=True)


def print_turning_points(label, d):
    """The local extremes of D12_bbox (signed: negative when the capsule is longer across the
    channel than along it): a damped oscillation shows as extremes of alternating sign and
    falling size, a monotonic relaxation as none."""
    y = d["D12_bbox"]
    turning = [i for i in range(1, len(y) - 1) if (y[i] - y[i - 1]) * (y[i + 1] - y[i]) < 0 and abs(y[i]) > 1e-4]
    if not turning:
        print(f"{label}: D12_bbox has no turning point (monotonic relaxation)")
        return
    points = "  ".join(f"t = {d['t'][i]:.2f}: {y[i]:+.4f}" for i in turning[:8])
    print(f"{label}: D12_bbox turning points: {points}")


def main():
    runs = sys.argv[1:]
    if not runs:
        sys.exit(__doc__)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    for run in runs:
        d = read(run)
        label = os.path.basename(os.path.normpath(run))
        ax[0].plot(d["t"], d["D12"], "-", label=f"{label}: D12 (inertia ellipsoid)")
        ax[0].plot(d["t"], d["D12_bbox"], "--", label=f"{label}: D12 (bounding box)")
        ax[1].plot(d["t"], 100 * d["area_rel"], "-", label=f"{label}: area")
        ax[1].plot(d["t"], 100 * d["volume_rel"], "--", label=f"{label}: volume")
        for t in (0.1, 0.5, 1.0, 2.0, 5.0, 10.0):
            if d["t"][-1] >= t - 1e-9:
                i = int(np.argmin(np.abs(d["t"] - t)))
                print(f"{label}: t = {d['t'][i]:.3f}  D12 = {d['D12'][i]:.5f}  D12_bbox = {d['D12_bbox'][i]:.5f}  "
                      f"area_rel = {d['area_rel'][i]:+.2e}  volume_rel = {d['volume_rel'][i]:+.2e}  vmax = {d['vmax'][i]:.3e}")
        print_turning_points(label, d)
    ax[0].set(xlabel="t", ylabel="Taylor parameter", title="capsule relaxation")
    ax[1].set(xlabel="t", ylabel="change from the reference sphere (%)", title="area and volume")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    out = os.path.join(runs[0], "relaxation.png")
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
