#!/usr/bin/env bash
# Installs the Debian 12 packages msim needs, only those missing. Needs root (or sudo).
set -euo pipefail
pkgs=(build-essential cmake pkg-config petsc-dev slepc-dev libeigen3-dev libcgal-dev libmetis-dev libtet1.5-dev tetgen
      openmpi-bin libopenmpi-dev libhdf5-openmpi-dev libopenblas0-pthread python3-matplotlib python3-numpy python3-h5py ffmpeg strace)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq "${missing[@]}" >/dev/null
echo "install-deps: done"
