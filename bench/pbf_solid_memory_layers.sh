#!/bin/sh
# Issue 44 item 5: peak memory of a solid part's PBF build stays bounded as the layers grow. A
# mesh (examples/designs/concave_cylinder.obj, 4 mm tall) hatched with islands and split into
# skin, core, up-skin and down-skin four layers thick (the sliding window of layers holds each
# layer while the layers within reach need it) at 400 and 1,600 layers (same part, finer layers):
# the peaks must differ by less than 20 %, as the streamed TPMS route's
# (bench/pbf_memory_layers.sh). Peak RSS from /usr/bin/time -v.
# Usage: bench/pbf_solid_memory_layers.sh [path/to/trellis] [extra trellis pbf options...]
set -eu
T=${1:-build/release/apps/trellis/trellis}
[ $# -gt 0 ] && shift
part="$(dirname "$0")/../examples/designs/concave_cylinder.obj"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
peak() {  # layer thickness, skin thickness, extra options → "peak_kB wall_time file_bytes"
  h=$1
  t=$2
  shift 2
  /usr/bin/time -v "$T" pbf "$part" --strategy island --layer-height "$h" -o "$dir/out.cli" \
    --set pbf.skin_thickness="$t" --set pbf.upskin_thickness="$t" \
    --set pbf.downskin_thickness="$t" "$@" >"$dir/out.txt" 2>"$dir/time.txt"
  kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$dir/time.txt")
  s=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$dir/time.txt")
  echo "$kb $s $(wc -c <"$dir/out.cli")"
}
a=$(peak 0.01 0.04 "$@")
b=$(peak 0.0025 0.01 "$@")
echo "400 layers:   peak ${a%% *} kB (wall, bytes: ${a#* })"
echo "1600 layers:  peak ${b%% *} kB (wall, bytes: ${b#* })"
awk -v a="${a%% *}" -v b="${b%% *}" 'BEGIN { r = b / a; printf "ratio 1600/400 layers: %.3f (must be < 1.20)\n", r; exit !(r < 1.2 && r > 1 / 1.2) }'
