#!/usr/bin/env bash
# Installs every build and run dependency of capsflow from Debian 12 packages.
# Idempotent: packages already present are skipped by apt; safe to run again.
# Never removes a package: if apt would have to (a conflict), it stops and says which.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev
  libopenmpi-dev openmpi-bin
  libhdf5-openmpi-dev hdf5-tools
  libvtk9-dev
  libtomlplusplus-dev libcli11-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-numpy python3-matplotlib python3-sympy
)

installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

missing=()
for p in "${packages[@]}"; do
  installed "$p" || missing+=("$p")
done

if ! ((${#missing[@]})); then
  echo "capsflow setup: all dependencies present"
  exit 0
fi

# The known conflict: libvtk9-dev depends on python3-vtk9, which python3-paraview (a
# recommend of "apt-get install paraview") conflicts with; apt would resolve it by removing
# ParaView's Python support, or later ParaView's install would remove libvtk9-dev.
if installed python3-paraview && [[ " ${missing[*]} " == *" libvtk9-dev "* ]]; then
  cat >&2 <<'MSG'
capsflow setup: python3-paraview is installed, and it conflicts with python3-vtk9, which
libvtk9-dev (needed to build capsflow) depends on. Nothing was changed. To have both ParaView
and the build dependencies, keep ParaView without its Python package:
  apt-get remove python3-paraview && apt-get install --no-install-recommends paraview
then run tools/setup.sh again (see README.md, "ParaView and the build dependencies").
MSG
  exit 1
fi

sudo_cmd=""
[ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
echo "capsflow setup: installing ${missing[*]}"
$sudo_cmd apt-get update -qq
# Ask apt what it would do first: any other conflict shows as packages to remove.
removals=$(apt-get install -s --no-install-recommends "${missing[@]}" 2>/dev/null | awk '/^Remv /{print $2}' | tr '\n' ' ')
if [ -n "$removals" ]; then
  echo "capsflow setup: installing ${missing[*]} would remove ${removals}(a package conflict);" \
       "nothing was changed. Resolve it by hand (apt-get install -s ... shows the plan)." >&2
  exit 1
fi
DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends --no-remove "${missing[@]}"
