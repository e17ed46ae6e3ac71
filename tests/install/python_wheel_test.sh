#!/usr/bin/env bash
# `pip wheel` of the checkout with this (built) build tree, the wheel checked (contents, RECORD),
# installed into a fresh virtual environment (--system-site-packages: Debian's numpy and pytest)
# and used from a folder outside the checkout with no PYTHONPATH or LD_LIBRARY_PATH: the
# `trellis` command, the module and every Trellis library it loads must come from the
# environment, and python/tests must pass against them.
#   python_wheel_test.sh SOURCE_DIR BUILD_DIR PYTHON VERSION
set -euo pipefail
src=$1 build=$2 py=$3 version=$4
tmp=$(mktemp -d "${TMPDIR:-/tmp}/trellis_wheel_XXXXXX")
trap 'rm -rf "$tmp"' EXIT
unset PYTHONPATH LD_LIBRARY_PATH TRELLIS_MODULE_DIR
venv=$tmp/venv

TRELLIS_BUILD_DIR=$build "$py" -m pip wheel -q --no-index --no-deps -w "$tmp/dist" "$src"
wheels=("$tmp"/dist/trellis-"$version"-*.whl)
[[ -f ${wheels[0]} ]] ||
  { echo "pip wheel wrote no trellis-$version wheel" >&2; ls "$tmp/dist" >&2; exit 1; }
"$py" - "${wheels[0]}" "$version" <<'EOF'
import base64, hashlib, sys, zipfile
wheel, version = sys.argv[1:]
info = f"trellis-{version}.dist-info"
z = zipfile.ZipFile(wheel)
names = set(z.namelist())
need = {"trellis/__init__.py", "trellis/_cli.py", "trellis/bin/trellis", f"{info}/METADATA",
        f"{info}/WHEEL", f"{info}/entry_points.txt", f"{info}/RECORD"}
need |= {f"trellis/lib/trellis/trellis_{m}.so" for m in ("vdb", "cgal", "cairo", "3mf")}
assert need <= names, f"missing from the wheel: {sorted(need - names)}"
assert any(n.startswith("trellis/_trellis.") and n.endswith(".so") for n in names)
assert any(n.startswith("trellis/lib/libtrellis.so.") for n in names)
assert z.getinfo("trellis/bin/trellis").external_attr >> 16 & 0o111, "the CLI is not executable"
assert "trellis = trellis._cli:main" in z.read(f"{info}/entry_points.txt").decode()
assert f"Version: {version}\n" in z.read(f"{info}/METADATA").decode()
record = {}
for line in z.read(f"{info}/RECORD").decode().splitlines():
    name, digest, size = line.rsplit(",", 2)
    record[name] = digest
assert set(record) == names, f"RECORD and the wheel differ: {sorted(set(record) ^ names)}"
for name, digest in record.items():
    if name != f"{info}/RECORD":
        data = z.read(name)
        want = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        assert digest == "sha256=" + want, f"RECORD's hash of {name} is wrong"
EOF

# Debian's pip (python3-pip) is seen through --system-site-packages and installs into the venv:
# --without-pip saves half a minute of ensurepip.
"$py" -m venv --system-site-packages --without-pip "$venv"
"$venv/bin/python" -m pip install -q --no-index "${wheels[0]}"
mkdir "$tmp/work"
cd "$tmp/work"

out=$("$venv/bin/trellis" --version)
[[ $out == "trellis $version" ]] || { echo "the venv's trellis --version says '$out'" >&2; exit 1; }
# The entry point execs the CLI: its exit code comes through (2: a user mistake).
rc=0
"$venv/bin/trellis" lattice2d --pattern no-such-pattern -o v.json 2>/dev/null || rc=$?
[[ $rc == 2 ]] ||
  { echo "trellis with a bad pattern exited $rc through the entry point, not 2" >&2; exit 1; }
# The CLI loads libtrellis and the CGAL module (Voronoi) from the environment.
LD_DEBUG=files "$venv/bin/trellis" lattice2d --pattern voronoi -o v.json >/dev/null 2>ld.txt
loaded=$(grep -o 'file=/[^ ]*trellis[^/ ]*\.so[^ ]*' ld.txt | sort -u | sed 's/^file=//')
grep -q '/lib/trellis/trellis_cgal\.so$' <<<"$loaded" ||
  { echo "the CLI did not load the environment's CGAL module:" >&2; echo "$loaded" >&2; exit 1; }
outside=$(grep -v "^$venv/" <<<"$loaded" || true)
[[ -z $outside ]] || { echo "the CLI loaded from outside the environment: $outside" >&2; exit 1; }

# The routes below load the CGAL and cairo modules; every Trellis library mapped must be the
# environment's.
"$venv/bin/python" - "$venv" <<'EOF'
import os, sys, tempfile
import trellis
venv = os.path.realpath(sys.argv[1]) + os.sep
assert os.path.realpath(trellis.__file__).startswith(venv), trellis.__file__
d = tempfile.mkdtemp()
r = trellis.lattice2d(os.path.join(d, "v.json"), pattern="voronoi", size=(5, 5),
                      preview=os.path.join(d, "p"))
assert r.lattice.edge_count > 10 and len(r.files) == 2, (r.lattice.edge_count, r.files)
with open("/proc/self/maps") as f:
    mapped = {line.split(None, 5)[5].strip() for line in f if len(line.split(None, 5)) == 6}
ours = {p for p in mapped if "trellis" in os.path.basename(p)}
names = {os.path.basename(p) for p in ours}
for want in ("libtrellis.so.", "_trellis.", "trellis_cgal.so", "trellis_cairo.so"):
    assert any(n.startswith(want) for n in names), f"{want} not loaded: {sorted(ours)}"
outside = sorted(p for p in ours if not os.path.realpath(p).startswith(venv))
assert not outside, f"loaded from outside the environment: {outside}"
EOF

TRELLIS_CLI=$venv/bin/trellis TRELLIS_SOURCE_DIR=$src "$venv/bin/python" -m pytest -q \
  -p no:cacheprovider --durations=8 --basetemp="$tmp/pytest" \
  --ignore="$src/python/tests/notebooks" "$src/python/tests"
echo "$(basename "${wheels[0]}") ($(du -k "${wheels[0]}" | cut -f1) KiB) installed into a venv;" \
     "python/tests passed there"
