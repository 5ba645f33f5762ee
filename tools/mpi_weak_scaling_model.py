#!/usr/bin/env python3
"""Weak scaling of the distributed flow step to 1024 ranks, from what capsflow_mpi_bench
measures (docs/parallel.md, "Measured").

Usage: tools/mpi_weak_scaling_model.py BENCH_LINES [--alpha 2e-6] [--beta 2e-10]

BENCH_LINES: output lines of `capsflow_mpi_bench uniform128 stokes STEPS` on 1 rank and on
2-4 ranks (key=value). The model:
- each rank keeps n cells of the finest level (the 2-rank run's share); P ranks hold a cube
  of n P cells, levels l = 0..L with 8^l cells each;
- a level with at most min(64 P, 32768) cells is replicated: one exchange brings every
  cell (point-to-point today: P - 1 messages; with MPI_Allgatherv: log2 P latencies);
- other levels: each rank's part is a Morton block of n_l = 8^l / P cells; its ghost cells
  are the shell of width w around it, g_l = (n_l^(1/3) + 2w)^3 - n_l (w = 2, 3 on the
  parent levels, which the dilation widens), times a shape factor fitted to the ghosts
  measured on 2-4 ranks (their parts touch the walls, which need no ghosts; Morton halves
  are slabs, quarters columns) for P <= 8, and 1 beyond (the busiest rank is inside the
  domain, its whole shell is ghosts); neighbour ranks min(26, P - 1);
- an exchange costs alpha per message and beta per byte; the exchanges per step and level
  are the measured ones, those after a red-black half-sweep carrying one colour (half the
  ghosts); the exchanges of every level at once (all_level_exchanges_per_step, each carrying
  all_level_fields_per_exchange fields) cost one message per neighbour and one gather of the
  replicated levels, and the bytes of every level's ghosts for each field; the compute time
  per cell and step is the 1-rank run's; no overlap of messages with work.
Prints, per rank count, the step time split into compute and messages, the level whose
messages cost most, and the efficiency; and checks the ghost model against the ranks
measured here.
"""
import math
import sys


def parse(path):
    rows = []
    for line in open(path):
        if "case=" not in line:
            continue
        kv = dict(x.split("=", 1) for x in line.split() if "=" in x)
        rows.append(kv)
    return rows


def ints(s):
    return [int(x) for x in s.split("/")] if s else []


def shell(n, w):
    side = n ** (1.0 / 3.0)
    return (side + 2 * w) ** 3 - n


def main():
    args = sys.argv[1:]
    if not args:
        print(__doc__)
        return 2
    alpha = float(args[args.index("--alpha") + 1]) if "--alpha" in args else 2e-6
    beta = float(args[args.index("--beta") + 1]) if "--beta" in args else 2e-10
    rows = parse(args[0])
    one = [r for r in rows if r["ranks"] == "1"]
    many = sorted((r for r in rows if r["ranks"] != "1"), key=lambda r: int(r["ranks"]))
    if not one or not many:
        print("need a 1-rank line and at least one line of 2-4 ranks")
        return 2
    cells = int(one[0]["leaves"])
    finest = round(math.log(cells, 8))
    t_cell = float(one[0]["s_per_step"]) / cells
    ref = many[0]
    exchanges = ints(ref["exchanges_per_step_per_level"])
    e_fine, e_mid, e_rep = exchanges[-1], max(exchanges[1:-1] or [exchanges[-1]]), exchanges[0]
    colour = ints(ref.get("colour_exchanges_per_step_per_level", "")) or [0] * len(exchanges)
    c_fine, c_mid = colour[-1], max(colour[1:-1] or [colour[-1]])
    e_all = float(ref.get("all_level_exchanges_per_step", 0))
    f_all = float(ref.get("all_level_fields_per_exchange", 0))

    # Shape factor of the ghost shells, from the measured non-replicated levels.
    print("ghost cells of the busiest rank, measured against the cube-shell model (w = 2 finest, 3 above):")
    factors = []
    for r in many:
        p = int(r["ranks"])
        g = ints(r["ghosts_per_level"])
        for l in range(len(g)):
            n_l = 8 ** l / p
            if 8 ** l <= min(64 * p, 32768):
                continue
            model = shell(n_l, 2 if l == finest else 3)
            factors.append(g[l] / model)
            print(f"  P = {p} level {l}: measured {g[l]:>8d}, cube shell {model:10.0f}, ratio {g[l] / model:5.2f}")
    factor = sum(factors) / len(factors)
    print(f"shape factor (mean ratio): {factor:.2f}")

    n = cells / int(ref["ranks"])  # finest cells per rank, kept in weak scaling
    print(f"\nweak scaling at {n:.3g} finest cells per rank, alpha = {alpha:g} s, beta = {beta:g} s/B, "
          f"{t_cell * 1e9:.1f} ns per cell and step, exchanges per step: finest {e_fine} ({c_fine} one-colour), "
          f"others {e_mid} ({c_mid} one-colour), replicated {e_rep}, all levels at once {e_all:g} "
          f"({f_all:g} fields each)")
    print(f"{'P':>5} {'levels':>6} {'compute s':>10} {'messages s':>10} {'worst level':>12} {'eff p2p':>8} "
          f"{'eff allgather':>13}")
    detail = []
    for p in [1, 2, 8, 64, 512, 1024]:
        levels = finest + round(math.log(p / int(ref["ranks"]), 8)) if p > 1 else finest
        levels = max(levels, finest)
        compute = t_cell * n * (8 / 7)  # leaves and parents
        comm_p2p = comm_ag = 0.0
        all_bytes = 0.0  # one all-level exchange of one field: every level's ghosts (or cells)
        worst = (0.0, -1)
        for l in range(levels + 1):
            total = 8 ** l
            if p == 1:
                break
            if total <= min(64 * p, 32768):
                cost_p2p = alpha * (p - 1) + beta * 8 * total
                cost_ag = alpha * math.ceil(math.log2(p)) + beta * 8 * total
                e = e_rep
                all_bytes += 8 * total
            else:
                g = (factor if p <= 8 else 1.0) * shell(total / p, 2 if l == levels else 3)
                e = e_fine if l == levels else e_mid
                halves = c_fine if l == levels else c_mid  # of e, one-colour exchanges
                # per exchange, averaged: alpha per message, beta per byte of the ghosts sent
                cost_p2p = cost_ag = alpha * min(26, p - 1) + beta * 8 * g * (1 - 0.5 * halves / e)
                all_bytes += 8 * g
            comm_p2p += e * cost_p2p
            comm_ag += e * cost_ag
            worst = max(worst, (e * cost_ag, l))
            if p == 1024:
                detail.append((l, total / p, "replicated" if total <= min(64 * p, 32768) else
                               f"ghosts/owned {g / (total / p):.1f}", e * cost_ag))
        if p > 1 and e_all > 0:  # the exchanges of every level at once
            whole = alpha * (min(26, p - 1) + math.ceil(math.log2(p))) + beta * all_bytes * f_all
            comm_p2p += e_all * whole
            comm_ag += e_all * whole
        eff_p2p = compute / (compute + comm_p2p)
        eff_ag = compute / (compute + comm_ag)
        print(f"{p:>5} {levels:>6} {compute:>10.3f} {comm_ag:>10.3f} {worst[1]:>12} {eff_p2p:>8.2f} {eff_ag:>13.2f}")
    print("\nP = 1024, per level (messages with MPI_Allgatherv on the replicated levels):")
    for l, per_rank, what, cost in detail:
        print(f"  level {l:>2}: {per_rank:12.3g} cells per rank, {what:>22}, {cost * 1e3:7.2f} ms per step")
    return 0


if __name__ == "__main__":
    sys.exit(main())
