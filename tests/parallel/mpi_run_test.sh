#!/usr/bin/env bash
# capsflow on N MPI ranks against one rank, through the binary as a user runs it:
#  1. the 2D cavity (uniform 64^2, t = 0.3) on 2 and 3 ranks, and adaptive (levels 5-7,
#     repartitioned after every adaptation) on 3 ranks, writes the same diagnostics (every
#     column but the wall time), the same cells_final.csv and the same snapshots' count as
#     the run without mpirun;
#     the 3D duct (adaptive) on 4 ranks the same;
#  2. a checkpoint written on 2 ranks restarts on 3 and ends where the uninterrupted run ends;
#  3. carried faces (fluid.carry_faces) on 2 ranks: uniform as one rank, adaptive refused;
#     a uniform grid too big for this node, and a case with capsules, on 2 ranks are refused:
#     exit 2, one capsflow line, no output folder.
# Usage: mpi_run_test.sh MPIEXEC CAPSFLOW CASES_DIR
set -u
mpiexec=$1 capsflow=$2 cases=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
cavity=(run "$cases/cavity_2d.toml" --adapt off --set adapt.max_level=6 --set time.t_end=0.3
        --set output.interval=10 --set output.checkpoint=true --set output.checkpoint_interval=20 --quiet)
no_wall() { cut -d, -f1-11,13- "$1"; }

"$capsflow" "${cavity[@]}" --out "$dir/serial" || fail "serial run exit $?"
for n in 2 3; do
  "$mpiexec" -n $n --oversubscribe "$capsflow" "${cavity[@]}" --out "$dir/np$n" 2> "$dir/err$n" ||
    fail "$n ranks: exit $? $(cat "$dir/err$n")"
  diff <(no_wall "$dir/serial/diagnostics.csv") <(no_wall "$dir/np$n/diagnostics.csv") > /dev/null ||
    fail "$n ranks: diagnostics differ from one rank"
  cmp -s "$dir/serial/cells_final.csv" "$dir/np$n/cells_final.csv" || fail "$n ranks: cells_final.csv differs"
  [ "$(ls "$dir/serial" | grep -c vtu)" -eq "$(ls "$dir/np$n" | grep -c vtu)" ] || fail "$n ranks: snapshot count"
  [ -s "$dir/err$n" ] && fail "$n ranks wrote to stderr: $(cat "$dir/err$n")"
done
echo "2 and 3 ranks: diagnostics and final cells identical to one rank"

adaptive=(run "$cases/cavity_2d.toml" --set time.t_end=0.3 --set output.interval=10 --quiet)
"$capsflow" "${adaptive[@]}" --out "$dir/adaptive1" || fail "adaptive serial run exit $?"
"$mpiexec" -n 3 --oversubscribe "$capsflow" "${adaptive[@]}" --out "$dir/adaptive3" 2> "$dir/err" ||
  fail "adaptive on 3 ranks: exit $? $(cat "$dir/err")"
diff <(no_wall "$dir/adaptive1/diagnostics.csv") <(no_wall "$dir/adaptive3/diagnostics.csv") > /dev/null ||
  fail "adaptive on 3 ranks: diagnostics differ from one rank"
cmp -s "$dir/adaptive1/cells_final.csv" "$dir/adaptive3/cells_final.csv" || fail "adaptive on 3 ranks: cells differ"
echo "adaptive on 3 ranks: diagnostics and final cells identical to one rank"

# 3D: the square duct (inflow profile, wall-refined, adapted every 5 steps) on 4 ranks; the
# initial refinement runs on the distributed tree (each rank refines its part of a coarse start).
duct=(run "$cases/duct_3d.toml" --set time.t_end=0.3 --set output.vtu=false --set output.cells_csv=true --quiet)
"$capsflow" "${duct[@]}" --out "$dir/duct1" || fail "duct serial run exit $?"
"$mpiexec" -n 4 --oversubscribe "$capsflow" "${duct[@]}" --out "$dir/duct4" 2> "$dir/err" ||
  fail "duct on 4 ranks: exit $? $(cat "$dir/err")"
diff <(no_wall "$dir/duct1/diagnostics.csv") <(no_wall "$dir/duct4/diagnostics.csv") > /dev/null ||
  fail "duct on 4 ranks: diagnostics differ from one rank"
cmp -s "$dir/duct1/cells_final.csv" "$dir/duct4/cells_final.csv" || fail "duct on 4 ranks: cells differ"
echo "3D duct on 4 ranks: diagnostics and final cells identical to one rank"

checkpoint=$(ls "$dir/np2"/checkpoint_000020.h5) || fail "2 ranks wrote no checkpoint at step 20"
"$mpiexec" -n 3 --oversubscribe "$capsflow" "${cavity[@]}" --restart "$checkpoint" --out "$dir/restart" 2> "$dir/err" ||
  fail "restart on 3 ranks: exit $? $(cat "$dir/err")"
cmp -s "$dir/serial/cells_final.csv" "$dir/restart/cells_final.csv" || fail "restart on 3 ranks ends elsewhere"
echo "checkpoint of 2 ranks restarted on 3: same final cells"

# Carried faces (fluid.carry_faces): on 2 ranks a uniform run is one rank's; an adaptive
# one, whose faces a distributed adapt cannot carry, is refused with exit 2 and one line.
carry=(run "$cases/cavity_2d.toml" --set time.t_end=0.1 --set fluid.carry_faces=true --set output.vtu=false --quiet)
"$capsflow" "${carry[@]}" --adapt off --set adapt.max_level=6 --out "$dir/carry1" || fail "carried faces serial exit $?"
"$mpiexec" -n 2 --oversubscribe "$capsflow" "${carry[@]}" --adapt off --set adapt.max_level=6 --out "$dir/carry2" \
  2> "$dir/err" || fail "carried faces, uniform, on 2 ranks: exit $? $(cat "$dir/err")"
diff <(no_wall "$dir/carry1/diagnostics.csv") <(no_wall "$dir/carry2/diagnostics.csv") > /dev/null ||
  fail "carried faces, uniform, on 2 ranks: diagnostics differ from one rank"
"$mpiexec" -n 2 --oversubscribe "$capsflow" "${carry[@]}" --out "$dir/carry_adaptive" 2> "$dir/err"
status=$?
if [ "$status" -ne 2 ] || [ "$(grep -c '^capsflow:.*carry_faces' "$dir/err")" -ne 1 ] || [ -e "$dir/carry_adaptive" ]; then
  fail "carried faces, adaptive, on 2 ranks: expected exit 2 and one line; got $status: $(cat "$dir/err")"
fi
echo "carried faces: uniform on 2 ranks identical to one rank, adaptive refused: $(grep '^capsflow:' "$dir/err")"

# A uniform grid no node here can hold its share of: refused by every rank alike, one line.
"$mpiexec" -n 2 --oversubscribe "$capsflow" run "$cases/duct_3d.toml" --adapt off --set adapt.max_level=10 \
  --quiet --out "$dir/huge" 2> "$dir/err"
status=$?
lines=$(grep -c '^capsflow:' "$dir/err")
if [ "$status" -ne 2 ] || [ "$lines" -ne 1 ] || ! grep -q 'memory estimate .* on a node holding 2 of the 2 ranks' "$dir/err" ||
   [ -e "$dir/huge" ]; then
  fail "huge grid on 2 ranks: expected exit 2, one capsflow line naming the node's share, no folder; got $status: $(cat "$dir/err")"
fi
echo "huge grid on 2 ranks refused: $(grep '^capsflow:' "$dir/err")"

"$mpiexec" -n 2 --oversubscribe "$capsflow" run "$cases/relaxation_quick.toml" --quiet --out "$dir/caps" 2> "$dir/err"
status=$?
lines=$(grep -c '^capsflow:' "$dir/err")
if [ "$status" -ne 2 ] || [ "$lines" -ne 1 ] || [ -e "$dir/caps" ]; then
  fail "capsules on 2 ranks: expected exit 2, one capsflow line, no folder; got $status, $lines lines: $(cat "$dir/err")"
fi
echo "capsules on 2 ranks refused: $(grep '^capsflow:' "$dir/err")"
