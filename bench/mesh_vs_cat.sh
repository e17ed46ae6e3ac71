#!/usr/bin/env bash
# Issue 40: loading a 50 MB binary STL as the slicer does (read_mesh + check_mesh) against `cat`
# of the same file, in one run, interleaved ROUNDS times. CPU time (all threads: perf stat's
# task-clock for cat, the benchmark's process CPU time for the loader) and wall time, minimum
# over the rounds; prints the load average before and after (the machine is shared).
# The mesh is made here (bench/make_torus_stl.py: a closed torus of 1M triangles; nothing fetched).
# BASE (optional): a folder with a baseline libtrellis.so.0.1, timed alongside (LD_LIBRARY_PATH).
# Usage: bench/mesh_vs_cat.sh [BUILD=build/release] [ROUNDS=3] [BASE]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:-build/release}"; rounds="${2:-3}"; base="${3:-}"
file="$(mktemp /tmp/trellis_torus_XXXXXX.stl)"
trap 'rm -f "$file"' EXIT
/usr/bin/python3 "$here/make_torus_stl.py" "$file"
echo "file: $file ($(stat -c %s "$file") bytes)"
echo "load: $(uptime | sed 's/.*load average: //')"
cat "$file" >/dev/null  # into the page cache
cat_ms() {  # CPU and wall milliseconds of `cat FILE >/dev/null`
  perf stat -x, -e task-clock "$@" cat "$file" 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}'
}
wall_cat_ms() {
  local t0 t1; t0=$(date +%s%N); cat "$file" >/dev/null; t1=$(date +%s%N)
  echo $(( (t1 - t0) / 1000 ))e-3
}
min() { awk -v a="$1" -v b="$2" 'BEGIN {print (a == "" || b + 0 < a + 0) ? b : a}'; }
declare -A best
run_bench() {  # label, LD_LIBRARY_PATH or ""
  local out
  out=$(LD_LIBRARY_PATH="$2" TRELLIS_BENCH_STL="$file" "$build/bench/bench_mesh_io" \
        --benchmark_filter='BM_(ReadFileOnly|LoadAndCheckStl1M)' --benchmark_min_time=0.2 \
        --benchmark_format=csv 2>/dev/null)
  while IFS=, read -r name iters real cpu _; do
    name="${name//\"/}"
    case "$name" in BM_*) ;; *) continue ;; esac
    name="${name%/real_time}"; name="${name%/process_time}"
    best["$1 $name cpu"]=$(min "${best["$1 $name cpu"]:-}" "$cpu")
    best["$1 $name wall"]=$(min "${best["$1 $name wall"]:-}" "$real")
  done <<<"$out"
}
for r in $(seq "$rounds"); do
  best["cat cpu"]=$(min "${best["cat cpu"]:-}" "$(cat_ms)")
  best["cat wall"]=$(min "${best["cat wall"]:-}" "$(wall_cat_ms)")
  [ -n "$base" ] && run_bench before "$base"
  run_bench after ""
done
printf 'cat: %.1f ms CPU, %.1f ms wall (min of %d)\n' "${best["cat cpu"]}" "${best["cat wall"]}" "$rounds"
while IFS= read -r key; do
  k="${key% cpu}"
  awk -v n="$k" -v c="${best["$k cpu"]}" -v w="${best["$k wall"]}" -v cc="${best["cat cpu"]}" \
      -v cw="${best["cat wall"]}" 'BEGIN {
    printf "%-40s %8.1f ms CPU (%5.2f x cat) %8.1f ms wall (%5.2f x cat)\n", n, c, c / cc, w, w / cw }'
done < <(printf '%s\n' "${!best[@]}" | grep ' cpu$' | grep -v '^cat' | sort)
echo "target: LoadAndCheckStl1M <= 2 x cat"
echo "load after: $(uptime | sed 's/.*load average: //')"
