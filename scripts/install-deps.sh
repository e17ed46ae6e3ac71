#!/usr/bin/env bash
# Installs the Debian packages Trellis needs to build and test, skipping those already present.
# Safe to run repeatedly; uses sudo only when not root.
set -euo pipefail
pkgs=(cmake g++ make pkg-config ninja-build ccache
      libtbb-dev libcli11-dev nlohmann-json3-dev libfmt-dev libtomlplusplus-dev
      libpolyclipping-dev libcairo2-dev libcgal-dev libgmp-dev libmpfr-dev libeigen3-dev
      libmuparser-dev libopenvdb-dev libboost-iostreams-dev lib3mf-dev libzip-dev libexpat1-dev
      libglpk-dev zlib1g-dev libpng-dev libmimalloc-dev libgtest-dev libbenchmark-dev prusa-slicer python3
      pybind11-dev python3-dev python3-numpy python3-pytest python3-distributed
      python3-matplotlib python3-nbformat python3-nbclient python3-ipykernel python3-nbconvert python3-pip python3-venv
      chromium firefox-esr time slurm-wlm munge
      clang-format  # tests/format_test.py: the tree as .clang-format lays it out
      libxml2-utils  # xmllint: 3MF toolpaths against the specification's XSD
      cura-engine)  # bench/ratios.sh (its definitions come from the cura package, extracted there)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# The viewer's build step (viewer/, docs/viewer.md) runs node and `npm ci`; a node from elsewhere
# (e.g. NodeSource, which bundles npm and conflicts with Debian's npm package) is fine.
command -v node >/dev/null && command -v npm >/dev/null || missing+=(nodejs npm)
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#pkgs[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
