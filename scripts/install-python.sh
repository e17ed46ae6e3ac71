#!/usr/bin/env bash
# `make python`: installs the built package into Debian's /usr/bin/python3 site-packages, so
# `python3 -c "import trellis"` works from anywhere. The package carries the library and its
# run-time modules (OpenVDB, CGAL, cairo, lib3mf parts, loaded on first use) beside the
# extension, which finds them through its $ORIGIN run path.
set -euo pipefail
build="$1"
py=/usr/bin/python3
# A second argument installs into that folder instead (the tests use it).
site="${2:-$("$py" -c 'import site; print(site.getsitepackages()[0])')}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO mkdir -p "$site"
$SUDO rm -rf "$site/trellis"
$SUDO cp -r "$build/python/trellis" "$site/trellis"
$SUDO cp -P "$build"/src/libtrellis.so* "$site/trellis/"
$SUDO mkdir -p "$site/trellis/trellis"
$SUDO cp "$build"/src/trellis/*.so "$site/trellis/trellis/"
echo "installed trellis $(cd / && PYTHONPATH="${2:+$site}" "$py" -c 'import trellis; print(trellis.__version__)') into $site"
