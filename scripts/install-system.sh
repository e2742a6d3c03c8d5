#!/bin/sh
# Installs the Debian packages soilbin runs on, if any is missing (idempotent);
# `install-system.sh docs` installs those the documentation site is built with.
# OpenBLAS: MUMPS is about 10x slower on the reference BLAS.
set -e
# h5py: Debian's, built on the HDF5 that DOLFINx loads (the field frames are written with it).
# numba: the constitutive kernels are compiled with it (Debian's, built on Debian's numpy).
# libegl1 libegl-mesa0: pyvista draws off screen through EGL (no X server).
PKGS="python3-dolfinx python3-gmsh python3-scipy python3-pytest python3-matplotlib \
python3-h5py python3-numba python3-venv python3-pip python3-setuptools python3-wheel libopenblas0-pthread \
openmpi-bin libegl1 libegl-mesa0"
# Sphinx with MyST Markdown, the furo theme, and MathJax 2 to render the math offline.
DOCS="python3-sphinx python3-myst-parser furo libjs-mathjax"
[ "${1:-}" = docs ] && PKGS="$DOCS"
missing=""
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
echo "installing Debian packages:$missing"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
