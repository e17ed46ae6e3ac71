#!/usr/bin/env bash
# `make python`: installs the built package (build/<preset>/python/trellis) into Debian's
# /usr/bin/python3 site-packages, so `python3 -c "import trellis"` works from anywhere.
set -euo pipefail
build="$1"
py=/usr/bin/python3
site=$("$py" -c 'import site; print(site.getsitepackages()[0])')
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO mkdir -p "$site"
$SUDO rm -rf "$site/trellis"
$SUDO cp -r "$build/python/trellis" "$site/trellis"
echo "installed trellis $("$py" -c 'import trellis; print(trellis.__version__)') into $site"
