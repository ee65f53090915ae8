#!/usr/bin/env bash
# Installs every Debian 12 package ugvr needs to build, test and fuzz. Idempotent: packages already present are
# skipped by apt-get, and the package lists are refreshed only when something is missing.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  clang libclang-rt-14-dev            # libFuzzer + sanitizer runtimes
  libgtest-dev libgmock-dev
  libtbb-dev                          # oneTBB: parallel topology and (later) rendering
  zlib1g-dev liblz4-dev libzstd-dev   # VTK XML compressors; brick store compression
  libpugixml-dev                      # VTK XML headers
  libcli11-dev nlohmann-json3-dev     # command line; JSON output and settings files
  libnetcdf-dev                       # Exodus II files are netCDF
  libcgns-dev                         # CGNS files (ADF and HDF5)
  libpng-dev                          # rendered images
  libboost-dev                        # Beast + Asio: the browser viewer's HTTP / WebSocket server (`ugvr view`)
  libturbojpeg0-dev                   # JPEG frames streamed to the browser viewer
  libepoxy-dev libegl-dev             # OpenGL 4.5 through headless EGL (GPU engines)
  libegl1 libegl-mesa0 libgl1-mesa-dri  # Mesa's EGL and llvmpipe: the GPU engines run without a GPU (CI)
  python3 python3-matplotlib          # benchmark plots
  python3-dev pybind11-dev python3-numpy python3-pytest  # `import ugvr` (python/) and its pytest suite
  python3-vtk9 python3-meshio         # ugvr.from_vtk / from_meshio and their tests; the PyVista-style bench
  jupyter-nbconvert python3-ipykernel # executes docs/python-demo.ipynb in CI
  chromium                            # headless browser for the viewer's end-to-end tests (tests/e2e; node + npm too)
  libopenmpi-dev openmpi-bin          # `mpirun -np N ugvr render` (docs/mpi.md): ~13 s to install
  paraview-dev                        # IceT, the sort-last compositor (ParaView 5.11's; docs/mpi.md): ~90 s to install
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
