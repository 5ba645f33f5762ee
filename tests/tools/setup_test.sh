#!/usr/bin/env bash
# tools/setup.sh against fake dpkg-query, apt-get and id on PATH: it must stop with a clear
# message, and never run a real install, when apt would remove a package (issue 15, item 12).
set -euo pipefail
setup="$1"
fake=$(mktemp -d)
trap 'rm -rf "$fake"' EXIT
cat > "$fake/dpkg-query" <<'SH'
#!/usr/bin/env bash
for p in $FAKE_INSTALLED; do [ "$p" = "${@: -1}" ] && { echo "install ok installed"; exit 0; }; done
exit 1
SH
cat > "$fake/apt-get" <<'SH'
#!/usr/bin/env bash
echo "apt-get $*" >> "$FAKE_LOG"
[[ " $* " == *" -s "* ]] && printf '%b' "${FAKE_PLAN:-}"
exit 0
SH
printf '#!/usr/bin/env bash\necho 0\n' > "$fake/id"
chmod +x "$fake"/*
export PATH="$fake:$PATH" FAKE_LOG="$fake/log"
all="build-essential cmake ninja-build pkg-config libeigen3-dev libopenmpi-dev openmpi-bin libhdf5-openmpi-dev
hdf5-tools libtomlplusplus-dev libcli11-dev libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev python3-numpy
python3-matplotlib python3-sympy"
fail() { echo "FAIL: $*"; exit 1; }

# ParaView's Python package installed, libvtk9-dev missing: the known conflict, named.
: > "$FAKE_LOG"
if out=$(FAKE_INSTALLED="$all python3-paraview" bash "$setup" 2>&1); then fail "conflict not detected: $out"; fi
[[ "$out" == *python3-paraview* && "$out" == *--no-install-recommends* ]] || fail "unclear message: $out"
grep -q "install -y" "$FAKE_LOG" && fail "installed despite the conflict"

# Any other install that apt would resolve by removing a package.
: > "$FAKE_LOG"
if out=$(FAKE_INSTALLED="$all" FAKE_PLAN='Inst libvtk9-dev (9.1)\nRemv python3-paraview [5.11]\n' bash "$setup" 2>&1); then
  fail "removal not detected: $out"
fi
[[ "$out" == *"would remove python3-paraview"* ]] || fail "removal not named: $out"
grep -q "install -y" "$FAKE_LOG" && fail "installed despite the removal"

# No conflict: installs, with --no-remove as a second guard.
: > "$FAKE_LOG"
FAKE_INSTALLED="$all" FAKE_PLAN='Inst libvtk9-dev (9.1)\n' bash "$setup" > /dev/null || fail "a clean install failed"
grep -q "install -y -qq --no-install-recommends --no-remove libvtk9-dev" "$FAKE_LOG" || fail "no install: $(cat "$FAKE_LOG")"

# Everything present: nothing to do.
: > "$FAKE_LOG"
out=$(FAKE_INSTALLED="$all libvtk9-dev" bash "$setup")
[[ "$out" == *"all dependencies present"* && ! -s "$FAKE_LOG" ]] || fail "touched apt with nothing missing: $out"
echo "setup.sh: conflicts detected, nothing removed"
