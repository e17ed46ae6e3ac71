#!/bin/sh
# Issue 23: peak memory of the FDM slice route for the same part at N vs 4N layers (finer layers)
# differs by less than 20 %: layers stream through a bounded pipeline into a temporary file and
# the G-code is written from it. Peak RSS and wall time from /usr/bin/time -v; run it with an
# older trellis (first argument) to see the whole-toolpath route grow.
# Usage: bench/slice_memory_layers.sh [path/to/trellis] [design] [layer height N] [extra options...]
# PROFILE=path/to/machine.toml picks the machine (default: the Prusa MK4S profile).
set -eu
T=${1:-build/release/apps/trellis/trellis}
D=${2:-examples/designs/csg_bracket.vcad}
H=${3:-0.1}
P=${PROFILE:-profiles/prusa_mk4s_lwpla.toml}
[ $# -gt 0 ] && shift
[ $# -gt 0 ] && shift
[ $# -gt 0 ] && shift
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
peak() {  # layer height, extra options → "peak_kB wall_time user_s file_bytes"
  h=$1
  shift
  if ! /usr/bin/time -v "$T" slice "$D" --machine "$P" --layer-height "$h" \
    -o "$dir/out.gcode" "$@" >"$dir/out.txt" 2>"$dir/time.txt"; then
    head -3 "$dir/time.txt" >&2
    exit 1
  fi
  kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$dir/time.txt")
  s=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$dir/time.txt")
  u=$(sed -n 's/.*User time (seconds): //p' "$dir/time.txt")
  echo "$kb $s ${u}s $(wc -c <"$dir/out.gcode")"
}
H4=$(awk -v h="$H" 'BEGIN { print h / 4 }')
a=$(peak "$H" "$@")
b=$(peak "$H4" "$@")
echo "$D at $H mm:  peak ${a%% *} kB (wall, user CPU, bytes: ${a#* })"
echo "$D at $H4 mm: peak ${b%% *} kB (wall, user CPU, bytes: ${b#* })"
awk -v a="${a%% *}" -v b="${b%% *}" 'BEGIN { r = b / a; printf "ratio 4N/N layers: %.3f (must be < 1.20)\n", r; exit !(r < 1.2 && r > 1 / 1.2) }'
