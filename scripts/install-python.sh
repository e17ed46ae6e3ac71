#!/usr/bin/env bash
# `make python`: builds the wheel from this build tree (pyproject.toml, python/build_backend) and
# installs it with pip for Debian's /usr/bin/python3 (numpy from python3-numpy), so
# `python3 -c "import trellis"` and the `trellis` command work from anywhere. In a virtual
# environment or another Python, `pip install .` does the same (docs/python.md).
#   install-python.sh BUILD_DIR
set -euo pipefail
build=$(realpath "$1")
py=/usr/bin/python3
src=$(cd "$(dirname "$0")/.." && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/trellis_python_XXXXXX")
trap 'rm -rf "$tmp"' EXIT
TRELLIS_BUILD_DIR=$build "$py" -m pip wheel -q --no-index --no-deps -w "$tmp" "$src"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
site=$("$py" -c 'import site; print(site.getsitepackages()[0])')
# An earlier `make python` copied the package there without pip's record of it: removed first.
if [[ -d $site/trellis ]] && ! compgen -G "$site/trellis-*.dist-info" >/dev/null; then
  $SUDO rm -rf "$site/trellis"
fi
# Debian's Python is externally managed (PEP 668); pip installs into /usr/local, beside and not
# over Debian's packages. Uninstalled first: the same version would otherwise be kept as it is.
opts=(-q --break-system-packages --root-user-action=ignore)
if "$py" -m pip show -q trellis >/dev/null 2>&1; then
  $SUDO "$py" -m pip uninstall -y "${opts[@]}" trellis
fi
$SUDO "$py" -m pip install "${opts[@]}" --no-index "$tmp"/trellis-*.whl
version=$(cd / && "$py" -c 'import trellis; print(trellis.__version__)')
bin=$("$py" -c 'import sysconfig; print(sysconfig.get_path("scripts"))')
echo "installed trellis $version into $site and the trellis command into $bin"
