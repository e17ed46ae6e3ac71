# Sourced by the side-by-side scripts (continuous_paths.sh, ratios.sh): the other slicers with the
# settings Trellis is compared at (0.2 mm layers, 2 walls of 0.4 mm beads, 20 % lines infill,
# 4 top / 4 bottom layers), the meshes fetched from Debian packages, and CPU timing.
# Functions work in the current directory (the caller's work dir).

# PrusaSlicer 2.5 (prusa-slicer): also matched speeds, travel and retraction for the toolpath
# comparison of continuous_paths.sh (Trellis: profiles/voron_klipper.toml).
prusa_args=(--export-gcode --layer-height 0.2 --first-layer-height 0.2 --nozzle-diameter 0.4
  --filament-diameter 1.75 --perimeters 2 --fill-density 20% --fill-pattern rectilinear
  --top-fill-pattern rectilinear --bottom-fill-pattern rectilinear --fill-angle 45
  --top-solid-layers 4 --bottom-solid-layers 4 --skirts 0 --brim-width 0
  --bed-shape 0x0,350x0,350x350,0x350 --max-print-height 340 --perimeter-generator classic
  --dont-arrange --extrusion-width 0.4 --first-layer-extrusion-width 0.4
  --perimeter-extrusion-width 0.4 --external-perimeter-extrusion-width 0.4
  --infill-extrusion-width 0.4 --solid-infill-extrusion-width 0.4 --top-infill-extrusion-width 0.4
  --perimeter-speed 80 --external-perimeter-speed 80 --small-perimeter-speed 80 --infill-speed 80
  --solid-infill-speed 80 --top-solid-infill-speed 80 --gap-fill-speed 80 --bridge-speed 80
  --first-layer-speed 80 --travel-speed 250 --travel-speed-z 15 --retract-length 0.6
  --retract-speed 40 --retract-lift 0.2 --retract-before-travel 1.5 --slowdown-below-layer-time 0
  --gcode-flavor marlin2)  # (2.5 has no klipper flavour; the moves are the same)

# CuraEngine 4.13 (cura-engine) with the cura package's definitions (extracted, not installed:
# shared notes). Its setting formulas are not re-evaluated, so the leaf settings are given.
cura_args=(-s machine_width=350 -s machine_depth=350 -s machine_height=340
  -s layer_height=0.2 -s layer_height_0=0.2 -s line_width=0.4 -s wall_line_width_0=0.4
  -s wall_line_width_x=0.4 -s wall_line_count=2 -s infill_sparse_density=20
  -s infill_line_distance=2 -s infill_pattern=lines -s top_layers=4 -s bottom_layers=4
  -s top_bottom_thickness=0.8 -s top_thickness=0.8 -s bottom_thickness=0.8 -s adhesion_type=none
  -s support_enable=false -e0 -s material_diameter=1.75)

# Installs cura-engine when missing (root or sudo) and extracts the definitions into ./cura_x;
# sets CURA_ENGINE_SEARCH_PATH and cura_def. Returns 1 (with a message) when it cannot.
peers_cura_setup() {
  if ! command -v CuraEngine >/dev/null; then
    local sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends cura-engine \
      >/dev/null 2>&1 || { echo "cannot install cura-engine" >&2; return 1; }
  fi
  if [ ! -f cura_x/usr/share/cura/resources/definitions/fdmprinter.def.json ]; then
    (apt-get download cura >/dev/null 2>&1 && dpkg-deb -x cura_*.deb cura_x) ||
      { echo "cannot fetch the cura package's definitions (apt-get download cura)" >&2; return 1; }
  fi
  export CURA_ENGINE_SEARCH_PATH="$PWD/cura_x/usr/share/cura/resources/definitions:$PWD/cura_x/usr/share/cura/resources/extruders"
  cura_def="$PWD/cura_x/usr/share/cura/resources/definitions/fdmprinter.def.json"
}

# Installs prusa-slicer when missing; returns 1 when it cannot.
peers_prusa_setup() {
  command -v prusa-slicer >/dev/null && return 0
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends prusa-slicer \
    >/dev/null 2>&1 || { echo "cannot install prusa-slicer" >&2; return 1; }
}

# Debian's occt-misc meshes into ./occt (apt-get download, not installed); returns 1 when it cannot.
peers_occt() {
  [ -f occt/usr/share/opencascade/data/stl/TR12J_OCC.stl ] && return 0
  (apt-get download occt-misc >/dev/null 2>&1 && dpkg-deb -x occt-misc_*.deb occt) ||
    { echo "cannot fetch occt-misc (apt-get download)" >&2; return 1; }
}
occt_stl() { echo "occt/usr/share/opencascade/data/stl/$1"; }

# A binary STL scaled about the origin: peers_scale_stl SRC DST FACTOR (TR12J_OCC.stl is
# 506 × 500 × 320 mm: by 0.5 it fits a 350 mm bed).
peers_scale_stl() {
  /usr/bin/python3 - "$1" "$2" "$3" <<'PY'
import struct, sys
src, dst, f = sys.argv[1], sys.argv[2], float(sys.argv[3])
data = open(src, 'rb').read()
n = struct.unpack('<I', data[80:84])[0]
assert len(data) == 84 + 50 * n, "a binary STL"
out = bytearray(data[:84])
for i in range(n):
    rec = data[84 + 50 * i:84 + 50 * (i + 1)]
    v = list(struct.unpack('<12f', rec[:48]))
    out += struct.pack('<12f', v[0], v[1], v[2], *[x * f for x in v[3:]]) + rec[48:]
open(dst, 'wb').write(out)
PY
}

# An STL (ASCII or binary) as a binary STL standing on z = 0 at the centre of the 350 mm bed, so
# every slicer sees the same placement (CuraEngine cuts what lies below z = 0):
# peers_place_stl SRC DST
peers_place_stl() {
  /usr/bin/python3 - "$1" "$2" <<'PY'
import re, struct, sys
src, dst = sys.argv[1], sys.argv[2]
data = open(src, 'rb').read()
tris = []
n = struct.unpack('<I', data[80:84])[0] if len(data) >= 84 else 0
if len(data) == 84 + 50 * n:
    for i in range(n):
        tris.append(struct.unpack('<9f', data[84 + 50 * i + 12:84 + 50 * i + 48]))
else:
    v = [float(x) for x in re.findall(rb'vertex\s+(\S+)\s+(\S+)\s+(\S+)', data) for x in x]
    tris = [tuple(v[k:k + 9]) for k in range(0, len(v), 9)]
assert tris, f"{src}: no triangles"
xs = [t[k] for t in tris for k in (0, 3, 6)]
ys = [t[k] for t in tris for k in (1, 4, 7)]
zs = [t[k] for t in tris for k in (2, 5, 8)]
d = (175 - (min(xs) + max(xs)) / 2, 175 - (min(ys) + max(ys)) / 2, -min(zs))
out = bytearray(b'placed for the slicer benchmarks'.ljust(80, b' ') + struct.pack('<I', len(tris)))
for t in tris:
    out += struct.pack('<12fH', 0, 0, 0, *[t[k] + d[k % 3] for k in range(9)], 0)
open(dst, 'wb').write(out)
PY
}

# Whether a G-code file has layers: peers_has_layers FILE (PrusaSlicer ;LAYER_CHANGE, Cura and
# Trellis ;LAYER:).
peers_has_layers() { grep -q -m1 -E '^;(LAYER_CHANGE|LAYER:)' "$1"; }

# CPU seconds (user + sys) of a command, its output discarded; last_wall prints its wall seconds.
cpu() {
  /usr/bin/time -f "%U %S %e" -o cpu.txt "$@" >/dev/null 2>&1 || { echo "failed: $*" >&2; return 1; }
  awk '{print $1 + $2}' cpu.txt
}
last_wall() { awk '{print $3}' cpu.txt; }

min_of() { awk -v a="$1" -v b="$2" 'BEGIN {print (a == "" || b + 0 < a + 0) ? b : a}'; }

load_now() { echo "$(cut -d' ' -f1-3 /proc/loadavg) ($(nproc) cores)"; }
# The 1-minute load average, and whether a load counts as quiet: at most QUIET_LOAD (1.5).
load1() { cut -d' ' -f1 /proc/loadavg; }
quiet_load="${QUIET_LOAD:-1.5}"
is_quiet() { awk -v l="$1" -v q="$quiet_load" 'BEGIN {exit !(l + 0 <= q + 0)}'; }
