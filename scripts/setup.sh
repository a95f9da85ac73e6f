#!/usr/bin/env bash
# Installs every Debian 12 package vdbscatter needs to build, test, run and bench (plots).
# Safe to run again: apt-get skips what is already installed.
# munge and Slurm are for tests/test_slurm.sh, which runs daemons of its own (own key, socket,
# ports, config). The packages' services: slurmctld and slurmd do not start without
# /etc/slurm/slurm.conf; munged may start (under systemd, or through /etc/init.d where no
# policy-rc.d forbids it) with the package's generated key on /run/munge: harmless, unused.
# --blender also installs Blender (large; for tests/test_blender.py and docs/handoff.md).
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libopenvdb-dev libnanovdb-dev libopenvdb-tools python3 python3-openvdb libboost-iostreams-dev
  libegl-dev libegl-mesa0 libgl1-mesa-dri libgl-dev libepoxy-dev
  libglfw3-dev xvfb xauth libpng-dev libstb-dev libopenexr-dev openexr
  liblapacke-dev libopenblas0-pthread libcjson-dev libcmocka-dev libxxhash-dev
  python3-matplotlib python3-numpy
  help2man man-db
  clang libclang-rt-14-dev llvm
  munge slurmctld slurmd slurm-client
)
for arg in "$@"; do
  case "$arg" in
    --blender) packages+=(blender) ;;
    *) echo "usage: scripts/setup.sh [--blender]" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  SUDO="sudo"
fi
echo "setup: installing ${missing[*]}"
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
