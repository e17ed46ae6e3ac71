#!/bin/bash
# Issue 21: direct vs STL PBF route, two builds side by side (e.g. main before and after a
# change), interleaved so both see the same machine load. Per round and build:
#   bench_pbf at the default 25 µm on 2–4 gyroid cells and at 10 µm on 2 cells (each route in
#   its own process; CPU seconds and peak RSS from wait4), then `trellis pbf` on the shipped
#   examples/designs/gyroid_sheet_cube.vcad ("EX") and on the default lattice cut by it
#   (--envelope, "EXOLD"), both routes (user + system seconds, peak RSS in kB).
# Prints one line per run, then each build's direct/STL ratios (ranges over the rounds).
# Usage: bench/pbf_routes_side_by_side.sh BASE_BUILD NEW_BUILD [ROUNDS]
#   (build directories holding bench/bench_pbf and apps/trellis/trellis)
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 BASE_BUILD NEW_BUILD [ROUNDS]" >&2; exit 2; }
BASE=$1 NEW=$2 ROUNDS=${3:-2}
EX=$(cd "$(dirname "$0")/.." && pwd)/examples/designs/gyroid_sheet_cube.vcad
F='BM_(Direct|Stl)RouteDefault/|BM_(Direct|Stl)Route/2/'
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for round in $(seq 1 "$ROUNDS"); do
  for v in base new; do
    if [ $v = base ]; then B=$BASE; else B=$NEW; fi
    "$B/bench/bench_pbf" --benchmark_filter="$F" --benchmark_format=csv 2>/dev/null |
      awk -F, -v v=$v -v r="$round" 'NR>1{gsub(/"/,"",$1); sub(/\/iterations.*/,"",$1); print "BENCH", r, v, $1, $(NF-1), $NF}'
    for route in direct stl; do
      for what in EX EXOLD; do
        if [ $what = EX ]; then args=("$EX"); else args=(--envelope "$EX"); fi
        /usr/bin/time -f "$what $round $v $route %U %S %M" "$B/apps/trellis/trellis" pbf "${args[@]}" \
          --route $route -o "$out/x.cli" >/dev/null 2>"$out/err"
        tail -1 "$out/err"
      done
    done
  done
done | tee "$out/runs.txt"
python3 - "$out/runs.txt" <<'EOF'
import collections, sys
d = collections.defaultdict(list)
for r in (l.split() for l in open(sys.argv[1]) if l.strip()):
    if r[0] == 'BENCH':
        d[(r[2], r[3])].append((float(r[4]), float(r[5])))
    else:  # user + system s, peak kB
        d[(r[2], r[0] + ' ' + r[3])].append((float(r[4]) + float(r[5]), float(r[6]) / 1024))
rng = lambda v: f'{min(v):.2f}-{max(v):.2f}'
pairs = [('BM_DirectRouteDefault/2', 'BM_StlRouteDefault/2'), ('BM_DirectRouteDefault/3', 'BM_StlRouteDefault/3'),
         ('BM_DirectRouteDefault/4', 'BM_StlRouteDefault/4'), ('BM_DirectRoute/2', 'BM_StlRoute/2'),
         ('EX direct', 'EX stl'), ('EXOLD direct', 'EXOLD stl')]
for v in ('base', 'new'):
    for a, b in pairs:
        A, B = d[(v, a)], d[(v, b)]
        if not A or not B:
            continue
        t = [x[0] / y[0] for x, y in zip(A, B)]
        m = max(x[1] for x in A) / min(y[1] for y in B)
        print(f'{v:4} {a:24} direct {rng([x[0] for x in A])} s  STL {rng([y[0] for y in B])} s  '
              f'time {rng(t)}x  memory {m:.3f}x')
EOF
