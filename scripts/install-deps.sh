#!/usr/bin/env bash
# Installs the Debian packages knitflow needs, only those missing; silent when all are present.
set -euo pipefail
packages=(
  g++ cmake make pkg-config
  libopenmpi-dev openmpi-bin libhdf5-openmpi-dev hdf5-tools libmetis-dev
  libgtest-dev libtomlplusplus-dev libcli11-dev libpng-dev
  libegl-dev libopengl-dev libepoxy-dev libglm-dev libegl-mesa0 libgl1-mesa-dri
  python3 python3-h5py python3-matplotlib python3-numpy
  clang libclang-rt-14-dev procps
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
