#!/usr/bin/python3
"""The plots of a convergence study written by `capsflow study` (docs/studies.md).

usage: plot_study.py STUDY_DIR

Reads STUDY_DIR/study.csv, orders.csv, equal_error.csv and members/*/diagnostics.csv and
writes, each with the CSV of the data it shows:
  error_vs_<x>.png   the seed's four criteria (N_inf, vmax, |dS/S0|, |dV/V0|) at t_end against
                     the ladder's x (the seed's Figure 4 a-d), one line per series, the
                     observed order written on each segment;
  error_vs_cost.png  the study's error against mean cells, wall time and CPU time, one line
                     per series (uniform and adaptive on one plot);
  d12.png            D12(t) and D12_bbox(t) of the plotted members (the seed's Figure 5).
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare_runs import load  # noqa: E402  (diagnostics.csv as a numpy record array)

UNITS = {"dt": "l/V", "dx": "l", "N_inf": "l", "vmax": "V", "D12_err": "-", "vmax_err": "V"}
CRITERIA = [("N_inf", "N_inf: max node error (l)"), ("vmax", "v_max at t_end (V)"),
            ("area_rel", "|dS/S0| at t_end"), ("volume_rel", "|dV/V0| at t_end")]
# Criteria that are errors (zero for the exact solution), whose observed orders are written on
# the plot; vmax and dS/S0 are too only once the capsule has relaxed (the seed's t = 10).
ORDERED = ("N_inf", "volume_rel")


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def usable(v):
    return math.isfinite(v) and v > 0


def series_label(name):
    """'adapt=false+...' reads better as 'uniform'/'adaptive'."""
    if not name:
        return "all members"
    return name.replace("adapt=false", "uniform").replace("adapt=true", "adaptive")


def write_csv(path, header, table):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(table)


def x_axis(study, members):
    """The ladder key on the x axis (orders.csv's), and the study.csv column to plot against:
    dx for max_level (a length, l), the key's own column otherwise."""
    keys = [k for k in study[0].keys() if "." in k or "[" in k]
    orders = rows(os.path.join(members, "..", "orders.csv"))
    key = keys[0]
    if orders:
        xs = {o["x_coarse"] for o in orders}
        for k in keys:
            if xs <= {r[k] for r in study}:
                key = k
                break
    label = key.split(".")[-1].split("[")[0]
    if label == "max_level":
        return key, "dx", "dx: finest cell (l)"
    unit = UNITS.get(label)
    return key, key, f"{label} ({unit})" if unit else label


def plot_criteria(out, study, orders, key, column, xlabel):
    name = column if column != key else key.split(".")[-1].split("[")[0]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    table = []
    by_series = {}
    for r in study:
        if r["t_end"]:
            by_series.setdefault(r["series"], []).append(r)
    for (crit, ylabel), ax in zip(CRITERIA, axes.flat):
        for index, (series, members) in enumerate(by_series.items()):
            pts = []
            for r in members:
                v = abs(number(r[crit]))
                if crit == "N_inf" and r["member"] == r["reference"]:
                    continue
                pts.append((number(r[column]), v, r["member"]))
            pts = sorted(p for p in pts if usable(p[1]))
            if not pts:
                continue
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=series_label(series))
            for o in orders if crit in ORDERED else []:
                if o["series"] == series and o["criterion"] == crit and math.isfinite(number(o["order"])):
                    xs = [number(r[column]) for r in members if r[key] in (o["x_coarse"], o["x_fine"])]
                    if len(xs) == 2:
                        xm = math.sqrt(xs[0] * xs[1])
                        ym = math.sqrt(number(o["e_coarse"]) * number(o["e_fine"]))
                        ax.annotate(f"{number(o['order']):.2f}", (xm, ym), textcoords="offset points",
                                    xytext=(0, 6 + 10 * index), fontsize=8, ha="center",
                                    color=ax.lines[-1].get_color())
        ax.set(xlabel=xlabel, ylabel=ylabel)
        ax.grid(alpha=0.3, which="both")
        if ax.lines:
            title = "series (observed order on each segment)" if crit in ORDERED else "series"
            ax.legend(fontsize=8, title=title, title_fontsize=7)
        else:
            ax.text(0.5, 0.5, "no data (no capsule, or no error > 0)", transform=ax.transAxes, ha="center")
    for r in study:
        table.append([r["series"], r["member"], r[column]] + [r[c] for c, _ in CRITERIA])
    fig.suptitle("criteria at t_end against " + xlabel)
    fig.tight_layout()
    png = os.path.join(out, f"error_vs_{name}.png")
    fig.savefig(png, dpi=110)
    plt.close(fig)
    write_csv(os.path.join(out, f"error_vs_{name}.csv"), ["series", "member", column] + [c for c, _ in CRITERIA], table)
    print(f"wrote {png}")


def plot_cost(out, study, error, key):
    column = {"N_inf": "N_inf", "D12": "D12_err", "vmax": "vmax_err"}[error]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    table = []
    by_series = {}
    for r in study:
        if r["t_end"] and r["member"] != r["reference"] and usable(number(r[column])):
            by_series.setdefault(r["series"], []).append(r)
            table.append([r["series"], r["member"], r[column], r["cells_mean"], r["wall_s"], r.get("cpu_s", "nan")])
    if not by_series:
        print(f"plot_study.py: no member has a positive {column}; error_vs_cost.png not drawn")
        return
    costs = ["cells_mean", "wall_s", "cpu_s"]
    labels = ["mean leaf cells", "wall time of the time loop (s)", "CPU time of the run, all threads (s)"]
    for ax, cost, xlabel in zip(axes, costs, labels):
        for series, members in by_series.items():
            label = key.split(".")[-1].split("[")[0]
            pts = sorted((number(r.get(cost)), number(r[column]), f"{label}={r[key]}") for r in members)
            pts = [p for p in pts if usable(p[0])]  # cpu_s: absent from studies of older builds
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=series_label(series))
            for p in pts:
                ax.annotate(p[2], (p[0], p[1]), textcoords="offset points", xytext=(4, 4), fontsize=6)
        unit = UNITS.get(column, "-")
        ax.set(xlabel=xlabel, ylabel=f"{column} at t_end against the reference ({unit})")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    references = {r["reference"] for r in study}
    reference = references.pop() if len(references) == 1 else "each series' finest member"
    fig.suptitle(f"error against cost (reference: {reference})")
    fig.tight_layout()
    png = os.path.join(out, "error_vs_cost.png")
    fig.savefig(png, dpi=110)
    plt.close(fig)
    write_csv(os.path.join(out, "error_vs_cost.csv"), ["series", "member", column] + costs, table)
    print(f"wrote {png}")


def plot_d12(out, study):
    fig, ax = plt.subplots(figsize=(8, 5))
    table = []
    for r in study:
        if r["plotted"] != "1" or not r["t_end"]:
            continue
        d = load(os.path.join(out, "members", r["member"]))
        if not any(math.isfinite(v) for v in d["D12"]):
            continue
        line, = ax.plot(d["t"], d["D12"], "-", label=f"{r['member']}: D12 (inertia ellipsoid)")
        ax.plot(d["t"], d["D12_bbox"], "--", color=line.get_color(), label=f"{r['member']}: D12_bbox (bounding box)")
        table += [[r["member"], t, a, b] for t, a, b in zip(d["t"], d["D12"], d["D12_bbox"])]
    if not table:
        plt.close(fig)
        print("plot_study.py: no member has a capsule; d12.png not drawn")
        return
    ax.set(xlabel="t (l/V)", ylabel="Taylor parameter", title="D12(t) and D12_bbox(t)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    png = os.path.join(out, "d12.png")
    fig.savefig(png, dpi=110)
    plt.close(fig)
    write_csv(os.path.join(out, "d12.csv"), ["member", "t", "D12", "D12_bbox"], table)
    print(f"wrote {png}")


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    study = rows(os.path.join(out, "study.csv"))
    orders = rows(os.path.join(out, "orders.csv"))
    error = rows(os.path.join(out, "equal_error.csv"))
    with open(os.path.join(out, "equal_error.csv")) as f:
        error = f.readline().strip().split(",")[1]
    key, column, xlabel = x_axis(study, os.path.join(out, "members"))
    plot_criteria(out, study, orders, key, column, xlabel)
    plot_cost(out, study, error, key)
    plot_d12(out, study)


if __name__ == "__main__":
    main()
