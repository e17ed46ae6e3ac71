#!/usr/bin/env bash
# Issue 40 item 2: the G-code scanner behind analyze / view / check against `cat FILE >/dev/null`
# and `wc -l FILE` on the same file, in one run, interleaved ROUNDS times (minimum over the
# rounds). Timed: `trellis analyze FILE` as a user runs it (perf stat's task-clock: CPU of all
# threads; and wall time), and the library's three passes (bench_gcode_reader with
# TRELLIS_BENCH_GCODE=FILE: BM_ScanFile = analyze's, BM_ViewScan = view's, BM_CheckScan =
# check's; process CPU time, wall time beside). CPU time is what the neighbours on a shared
# machine disturb least; the load average is printed before and after.
# FILE: a G-code file; without one, a ~100 MB PrusaSlicer-style file is made here
# (bench/make_large_gcode.py) and removed afterwards.
# BASE (optional): a folder holding a baseline `trellis` and its libtrellis.so.0.1, timed
# alongside in the same rounds (the benchmark binary swaps its library by LD_LIBRARY_PATH).
# Usage: bench/io_vs_cat.sh [FILE|-] [BUILD=build/release] [ROUNDS=5] [BASE]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
file="${1:--}"; build="${2:-build/release}"; rounds="${3:-5}"; base="${4:-}"
dir="$(mktemp -d /tmp/trellis_io_vs_cat_XXXXXX)"
trap 'rm -rf "$dir"' EXIT
if [ "$file" = "-" ]; then
  file="$dir/large.gcode"
  /usr/bin/python3 "$here/make_large_gcode.py" "$file" 100 >/dev/null
fi
echo "file: $file ($(stat -c %s "$file") bytes, $(wc -l <"$file") lines)"
echo "load: $(uptime | sed 's/.*load average: //')"
cat "$file" >/dev/null  # into the page cache
declare -A best
min() { awk -v a="$1" -v b="$2" 'BEGIN {print (a == "" || b + 0 < a + 0) ? b : a}'; }
keep() { best["$1"]=$(min "${best["$1"]:-}" "$2"); }
# CPU ms (task-clock) and wall ms of one run of "$@", stdout discarded: "cpu wall".
run_cpu_wall() {
  local t0 t1 cpu
  t0=$(date +%s%N)
  cpu=$(perf stat -x, -e task-clock "$@" 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}')
  t1=$(date +%s%N)
  echo "$cpu $(( (t1 - t0) / 1000 ))e-3"
}
time_tool() {  # label, command...
  local label="$1" r
  shift
  r=$(run_cpu_wall "$@")
  keep "$label cpu" "${r% *}"
  keep "$label wall" "${r#* }"
}
run_bench() {  # label prefix, LD_LIBRARY_PATH or ""
  local out header
  out=$(LD_LIBRARY_PATH="$2" TRELLIS_BENCH_GCODE="$file" "$build/bench/bench_gcode_reader" \
        --benchmark_filter='BM_(ScanFile|ViewScan|CheckScan)' --benchmark_min_time=0.01 \
        --benchmark_format=csv 2>/dev/null)
  header=$(grep '^name,' <<<"$out")
  local wall_col
  wall_col=$(tr ',' '\n' <<<"$header" | grep -n '^"\?wall_ms"\?$' | cut -d: -f1)
  while IFS= read -r row; do
    local name cpu wall
    name=$(cut -d, -f1 <<<"$row" | tr -d '"')
    case "$name" in BM_*) ;; *) continue ;; esac
    name="${name%/manual_time}"
    cpu=$(cut -d, -f3 <<<"$row")
    wall=$(cut -d, -f"$wall_col" <<<"$row")
    keep "$1 $name cpu" "$cpu"
    keep "$1 $name wall" "$wall"
  done <<<"$out"
}
for r in $(seq "$rounds"); do
  time_tool "cat" cat "$file"
  time_tool "wc -l" wc -l "$file"
  [ -n "$base" ] && time_tool "before analyze" env LD_LIBRARY_PATH="$base" "$base/trellis" \
    analyze "$file" --report /dev/null
  time_tool "after  analyze" "$build/apps/trellis/trellis" analyze "$file" --report /dev/null
  [ -n "$base" ] && run_bench "before" "$base"
  run_bench "after " ""
done
bytes=$(stat -c %s "$file")
printf '%-28s %9s %7s %9s %7s %9s\n' "" "CPU ms" "x cat" "wall ms" "x cat" "MB/s CPU"
while IFS= read -r key; do
  k="${key% cpu}"
  awk -v n="$k" -v c="${best["$k cpu"]}" -v w="${best["$k wall"]}" -v cc="${best["cat cpu"]}" \
      -v cw="${best["cat wall"]}" -v b="$bytes" 'BEGIN {
    printf "%-28s %9.1f %7.2f %9.1f %7.2f %9.0f\n", n, c, c / cc, w, w / cw, b / 1e3 / c }'
done < <(printf '%s\n' "${!best[@]}" | grep ' cpu$' | sort)
echo "(min of $rounds interleaved rounds; target: analyze <= 2 x cat)"
echo "load after: $(uptime | sed 's/.*load average: //')"
