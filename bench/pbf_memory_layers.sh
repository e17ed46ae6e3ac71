#!/bin/sh
# Issue 23 must-hold: peak memory of the PBF route on a 10 mm gyroid cube at 500 vs 2,000 layers
# (same part, finer layers) differs by less than 20 %: the layers' vectors stream to the .cli
# writer through a bounded pipeline. Peak RSS from /usr/bin/time -v.
# Usage: bench/pbf_memory_layers.sh [path/to/trellis] [extra trellis pbf options...]
set -eu
T=${1:-build/release/apps/trellis/trellis}
[ $# -gt 0 ] && shift
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
peak() {  # layer thickness, extra options → "peak_kB wall_time file_bytes"
  h=$1
  shift
  /usr/bin/time -v "$T" pbf --size 10,10,10 --layer-height "$h" -o "$dir/out.cli" "$@" \
    >"$dir/out.txt" 2>"$dir/time.txt"
  kb=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$dir/time.txt")
  s=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$dir/time.txt")
  echo "$kb $s $(wc -c <"$dir/out.cli")"
}
a=$(peak 0.02 "$@")
b=$(peak 0.005 "$@")
echo "500 layers:   peak ${a%% *} kB (wall, bytes: ${a#* })"
echo "2000 layers:  peak ${b%% *} kB (wall, bytes: ${b#* })"
awk -v a="${a%% *}" -v b="${b%% *}" 'BEGIN { r = b / a; printf "ratio 2000/500 layers: %.3f (must be < 1.20)\n", r; exit !(r < 1.2 && r > 1 / 1.2) }'
