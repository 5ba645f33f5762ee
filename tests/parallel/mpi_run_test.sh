#!/usr/bin/env bash
# capsflow on N MPI ranks against one rank, through the binary as a user runs it:
#  1. the 2D cavity (uniform 64^2, t = 0.3) on 2 and 3 ranks (its .pvtu snapshots read back
#     as one rank's .vtu), and adaptive (levels 5-7,
#     repartitioned after every adaptation) on 3 ranks, writes the same diagnostics (every
#     column but the wall time), the same cells_final.csv and the same snapshots' count as
#     the run without mpirun;
#     the 3D duct (adaptive) on 4 ranks the same, and the constricted channel (embedded walls)
#     on 3 ranks;
#  2. a checkpoint written on 2 ranks restarts on 3 and ends where the uninterrupted run ends
#     (each rank reads its share of the rows); one of format version 2 restarts on 2 as on 1;
#  3. carried faces (fluid.carry_faces) on 2 and 3 ranks, uniform and adaptive, as one rank;
#     a warning (unconverged solves) printed once, not once per rank;
#     a uniform grid too big for this node, and a capsule with the cell-centred coupling, on 2
#     ranks are refused: exit 2, one capsflow line, no output folder (under mpirun -q, nothing else);
#  4. capsules on 2 to 4 ranks: the quick relaxation, a capsule in a tube (embedded walls) and
#     the seed case's scheme (midpoint nodes,
#     adaptations in time) write one rank's diagnostics, capsule rows and final nodes; a
#     checkpoint written on 2 ranks restarts on 1 and 3 into the uninterrupted run; a capsule
#     carried across ranks by an inflow changes owner and matches one rank; an inner fluid of
#     another viscosity and density, and one in the tube, match one rank on 3; a capsule blowing
#     up on one rank stops every rank with status 3 and one line; two and eight capsules in a
#     periodic box on 4 ranks match one rank, a rank hearing of at most 4 of the 8; the
#     implicit coupling in the channel and in the tube matches one rank on 3, with Euler's
#     and BDF2's rules.
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
  # Every rank writes its own rows into the one file: the file one rank writes (h5diff: every
  # dataset and attribute, the checksums included).
  h5diff "$dir/serial/checkpoint_000020.h5" "$dir/np$n/checkpoint_000020.h5" > /dev/null ||
    fail "$n ranks: the checkpoint differs from one rank's"
done
echo "2 and 3 ranks: diagnostics, final cells and checkpoints identical to one rank"

# Snapshots on N ranks: fluid_NNNNNN.pvtu with one piece per rank, read back with VTK's XML
# reader, hold the cells and values of one rank's fluid_NNNNNN.vtu.
for vtu in "$dir"/serial/fluid_*.vtu; do
  name=$(basename "$vtu" .vtu)
  /usr/bin/python3 "$(dirname "$0")/same_grid.py" "$vtu" "$dir/np3/$name.pvtu" > /dev/null ||
    fail "3 ranks: $name.pvtu differs from one rank's $name.vtu"
done
grep -q 'fluid_000010.pvtu' "$dir/np3/series.pvd" || fail "3 ranks: series.pvd does not list the .pvtu"
echo "3 ranks: every .pvtu snapshot holds one rank's cells and values"

# matches_one_rank LABEL RANKS ARGS...: capsflow ARGS on one rank and on RANKS ranks writes the
# same diagnostics (every column but the wall time) and, when written, the same final cells.
matches_one_rank() {
  local label=$1 n=$2; shift 2
  [ -e "$dir/$label.1/diagnostics.csv" ] || "$capsflow" "$@" --out "$dir/$label.1" || fail "$label on one rank: exit $?"
  "$mpiexec" -n "$n" --oversubscribe "$capsflow" "$@" --out "$dir/$label.$n" 2> "$dir/err" ||
    fail "$label on $n ranks: exit $? $(cat "$dir/err")"
  diff <(no_wall "$dir/$label.1/diagnostics.csv") <(no_wall "$dir/$label.$n/diagnostics.csv") > /dev/null ||
    fail "$label on $n ranks: diagnostics differ from one rank"
  if [ -e "$dir/$label.1/cells_final.csv" ]; then
    cmp -s "$dir/$label.1/cells_final.csv" "$dir/$label.$n/cells_final.csv" || fail "$label on $n ranks: cells differ"
  fi
  echo "$label on $n ranks: identical to one rank"
}
# refused LABEL PATTERN ARGS...: capsflow ARGS on 2 ranks exits 2 with one capsflow line
# matching PATTERN and creates no output folder.
refused() {
  local label=$1 pattern=$2; shift 2
  "$mpiexec" -n 2 --oversubscribe "$capsflow" "$@" --quiet --out "$dir/$label" 2> "$dir/err"
  local status=$?
  if [ "$status" -ne 2 ] || [ "$(grep -c '^capsflow:' "$dir/err")" -ne 1 ] || ! grep -q "^capsflow:.*$pattern" "$dir/err" ||
     [ -e "$dir/$label" ]; then
    fail "$label on 2 ranks: expected exit 2, one capsflow line with '$pattern', no folder; got $status: $(cat "$dir/err")"
  fi
  echo "$label on 2 ranks refused: $(grep '^capsflow:' "$dir/err")"
}

matches_one_rank adaptive-cavity 3 run "$cases/cavity_2d.toml" --set time.t_end=0.3 --set output.interval=10 --quiet

# Embedded walls: the constricted channel (a slab pierced by a circular throat, refined along
# its walls) on 3 ranks.
matches_one_rank constriction 3 run "$cases/constriction_stokes.toml" --set time.t_end=0.03 --set output.vtu=false \
  --set output.cells_csv=true --quiet

# 3D: the square duct (inflow profile, wall-refined, adapted every 5 steps) on 4 ranks; the
# initial refinement runs on the distributed tree (each rank refines its part of a coarse start).
matches_one_rank duct 4 run "$cases/duct_3d.toml" --set time.t_end=0.3 --set output.vtu=false \
  --set output.cells_csv=true --quiet

checkpoint=$(ls "$dir/np2"/checkpoint_000020.h5) || fail "2 ranks wrote no checkpoint at step 20"
"$mpiexec" -n 3 --oversubscribe "$capsflow" "${cavity[@]}" --restart "$checkpoint" --out "$dir/restart" 2> "$dir/err" ||
  fail "restart on 3 ranks: exit $? $(cat "$dir/err")"
cmp -s "$dir/serial/cells_final.csv" "$dir/restart/cells_final.csv" || fail "restart on 3 ranks ends elsewhere"
echo "checkpoint of 2 ranks restarted on 3: same final cells"

# A checkpoint of format version 2 (its checksums chain through the bytes: every rank reads
# it whole) restarts on 2 ranks as on one (tests/app/data, the small cavity of
# tests/app/small_cavity.hpp, carried faces).
# The case's text is the raw string of small_cavity.hpp.
sed -n '/R"(/,/^)"/{ s/.*R"(//; /^)"/d; p; }' "$(dirname "$0")/../app/small_cavity.hpp" > "$dir/small_cavity.toml"
grep -q '^max_level = 4' "$dir/small_cavity.toml" || fail "could not read the small cavity case from small_cavity.hpp"
v2=(run "$dir/small_cavity.toml" --quiet --set fluid.carry_faces=true --set output.vtu=false
    --restart "$(dirname "$0")/../app/data/checkpoint_v2_small_cavity.h5")
"$capsflow" "${v2[@]}" --out "$dir/v2.1" || fail "version-2 checkpoint on one rank: exit $?"
"$mpiexec" -n 2 --oversubscribe "$capsflow" "${v2[@]}" --out "$dir/v2.2" 2> "$dir/err" ||
  fail "version-2 checkpoint on 2 ranks: exit $? $(cat "$dir/err")"
diff <(no_wall "$dir/v2.1/diagnostics.csv") <(no_wall "$dir/v2.2/diagnostics.csv") > /dev/null ||
  fail "version-2 checkpoint on 2 ranks: diagnostics differ from one rank"
echo "checkpoint of format version 2 restarted on 2 ranks: one rank's diagnostics"

# Carried faces (fluid.carry_faces): on 2 ranks, uniform and adaptive (the faces travel
# through the distributed adaptations), one rank's numbers.
carry=(run "$cases/cavity_2d.toml" --set time.t_end=0.1 --set fluid.carry_faces=true --set output.vtu=false --quiet)
matches_one_rank carried-faces-uniform 2 "${carry[@]}" --adapt off --set adapt.max_level=6
matches_one_rank carried-faces-adaptive 3 "${carry[@]}"

# A warning is printed once, not once per rank: solves forced to miss their tolerance.
"$mpiexec" -n 2 --oversubscribe "$capsflow" "${cavity[@]}" --set time.t_end=0.02 --set fluid.multigrid.max_cycles=1 \
  --set fluid.multigrid.tolerance=1e-12 --out "$dir/warned" 2> "$dir/err" || fail "warning run: exit $?"
[ "$(grep -c '^warning:' "$dir/err")" -eq 1 ] || fail "2 ranks: expected one warning line, got: $(cat "$dir/err")"
echo "2 ranks: one warning line"

# A uniform grid no node here can hold its share of: refused by every rank alike.
refused huge-grid 'memory estimate .* on a node holding 2 of the 2 ranks' \
  run "$cases/duct_3d.toml" --adapt off --set adapt.max_level=10
refused cell-coupling 'staggered = false' run "$cases/relaxation_quick.toml" --set 'capsule[0].staggered=false'

# With Open MPI's mpirun -q (README), a refusal prints capsflow's one line and nothing else.
if "$mpiexec" --version 2>&1 | grep -qi "open-\?mpi\|openrte"; then
  "$mpiexec" -q -n 2 --oversubscribe "$capsflow" run "$cases/relaxation_quick.toml" --set 'capsule[0].staggered=false' \
    --quiet --out "$dir/quiet" > "$dir/all" 2>&1
  status=$?
  if [ "$status" -ne 2 ] || [ "$(wc -l < "$dir/all")" -ne 1 ] || ! grep -q '^capsflow:.*staggered' "$dir/all"; then
    fail "mpirun -q: expected exit 2 and capsflow's one line alone; got $status: $(cat "$dir/all")"
  fi
  echo "mpirun -q: one line"
fi

# Capsules on N ranks (issue 27): each capsule on the rank of its centroid, its nodes routed
# to the owners of their stencils' cells; every diagnostics column but the wall time, every
# capsule row and the final nodes to the last bit of one rank's.
capsule_matches_one_rank() {
  local label=$1 n=$2; shift 2
  matches_one_rank "$label" "$n" "$@"
  cmp -s "$dir/$label.1/capsules.csv" "$dir/$label.$n/capsules.csv" || fail "$label on $n ranks: capsules.csv differs"
  cmp -s "$dir/$label.1/membrane_final.csv" "$dir/$label.$n/membrane_final.csv" ||
    fail "$label on $n ranks: membrane_final.csv differs"
}
quick=(run "$cases/relaxation_quick.toml" --set adapt.max_level=4 --set 'capsule[0].nodes=642' --set time.t_end=0.02
       --set output.diagnostics_interval=1 --set output.vtu=false --quiet)
for n in 2 4; do capsule_matches_one_rank "quick-relaxation" "$n" "${quick[@]}"; done
# An inner fluid (5 times as viscous, twice as dense): each rank cuts the capsules whose box
# reaches its cells from the positions their owners send, in capsule order.
capsule_matches_one_rank "inner-fluid" 3 "${quick[@]}" --set 'capsule[0].viscosity_ratio=5' --set 'capsule[0].density_ratio=2'
# A capsule in a tube (embedded walls) on 3 ranks, within its kernels' reach of the wall: its
# stencils there are renormalised over the open faces on every rank it is routed to.
tube=(run "$cases/tube_capsule_stokes.toml" --set 'capsule[0].nodes=642' --set 'capsule[0].radius=0.6'
      --set time.t_end=0.006 --set output.diagnostics_interval=1 --set output.vtu=false --quiet)
capsule_matches_one_rank "tube-capsule" 3 "${tube[@]}"
# The same with an inner fluid 5 times as viscous and twice as dense, BDF2 and the implicit
# coupling: the walls' flux takes each cut cell's viscosity, the projection each face's 1/rho
# times its fluid fraction, the viscous solves the band's stabilisation (ghosts included).
capsule_matches_one_rank "tube-inner-fluid" 3 "${tube[@]}" --set 'capsule[0].viscosity_ratio=5' --set 'capsule[0].density_ratio=2' \
  --set 'time.coupling="implicit"' --set 'time.node_scheme="bdf2"'
# The implicit coupling (issue 30): its solve's inner products summed over the capsules
# exactly, its flow steps taken again from one start on every rank; in the channel and in
# the tube (embedded walls).
capsule_matches_one_rank "implicit-coupling" 3 "${quick[@]}" --set 'time.coupling="implicit"' --set time.dt=0.005
capsule_matches_one_rank "tube-implicit" 3 "${tube[@]}" --set 'time.coupling="implicit"'
# BDF2 (nodes and flow) with the step control: the capsules' last motion and the flow's
# u^(n-1) on every rank.
capsule_matches_one_rank "bdf2-step-control" 3 "${quick[@]}" --set 'time.coupling="auto"' --set 'time.node_scheme="bdf2"' \
  --set time.tolerance=0.1
# Steps too long for BDF2's prediction or for the implicit step's end (an element folds
# there) taken again shorter: the owner's failure is a shorter step's on every rank.
capsule_matches_one_rank "bdf2-steps-taken-again" 3 "${quick[@]}" --set 'capsule[0].radius=0.6' --set time.dt=4 \
  --set time.t_end=8 --set 'time.coupling="implicit"' --set 'time.node_scheme="bdf2"' --set time.tolerance=0.1
capsule_matches_one_rank "tube-bdf2" 3 "${tube[@]}" --set 'time.coupling="implicit"' --set 'time.node_scheme="bdf2"'
# The pressure iterated in BDF2's steps (GMRES over whole passes, inner products exact), in
# the tube: embedded walls and an inflow.
capsule_matches_one_rank "tube-bdf2-pressure" 3 "${tube[@]}" --set 'time.coupling="implicit"' --set 'time.node_scheme="bdf2"' \
  --set fluid.pressure_iterations=3
# The seed case's scheme (midpoint nodes, adaptations in time, faces carried through them).
seed=(run "$cases/relaxation_stokes.toml" --set adapt.max_level=5 --set adapt.wall_level=4 --set 'capsule[0].nodes=2562'
      --set time.t_end=0.02 --set output.diagnostics_interval=1 --set output.vtu=false --set output.checkpoint=false --quiet)
capsule_matches_one_rank "seed-scheme" 3 "${seed[@]}"
# A capsule carried along the channel by an inflow crosses from one rank's cells to the next:
# it changes owner during the run (the summary line counts it) and matches one rank.
carried=(run "$cases/relaxation_quick.toml" --set adapt.max_level=4 --set 'capsule[0].nodes=642' --set 'capsule[0].radius=0.5'
         --set 'capsule[0].shape=sphere' --set 'capsule[0].centre=[-2.0,0.0,0.0]' --set time.dt=0.002 --set time.t_end=0.5
         --set 'fluid.boundary.x_lo={type="inflow",profile="square_duct",mean_velocity=2.0}' --set output.vtu=false)
capsule_matches_one_rank "carried-capsule" 3 "${carried[@]}"  # not --quiet: the summary line
moves=$(tr '\r' '\n' < "$dir/err" | sed -n 's/^capsules moved between ranks \([0-9]*\) times.*$/\1/p')
[ -n "$moves" ] && [ "$moves" -ge 1 ] || fail "carried capsule on 3 ranks: expected it to change owner; got: $(cat "$dir/err")"
echo "carried capsule on 3 ranks: changed owner $moves time(s)"

# Two and eight capsules in a triply periodic box on 4 ranks: each run one rank's, and a rank
# hears only of the capsules near its cells (at most 4 of the 8: nothing scales with the
# capsules times the ranks; the summary line gives the most capsules routed to a rank).
box() {  # box CAPSULE_CENTRES...: the case with one ellipsoidal capsule at each centre
  printf '%s\n' 'name = "box"' '[domain]' 'roots = [2, 2, 2]' 'root_size = 2.0' 'origin = [-2.0, -2.0, -2.0]' \
    'periodic = [true, true, true]' '[fluid]' 'stokes = true' '[adapt]' 'min_level = 2' 'max_level = 4' '[time]' \
    'dt = 0.002' 't_end = 0.02' '[output]' 'vtu = false' 'diagnostics_interval = 1'
  for centre in "$@"; do
    printf '%s\n' '[[capsule]]' 'Ca = 0.1' 'nodes = 642' 'radius = 0.4' "centre = [$centre]" 'shape = "ellipsoid"' \
      'axes_factors = [1.3, 0.877058019307029, 0.877058019307029]'
  done
}
box "-1.0, -1.0, -1.0" "1.0, 1.0, 1.0" > "$dir/box2.toml"
box "-1.0, -1.0, -1.0" "1.0, -1.0, -1.0" "-1.0, 1.0, -1.0" "1.0, 1.0, -1.0" "-1.0, -1.0, 1.0" "1.0, -1.0, 1.0" \
    "-1.0, 1.0, 1.0" "1.0, 1.0, 1.0" > "$dir/box8.toml"
for k in 2 8; do
  capsule_matches_one_rank "box-$k-capsules" 4 run "$dir/box$k.toml"  # not --quiet: the summary line
  seen=$(tr '\r' '\n' < "$dir/err" | sed -n 's/.*at most \([0-9]*\) of the [0-9]* capsules.*/\1/p')
  [ -n "$seen" ] || fail "box with $k capsules on 4 ranks: no traffic line in $(cat "$dir/err")"
  if [ "$k" -eq 8 ] && [ "$seen" -gt 4 ]; then fail "box with 8 capsules on 4 ranks: $seen capsules routed to one rank"; fi
  echo "box with $k capsules on 4 ranks: one rank's numbers; at most $seen capsules routed to a rank"
done

# A capsule that blows up on one rank while the other rank's capsule is fine (two capsules at
# either end of the channel, the second far too stiff for dt): every rank stops with status
# 3 and one message, within seconds (no rank left waiting in a collective).
cat > "$dir/two.toml" <<'CASE'
name = "two_capsules"
[domain]
roots = [4, 1, 1]
root_size = 2.0
origin = [-4.0, -1.0, -1.0]
[fluid]
stokes = true
boundary = { x_lo = { type = "wall" }, x_hi = { type = "outflow" }, y_lo = { type = "wall" }, y_hi = { type = "wall" }, z_lo = { type = "wall" }, z_hi = { type = "wall" } }
[adapt]
min_level = 2
max_level = 4
wall_level = 3
[[capsule]]
Ca = 0.05
nodes = 642
radius = 0.5
centre = [-2.5, 0.0, 0.0]
shape = "ellipsoid"
axes_factors = [1.5, 0.8164965809277261, 0.8164965809277261]
[[capsule]]
Ca = 0.00001
nodes = 642
radius = 0.5
centre = [2.5, 0.0, 0.0]
shape = "ellipsoid"
axes_factors = [1.5, 0.8164965809277261, 0.8164965809277261]
[time]
t_end = 0.2
[output]
vtu = false
CASE
timeout 120 "$mpiexec" -q -n 2 --oversubscribe "$capsflow" run "$dir/two.toml" --out "$dir/two" --quiet > "$dir/all" 2>&1
status=$?
if [ "$status" -ne 3 ] || [ "$(grep -c '^capsflow:' "$dir/all")" -ne 1 ] || ! grep -q '^capsflow: capsule coupling: step [0-9]* .*capsule 1:' "$dir/all"; then
  fail "a blow-up on one rank: expected exit 3 and one capsflow line naming capsule 1; got $status: $(cat "$dir/all")"
fi
echo "a blow-up on one of 2 ranks: exit 3 on every rank, one line"

# Written on 2 ranks, restarted on 1 and on 3: the uninterrupted run's rows and nodes (the
# capsule's state and the projected faces travel in the one checkpoint file).
"$mpiexec" -n 2 --oversubscribe "$capsflow" "${seed[@]}" --set output.checkpoint=true --set output.checkpoint_interval=10 \
  --out "$dir/seed-written-on-2" 2> "$dir/err" || fail "seed scheme on 2 ranks with checkpoints: exit $? $(cat "$dir/err")"
for n in 1 3; do
  cp -r "$dir/seed-written-on-2" "$dir/seed-restart-$n"
  restart=("${seed[@]}" --set output.checkpoint=true --set output.checkpoint_interval=10 --out "$dir/seed-restart-$n"
           --restart "$dir/seed-restart-$n/checkpoint_000010.h5")
  if [ "$n" -eq 1 ]; then "$capsflow" "${restart[@]}" 2> "$dir/err"; else "$mpiexec" -n "$n" --oversubscribe "$capsflow" "${restart[@]}" 2> "$dir/err"; fi ||
    fail "restart on $n ranks: exit $? $(cat "$dir/err")"
  diff <(no_wall "$dir/seed-scheme.1/diagnostics.csv") <(no_wall "$dir/seed-restart-$n/diagnostics.csv") > /dev/null ||
    fail "checkpoint of 2 ranks restarted on $n: diagnostics differ from the uninterrupted run"
  cmp -s "$dir/seed-scheme.1/membrane_final.csv" "$dir/seed-restart-$n/membrane_final.csv" ||
    fail "checkpoint of 2 ranks restarted on $n: final nodes differ from the uninterrupted run"
  echo "capsule checkpoint of 2 ranks restarted on $n: the uninterrupted run's rows and nodes"
done
# The adaptive tree's levels, the capsule and the faces, written collectively on 3 ranks: the
# checkpoint one rank writes at the same step.
last=$(ls "$dir/seed-restart-1" | grep '^checkpoint_' | sort | tail -1)
[ "$last" != checkpoint_000010.h5 ] || fail "the restarted runs wrote no checkpoint of their own"
h5diff "$dir/seed-restart-1/$last" "$dir/seed-restart-3/$last" > /dev/null ||
  fail "the capsule checkpoint written on 3 ranks differs from one rank's ($last)"
echo "capsule checkpoint written on 3 ranks: the one of 1 rank ($last)"
