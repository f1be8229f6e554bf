#!/usr/bin/env bash
# Installs the Debian packages that are missing (apt-get, as root) and builds the solver
# (Release, -O3). Idempotent: a second call only rebuilds what changed.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

packages=(
  build-essential cmake pkg-config
  libeigen3-dev libsuitesparse-dev libhypre-dev libopenmpi-dev libopenblas0-openmp libhdf5-dev libgtest-dev
  nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  python3 python3-numpy python3-scipy python3-h5py python3-meshio python3-matplotlib python3-pytest
  libtorch-dev python3-torch
  openfoam openfoam-examples
)
missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q "${missing[@]}"
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
