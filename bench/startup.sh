#!/usr/bin/env bash
# Start-up cost of a Trellis command (default: `trellis --version`): CPU time and peak RSS over
# many runs, shared libraries loaded and the dynamic loader's relocation count.
#   bench/startup.sh [TRELLIS_BINARY] [RUNS] [-- ARGS...]
# e.g. bench/startup.sh build/release/apps/trellis/trellis 50
#      bench/startup.sh build/release/apps/trellis/trellis 20 -- lattice2d --pattern voronoi -o /tmp/v.json
set -euo pipefail
bin=${1:-build/release/apps/trellis/trellis}
runs=${2:-50}
shift $(($# < 2 ? $# : 2))
args=(--version)
if [[ ${1:-} == -- ]]; then
  shift
  args=("$@")
fi
[[ -x $bin ]] || { echo "startup.sh: no executable $bin" >&2; exit 2; }
echo "== $bin ${args[*]} ($runs runs)"

# CPU time per run: perf stat's task-clock when perf works here, else /usr/bin/time sums.
if perf stat -r 1 -x, -e task-clock true >/dev/null 2>&1; then
  perf stat -r "$runs" -x, -e task-clock "$bin" "${args[@]}" 2>&1 >/dev/null |
    awk -F, '/task-clock/ {printf "cpu time (perf task-clock, mean): %.2f ms (+-%s)\n", $1, $4}'
fi
# The whole loop's user+sys (children included), divided by the runs: finer than per-run
# /usr/bin/time (10 ms ticks). Peak RSS per run from /usr/bin/time.
TIMEFORMAT='%U %S'
cpu=$({ time (for ((i = 0; i < runs; i++)); do "$bin" "${args[@]}" >/dev/null 2>&1; done); } 2>&1)
awk -v c="$cpu" -v n="$runs" 'BEGIN {split(c, t, " "); printf "cpu time (user+sys over %d runs, mean): %.2f ms\n", n, 1000 * (t[1] + t[2]) / n}'
rss=0
for ((i = 0; i < 10; i++)); do
  m=$(/usr/bin/time -f '%M' "$bin" "${args[@]}" 2>&1 >/dev/null | tail -1)
  ((m > rss)) && rss=$m
done
echo "peak RSS (max over 10 runs): $((rss / 1024)) MB ($rss kB)"

libs=$(LD_DEBUG=libs "$bin" "${args[@]}" 2>&1 >/dev/null | grep -c 'calling init:' || true)
echo "shared objects initialised: $libs"
LD_DEBUG=statistics "$bin" "${args[@]}" 2>&1 >/dev/null |
  awk '/final number of relocations:/ {r=$NF} /final number of relocations from cache:/ {c=$NF}
       /total startup time in dynamic loader/ {cyc=$(NF-1)}
       END {printf "relocations: %s (from cache: %s); loader start-up: %s cycles\n", r, c, cyc}'
