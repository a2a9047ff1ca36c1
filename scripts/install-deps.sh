#!/usr/bin/env bash
# Installs the Debian 12 packages Plumage builds against, but only those that are
# missing, so a second run on a prepared machine costs no network and no root.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

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
  python3-venv           # `python3 -m venv`: `pip install .` into a fresh venv (python.venv_install)
  openmpi-bin libopenmpi-dev  # `mpirun -np N plumage run STUDY` (common/distributed.h; tests/mpi)
  libmeep-dev            # full wave (sim/fullwave): Meep's FDTD library, linked
  libhdf5-openmpi-103-1  # needed by Meep's MPI build, unpacked beside the serial one (below)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive

if ((${#missing[@]} > 0)); then
  echo "plumage: installing missing Debian packages: ${missing[*]}" >&2
  if ((${#sudo_cmd[@]} > 0)) && ! command -v sudo >/dev/null; then
    echo "plumage: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Meep's MPI build (plumage_fullwave_mpi, tests/mpi): Debian's libmeep-mpi-default30 and -dev
# conflict with libmeep30/libmeep-dev (the same file names), so they are not installed but
# unpacked into the build folder, where CMake finds them (PLUMAGE_MEEP_MPI_PREFIX) and links
# them with an RPATH; their other run-time needs are ordinary packages (above). The version
# is the serial one's, so both builds are the same Meep. Unpacked once per version.
unpack_meep_mpi() {
  local dir=${PLUMAGE_MEEP_MPI_PREFIX:-${PLUMAGE_BUILD_DIR:-$root/build}/meep-mpi}
  local version runtime
  version=$(dpkg-query -W -f='${Version}' libmeep-dev)
  # libmeep-dev depends on the run-time package by its soname (libmeep30 in Debian 12)
  runtime=$(dpkg-query -W -f='${Depends}' libmeep-dev | grep -o 'libmeep[0-9]\+' | head -n 1)
  runtime=libmeep-mpi-default${runtime#libmeep}
  if [[ -f $dir/.version && $(cat "$dir/.version") == "$version" ]]; then
    return 0
  fi
  echo "plumage: unpacking $runtime and libmeep-mpi-default-dev $version into $dir" >&2
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  # apt-get download runs as the _apt user unless told otherwise, and _apt cannot write here
  local apt=(apt-get -q)
  [[ $(id -u) -eq 0 ]] && apt+=(-o APT::Sandbox::User=root)
  local debs=("$runtime=$version" "libmeep-mpi-default-dev=$version")
  if ! (cd "$work" && "${apt[@]}" download "${debs[@]}") >&2; then
    "${sudo_cmd[@]}" apt-get update -q  # lists older than the installed libmeep-dev
    (cd "$work" && "${apt[@]}" download "${debs[@]}") >&2
  fi
  mkdir -p "$work/root"
  for deb in "$work"/*.deb; do dpkg-deb -x "$deb" "$work/root"; done
  local lib
  lib=$(find "$work/root" -name 'libmeep.so.*.*' | head -n 1)
  if ldd "$lib" | grep -q 'not found'; then
    echo "plumage: Meep's MPI build misses libraries: $(ldd "$lib" | grep 'not found' | tr -s ' \t\n' ' ')" >&2
    exit 1
  fi
  echo "$version" >"$work/root/.version"
  rm -rf "$dir"
  mkdir -p "$(dirname "$dir")"
  mv "$work/root" "$dir"
}
unpack_meep_mpi
