#!/usr/bin/env python3
"""Weak scaling of the capsule layer to 1024 ranks (one capsule per rank), from what
`capsflow run` prints on 1-4 ranks (docs/parallel.md, "Capsules: weak-scaling model").

Usage: tools/capsule_weak_scaling_model.py --one LOG1 --adapting LOG [LOG...] --still LOG [LOG...]
         [--alpha 2e-6] [--beta 2e-10] [--interval 4]

LOG1: stderr of the case on one rank without mpirun (its time per step is the compute).
--adapting: stderr of the case on 2-4 ranks adapting after every step; --still: the same
with adaptation off (adapt.interval=1000). From them, per step: the reductions and
all-to-all exchanges without adaptation, and those an adaptation adds; the words the
busiest rank sends (the capsule traffic line); the capsules routed to the busiest rank.

The model, at P ranks each holding one capsule and the same fluid as the 1-rank run:
- compute: the 1-rank run's time per step (membrane, spreading, fluid, interpolation, and
  the adaptation scaled from every step to one every --interval steps);
- capsule words: the busiest rank's words per step and capsule, measured, times the
  capsules within reach of a rank's part: the most measured on 2-4 ranks, and 8 from P = 8
  on (a capsule across a corner of the Morton parts reaches 8 in 3D), at beta per byte, one
  message per neighbour (min(26, P - 1)) at alpha;
- reductions: 2 log2 P latencies each (recursive doubling);
- all-to-all exchanges (parallel::all_to_all, the leaf migration: MPI_Alltoall of the
  counts, log2 P latencies and 4 P bytes, then MPI_Alltoallv, which Open MPI runs pairwise
  with every rank: P - 1 latencies), left per adaptation on the replicated levels' plan and
  the leaf migration;
- sparse exchanges (parallel::sparse_exchange: the node routing, the returned velocities,
  the capsule migration, the plan's questions and answers): min(26, P - 1) latencies and
  2 log2 P for the non-blocking barrier (the words are counted above); the last column is
  the efficiency if they were all-to-all exchanges, as before;
- the partition's split keys (one MPI_Allreduce of P words per adaptation) at 2 log2 P
  latencies and 16 P bytes;
- the flow's own messages are in tools/mpi_weak_scaling_model.py (0.92 at 1024 ranks), not
  repeated here.
Prints per P the step time's terms and the efficiency, and the term that stops scaling
first.
"""
import math
import re
import sys


def read(path):
    text = open(path).read().replace("\r", "\n")
    out = {}
    m = re.search(r"time per step: membrane ([\d.]+) ms, spreading ([\d.]+) ms, fluid ([\d.]+) ms, "
                  r"interpolation ([\d.]+) ms, adapt ([\d.]+) ms \((\d+) adaptations", text)
    if not m:
        sys.exit(f"{path}: no 'time per step' line")
    out["stages_ms"] = [float(x) for x in m.groups()[:5]]
    out["adaptations"] = int(m.group(6))
    m = re.search(r"collectives per step: ([\d.]+) reductions, ([\d.]+) all-to-all exchanges"
                  r"(?:, ([\d.]+) sparse exchanges)?", text)
    if m:
        out["reductions"], out["all_to_all"] = float(m.group(1)), float(m.group(2))
        out["sparse"] = float(m.group(3) or 0.0)
    m = re.search(r"at most (\d+) words sent a step by a rank, at most (\d+) of the (\d+) capsules", text)
    if m:
        out["words"], out["heard"], out["capsules"] = int(m.group(1)), int(m.group(2)), int(m.group(3))
    steps = re.findall(r"step (\d+)\s+t ", text)
    out["steps"] = int(steps[-1]) if steps else 0
    return out


def option(args, name, default):
    return float(args[args.index(name) + 1]) if name in args else default


def files(args, name):
    if name not in args:
        return []
    i = args.index(name) + 1
    out = []
    while i < len(args) and not args[i].startswith("--"):
        out.append(args[i])
        i += 1
    return out


def main():
    args = sys.argv[1:]
    one, adapting, still = files(args, "--one"), files(args, "--adapting"), files(args, "--still")
    if len(one) != 1 or not adapting or not still:
        print(__doc__)
        return 2
    alpha, beta, interval = option(args, "--alpha", 2e-6), option(args, "--beta", 2e-10), option(args, "--interval", 4)
    base = read(one[0])
    runs_a = [read(p) for p in adapting]
    runs_s = [read(p) for p in still]
    for r in runs_a + runs_s:
        if "reductions" not in r or "words" not in r:
            sys.exit("a 2-4 rank log lacks the collectives or the capsule traffic line")
    # Per step without adaptation, and what one adaptation adds (every step in the adapting runs).
    def per_step_and_adaptation(key):
        step = max(r[key] for r in runs_s)
        return step, max(a[key] - step for a in runs_a)
    red_step, red_adapt = per_step_and_adaptation("reductions")
    a2a_step, a2a_adapt = per_step_and_adaptation("all_to_all")
    sparse_step, sparse_adapt = per_step_and_adaptation("sparse")
    words_per_capsule = max(r["words"] / r["heard"] for r in runs_s)
    heard_measured = max(r["heard"] for r in runs_s)
    membrane, spreading, fluid, interpolation, adapt = base["stages_ms"]
    adapt_every = adapt * base["steps"] / max(1, base["adaptations"])  # ms per adaptation
    compute = 1e-3 * (membrane + spreading + fluid + interpolation + adapt_every / interval)
    print(f"measured: one rank {compute * 1e3:.1f} ms a step (adapting every {interval:g} steps); per step "
          f"{red_step:.1f} reductions, {a2a_step:.2f} all-to-all and {sparse_step:.2f} sparse exchanges, an "
          f"adaptation adds {red_adapt:.1f}, {a2a_adapt:.2f} and {sparse_adapt:.2f}; the busiest rank sends "
          f"{words_per_capsule:.0f} words a step per capsule it hears of (at most {heard_measured} heard on 2-4 ranks)")
    print(f"alpha = {alpha:g} s, beta = {beta:g} s/B\n")
    head = (f"{'P':>5} {'compute ms':>10} {'words ms':>9} {'reduce ms':>9} {'a2a ms':>8} {'sparse ms':>9} "
            f"{'split ms':>8} {'efficiency':>10} {'all dense':>9}")
    print(head)
    first = last = None
    for p in [2, 4, 8, 64, 512, 1024]:
        log = math.ceil(math.log2(p))
        neighbours = min(26, p - 1)
        heard = heard_measured if p < 8 else 8
        words = neighbours * alpha + beta * 8 * words_per_capsule * heard
        reductions = (red_step + red_adapt / interval) * 2 * log * alpha
        dense_calls = a2a_step + a2a_adapt / interval
        sparse_calls = sparse_step + sparse_adapt / interval
        counts = log * alpha + beta * 4 * p  # MPI_Alltoall of the counts
        dense_cost = counts + (p - 1) * alpha
        dense = dense_calls * dense_cost
        sparse = sparse_calls * (neighbours * alpha + 2 * log * alpha)
        split = (2 * log * alpha + beta * 16 * p) / interval
        terms = {"capsule words": words, "reductions": reductions, "all-to-all exchanges": dense,
                 "sparse exchanges": sparse, "split keys": split}
        eff = compute / (compute + words + reductions + dense + sparse + split)
        # What it was with every exchange an all_to_all.
        eff_dense = compute / (compute + words + reductions + (dense_calls + sparse_calls) * dense_cost + split)
        big = max(terms, key=terms.get)
        if first is None and terms[big] > 0.05 * compute:
            first = (p, big, terms[big])
        last = (p, big, terms[big])
        print(f"{p:>5} {compute * 1e3:>10.2f} {words * 1e3:>9.3f} {reductions * 1e3:>9.3f} {dense * 1e3:>8.3f} "
              f"{sparse * 1e3:>9.3f} {split * 1e3:>8.3f} {eff:>10.2f} {eff_dense:>9.2f}")
    if first:
        print(f"\nfirst term above 5% of the compute: {first[1]} at P = {first[0]} ({first[2] * 1e3:.2f} ms a step)")
    else:
        print("\nno term reaches 5% of the compute up to 1024 ranks")
    print(f"largest term at P = {last[0]}: {last[1]} ({last[2] * 1e3:.2f} ms a step)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
