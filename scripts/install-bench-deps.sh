#!/usr/bin/env bash
# Installs the Debian 12 packages that only the peer benchmarks need (not part of CI, not needed to build or test
# ugvr): ParaView 5.11's pvbatch (bench/peer_paraview_resample.py), VTK 9.1's Python bindings (bench/peer_vtk_*.py),
# and a virtual X server for their OpenGL contexts (Mesa llvmpipe; Debian's ParaView has no EGL/OSMesa, so pvbatch
# needs an X display even with --force-offscreen-rendering). Idempotent, like scripts/install-deps.sh: packages already
# present are skipped, and the package lists are refreshed only when something is missing.
#
# pvbatch's Python side (paraview.simple and ParaView's own vtkmodules) is the package python3-paraview, which
# Conflicts with python3-vtk9 (both ship /usr/lib/python3/dist-packages/vtkmodules): installing one removes the other.
# So python3-paraview is not installed: the .deb of the installed paraview's exact version is unpacked into
# PV_PYTHON_PREFIX (default /opt/ugvr-bench/python3-paraview), and bench/run_peer_paraview.sh puts its dist-packages
# first on pvbatch's PYTHONPATH. Re-unpacked only when the paraview version changes.
set -euo pipefail

PACKAGES=(
  paraview                            # pvbatch: bench/peer_paraview_resample.py (ParaView 5.11)
  python3-vtk9                        # bench/peer_vtk_load.py, bench/peer_vtk_render.py (VTK 9.1)
  xvfb xauth                          # xvfb-run: an X display for the OpenGL render windows
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
updated=
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-bench-deps: all ${#PACKAGES[@]} packages present"
else
  echo "install-bench-deps: installing ${missing[*]}"
  $SUDO apt-get update -qq
  updated=1
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# python3-paraview, unpacked beside the system (see the header)
prefix=${PV_PYTHON_PREFIX:-/opt/ugvr-bench/python3-paraview}
version=$(dpkg-query -W -f='${Version}' paraview)
if [ -f "$prefix/usr/lib/python3/dist-packages/paraview/simple.py" ] && [ "$(cat "$prefix/VERSION" 2>/dev/null)" = "$version" ]; then
  echo "install-bench-deps: python3-paraview $version present in $prefix"
  exit 0
fi
echo "install-bench-deps: unpacking python3-paraview $version into $prefix"
[ -n "$updated" ] || $SUDO apt-get update -qq
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
chmod 755 "$tmp"
id _apt >/dev/null 2>&1 && $SUDO chown _apt "$tmp"  # apt-get download runs as _apt when it can
(cd "$tmp" && $SUDO apt-get download -qq "python3-paraview=$version")
$SUDO rm -rf "$prefix"
$SUDO mkdir -p "$prefix"
$SUDO dpkg-deb -x "$tmp"/python3-paraview_*.deb "$prefix"
echo "$version" | $SUDO tee "$prefix/VERSION" >/dev/null
