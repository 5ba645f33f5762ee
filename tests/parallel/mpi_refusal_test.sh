#!/usr/bin/env bash
# mpirun -np 2 capsflow run CASE: refused with exit status 2 and one capsflow line (from rank
# 0 only), no output folder written. Usage: mpi_refusal_test.sh MPIEXEC CAPSFLOW CASE
set -u
mpiexec=$1 capsflow=$2 case_file=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$mpiexec" -n 2 --oversubscribe "$capsflow" run "$case_file" --quiet --out "$dir/out" 2> "$dir/err"
status=$?
lines=$(grep -c '^capsflow:' "$dir/err")
if [ "$status" -ne 2 ] || [ "$lines" -ne 1 ] || [ -e "$dir/out" ]; then
  echo "expected exit 2, one capsflow line and no output folder; got exit $status, $lines lines:"
  cat "$dir/err"
  exit 1
fi
echo "refused as promised: $(grep '^capsflow:' "$dir/err")"
