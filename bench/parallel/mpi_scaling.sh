#!/usr/bin/env bash
# Strong scaling on this machine's cores: the same flow step as 1 rank x 1 thread, 1 rank x
# 2 threads (OpenMP) and 2 ranks x 1 thread (MPI), interleaved REPEATS times (shared
# machines drift), then the ratios of the medians: MPI speed-up (2 ranks against 1) and
# MPI against OpenMP on the same two cores.
# Usage: bench/parallel/mpi_scaling.sh BUILD_DIR [CASE=uniform128|seed_shell] [PHYSICS=stokes|ns|adapt] [STEPS=5] [REPEATS=3]
# (adapt: the seed shell's adaptation alone, STEPS adaptations; the times are per adaptation)
set -eu
build=$1 case=${2:-uniform128} physics=${3:-stokes} steps=${4:-5} repeats=${5:-3}
bench="$build/bench/parallel/capsflow_mpi_bench"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=$(mktemp)
for r in $(seq "$repeats"); do
  OMP_NUM_THREADS=1 "$bench" "$case" "$physics" "$steps" | sed 's/^/config=1x1 /' >> "$out"
  OMP_NUM_THREADS=2 "$bench" "$case" "$physics" "$steps" | sed 's/^/config=1x2 /' >> "$out"
  OMP_NUM_THREADS=1 mpirun -np 2 --bind-to core "$bench" "$case" "$physics" "$steps" | sed 's/^/config=2x1 /' >> "$out"
done
cat "$out"
python3 - "$out" <<'PY'
import re, sys, statistics
rows = [dict(kv.split('=', 1) for kv in line.split()) for line in open(sys.argv[1])]
for r in rows:
    r.setdefault('s_per_step', r.get('s_per_adapt'))  # adapt: seconds per adaptation
med = {c: statistics.median(float(r['s_per_step']) for r in rows if r['config'] == c) for c in ('1x1', '1x2', '2x1')}
mpi = [r for r in rows if r['config'] == '2x1' and 'bytes_per_step' in r]
print(f"median s/step: 1 rank x 1 thread {med['1x1']:.4f}, 1 rank x 2 threads {med['1x2']:.4f}, 2 ranks x 1 thread {med['2x1']:.4f}")
print(f"speed-up 2 ranks / 1 rank: {med['1x1'] / med['2x1']:.2f} (target >= 1.5)")
print(f"OpenMP 1x2 / 1x1: {med['1x1'] / med['1x2']:.2f}")
print(f"MPI 2x1 time / OpenMP 1x2 time: {med['2x1'] / med['1x2']:.2f} (target <= 1.10)")
# The same ratios per repeat (the three runs of one repeat follow each other, so a drift of
# the machine's speed over minutes cancels in them), and their medians.
per = {c: [float(r['s_per_step']) for r in rows if r['config'] == c] for c in ('1x1', '1x2', '2x1')}
speedups = sorted(a / b for a, b in zip(per['1x1'], per['2x1']))
versus = sorted(b / a for a, b in zip(per['1x2'], per['2x1']))
print(f"per repeat: speed-up median {statistics.median(speedups):.2f} (range {speedups[0]:.2f}-{speedups[-1]:.2f}), "
      f"MPI/OpenMP median {statistics.median(versus):.2f} (range {versus[0]:.2f}-{versus[-1]:.2f})")
if not mpi:
    sys.exit(0)
print(f"2 ranks: bytes sent per step by the busiest rank {statistics.median(float(r['bytes_per_step']) for r in mpi):.3g}, "
      f"fraction of the step waiting {statistics.median(float(r['wait_fraction']) for r in mpi):.3f}, "
      f"of which the messages alone {statistics.median(float(r['exchange_fraction']) for r in mpi):.3f} (the rest: imbalance)")
print(f"2 ranks: fraction of the step waiting in the relaxation's one-colour exchanges "
      f"{statistics.median(float(r['wait_colour_fraction']) for r in mpi):.3f}, in reductions (not in the waiting above) "
      f"{statistics.median(float(r['reduce_fraction']) for r in mpi):.3f}")
PY
rm -f "$out"
