#!/usr/bin/python3
"""Compare two runs of one case from their diagnostics.csv (e.g. adaptive against uniform).

Usage: compare_runs.py RUN_DIR REFERENCE_DIR [--times 1,2,5,10]

Prints, for each run, D12, D12_bbox, area_rel, volume_rel, vmax and cells at the given
times, then the largest difference in D12 and D12_bbox over the common time span (relative
to the reference's value at that time, and absolute), the mean cell counts and their
ratio, and the wall times (summed over the segments of a run resumed from checkpoints).
Rows are matched by step; the common span is the shorter run's.
"""
import argparse
import sys

import numpy as np


def load(run_dir):
    path = f"{run_dir}/diagnostics.csv"
    try:
        # One data row reads as a 0-d array: at least 1-d, so that every column iterates.
        return np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True))
    except OSError as error:
        sys.exit(f"compare_runs: cannot read {path}: {error}")


def cumulative_wall(data):
    """wall_s restarts from zero when a run resumes from a checkpoint: sum the segments."""
    wall = np.array(data["wall_s"], dtype=float)
    offset, segments = 0.0, 1
    for i in range(1, len(wall)):
        if data["wall_s"][i] < data["wall_s"][i - 1]:
            offset += data["wall_s"][i - 1]
            segments += 1
        wall[i] = data["wall_s"][i] + offset
    return wall, segments


def at_time(data, t):
    i = int(np.argmin(np.abs(data["t"] - t)))
    return data[i] if abs(data["t"][i] - t) <= 0.5 * max(data["dt"][i], 1e-12) + 1e-9 else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run")
    parser.add_argument("reference")
    parser.add_argument("--times", default="1,2,5,10")
    args = parser.parse_args()
    try:
        times = [float(x) for x in args.times.split(",")]
    except ValueError:
        print(f"compare_runs: --times must be numbers separated by commas, got '{args.times}'", file=sys.stderr)
        sys.exit(2)
    runs = {"run": load(args.run), "reference": load(args.reference)}

    columns = ["D12", "D12_bbox", "area_rel", "volume_rel", "vmax", "cells"]
    print(f"{'':10s} {'t':>6s} " + " ".join(f"{c:>12s}" for c in columns))
    for t in times:
        for name, data in runs.items():
            row = at_time(data, t)
            if row is None:
                print(f"{name:10s} {t:6.2f} (not reached)")
                continue
            print(f"{name:10s} {t:6.2f} " + " ".join(f"{row[c]:12.5g}" for c in columns))

    run, ref = runs["run"], runs["reference"]
    common, i_run, i_ref = np.intersect1d(run["step"], ref["step"], return_indices=True)
    if len(common) == 0:
        sys.exit("compare_runs: the runs share no output step")
    print(f"\ncommon span: t in [{ref['t'][i_ref[0]]:.4g}, {ref['t'][i_ref[-1]]:.4g}], {len(common)} rows")
    for column in ["D12", "D12_bbox"]:
        diff = np.abs(run[column][i_run] - ref[column][i_ref])
        rel = diff / np.maximum(np.abs(ref[column][i_ref]), 1e-300)
        worst = int(np.argmax(rel))
        print(f"{column:9s} max |diff| {diff.max():.3e}; max relative {rel[worst]:.3e} "
              f"(t = {ref['t'][i_ref[worst]]:.4g})")
    cells_run, cells_ref = run["cells"][i_run].mean(), ref["cells"][i_ref].mean()
    print(f"mean cells: run {cells_run:.0f}, reference {cells_ref:.0f}, ratio {cells_ref / cells_run:.2f}")
    (wall_run, seg_run), (wall_ref, seg_ref) = cumulative_wall(run), cumulative_wall(ref)
    wall_run, wall_ref = wall_run[i_run[-1]], wall_ref[i_ref[-1]]
    print(f"wall time to the last common step: run {wall_run:.0f} s ({seg_run} segment(s)), "
          f"reference {wall_ref:.0f} s ({seg_ref} segment(s)), ratio {wall_ref / wall_run:.2f}")


if __name__ == "__main__":
    main()
