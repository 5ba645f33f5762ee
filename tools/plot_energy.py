#!/usr/bin/env python3
"""The energy budget of a finished run (diagnostics.csv's energy columns, README "Outputs"):
where the membrane's elastic energy goes, and how well the balance closes.

usage: plot_energy.py RUN_DIR [RUN_DIR ...]   (one set of curves per run; the plot goes to the first)
Reads RUN_DIR/diagnostics.csv, writes RUN_DIR/energy.png and prints the budget at a few times.

Left: the membranes' elastic energy and the fluid's kinetic energy. Middle: what the two lost
since t = 0, E_membrane(0) + E_kinetic(0) - E_membrane - E_kinetic, against where it went:
viscous dissipation W_dissipation, what the adaptations removed, minus the work of the sides
(energy that came in), and the residual, the balance's error (docs/numerics.md, "Energy
budget"). Right: the powers: P_nodes (the membranes' forces against their nodes'
velocities), P_spread (the spread forces against the face velocity; equal to P_nodes when
the kernels are adjoint), the dissipation and the sides' work rate. The shares printed are
of E_membrane(0) + E_kinetic(0).
"""
import os
import sys

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

NEEDED = ("E_membrane", "E_kinetic", "W_dissipation", "W_boundary", "W_adaptation", "energy_residual")


def read(run):
    path = os.path.join(run, "diagnostics.csv")
    if not os.path.exists(path):
        sys.exit(f"plot_energy.py: {path} not found")
    d = np.genfromtxt(path, delimiter=",", names=True)
    missing = [c for c in NEEDED if c not in d.dtype.names]
    if missing:
        sys.exit(f"plot_energy.py: {path} has no column {', '.join(missing)} (written before the energy budget existed)")
    return d


def start_values(d):
    """E_membrane(0) + E_kinetic(0), from the residual's definition at any row."""
    return (d["energy_residual"][0] + d["E_membrane"][0] + d["E_kinetic"][0] + d["W_dissipation"][0]
            + d["W_adaptation"][0] - d["W_boundary"][0])


def main():
    runs = sys.argv[1:]
    if not runs:
        sys.exit(__doc__)
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.8))
    for run in runs:
        d = read(run)
        label = os.path.basename(os.path.normpath(run))
        total0 = start_values(d)
        lost = total0 - d["E_membrane"] - d["E_kinetic"]  # by the membranes and the fluid since t = 0
        ax[0].plot(d["t"], d["E_membrane"], "-", label=f"{label}: E_membrane")
        ax[0].plot(d["t"], d["E_kinetic"], "-", label=f"{label}: E_kinetic")
        ax[1].plot(d["t"], lost, "k-", label=f"{label}: lost by membranes and fluid")
        ax[1].plot(d["t"], d["W_dissipation"], "-", label=f"{label}: dissipated")
        if np.any(d["W_adaptation"] != 0):
            ax[1].plot(d["t"], d["W_adaptation"], ":", label=f"{label}: removed by adaptations")
        if np.any(d["W_boundary"] != 0):
            ax[1].plot(d["t"], -d["W_boundary"], "-.", label=f"{label}: minus the sides' work")
        ax[1].plot(d["t"], d["energy_residual"], "r--", label=f"{label}: residual (the scheme's error)")
        ax[2].plot(d["t"], d["P_nodes"], "-", label=f"{label}: P_nodes = F.V")
        ax[2].plot(d["t"], d["P_spread"], "--", label=f"{label}: P_spread = f.uf")
        ax[2].plot(d["t"], d["dissipation"], "-", label=f"{label}: dissipation")
        if np.any(d["P_boundary"] != 0):
            ax[2].plot(d["t"], d["P_boundary"], "-.", label=f"{label}: sides' work rate")
        print(f"{label}: E_membrane(0) + E_kinetic(0) = {total0:.6g}; shares of it below")
        for t in (0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 10.0):
            if d["t"][-1] >= t - 1e-9 and d["t"][0] <= t + 1e-9:
                i = int(np.argmin(np.abs(d["t"] - t)))
                share = (lambda x: 100 * x / total0) if total0 != 0 else (lambda x: float("nan"))
                print(f"{label}: t = {d['t'][i]:.3f}  membrane {share(d['E_membrane'][i]):.2f}%, kinetic "
                      f"{share(d['E_kinetic'][i]):.2f}%, dissipated {share(d['W_dissipation'][i]):.2f}%, "
                      f"sides' work {share(d['W_boundary'][i]):+.3f}%, adaptations {share(d['W_adaptation'][i]):+.3f}%, "
                      f"residual {share(d['energy_residual'][i]):+.3f}%")
    ax[0].set(xlabel="t", ylabel="energy", title="energies")
    ax[1].set(xlabel="t", ylabel="energy", title="where it went")
    ax[2].set(xlabel="t", ylabel="power", title="powers")
    ax[2].set_yscale("symlog", linthresh=1e-3 * max(1e-300, float(np.nanmax(np.abs(read(runs[0])["dissipation"])))))
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    out = os.path.join(runs[0], "energy.png")
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
