#!/usr/bin/env bash
# Installs the Debian 12 packages Plumage builds against, but only those that are
# missing, so a second run on a prepared machine costs no network and no root.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config git
  clang-format           # the style check (tests: format.clang_format)
  libembree-dev          # ray tracing (Embree 3)
  libcgal-dev            # mesh validation and repair
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libblosc-dev  # spongy volumes; OpenVDB's CMake module needs boost-iostreams
  libboost-dev           # Boost.Math special functions and distributions (analysis/statistics)
  libeigen3-dev          # small dense linear algebra (transfer matrices, fits)
  libhdf5-dev            # records (C and C++ APIs)
  libgtest-dev libgmock-dev libbenchmark-dev
  liblcms2-dev           # Little-CMS: cross-check of Lab/CIEDE2000 in tests only
  libcli11-dev           # command line
  libtomlplusplus-dev    # study files
  libfmt-dev
  libfftw3-dev           # power spectra of spongy volumes (sim/wave)
  libstb-dev libpng-dev  # PNG output
  libopenexr-dev         # HDR and spectral images (OpenEXR 3)
  python3-numpy python3-h5py python3-matplotlib  # plots; these belong to /usr/bin/python3
  pybind11-dev python3-pybind11 python3-dev  # the `plumage` Python module (python/), for /usr/bin/python3
  python3-pytest         # its tests (python/tests, run by ctest)
  openmpi-bin libopenmpi-dev  # `mpirun -np N plumage run STUDY` (common/distributed.h; tests/mpi)
  libmeep-dev            # full wave (sim/fullwave): Meep's FDTD library, linked
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  exit 0
fi

echo "plumage: installing missing Debian packages: ${missing[*]}" >&2
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "plumage: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
