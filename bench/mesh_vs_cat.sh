#!/usr/bin/env bash
# Issue 40: loading a mesh as the slicer does (read_mesh + check_mesh) against `cat` of the same
# file, in one run, interleaved ROUNDS times: the same 1M-triangle torus as a 50 MB binary STL, a
# 178 MB ASCII STL, a 40 MB OBJ and a 9.6 MB 3MF (83 MB of model XML). CPU time (all threads:
# perf stat's task-clock for cat, the benchmark's process CPU time for the loader) and wall time,
# minimum over the rounds; prints the load average before and after (the machine is shared).
# The stages (BM_Stage*: parse and weld from memory, the weld alone, the check alone; 2 threads)
# say where the time goes.
# The meshes are made here (bench/make_torus_stl.py: closed tori; nothing fetched).
# BASE (optional): a folder with a baseline libtrellis.so.0.1, timed alongside (LD_LIBRARY_PATH).
# Usage: bench/mesh_vs_cat.sh [BUILD=build/release] [ROUNDS=3] [BASE]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:-build/release}"; rounds="${2:-3}"; base="${3:-}"
dir="$(mktemp -d /tmp/trellis_mesh_io_XXXXXX)"
trap 'rm -rf "$dir"' EXIT
/usr/bin/python3 "$here/make_torus_stl.py" "$dir/torus.stl"
/usr/bin/python3 "$here/make_torus_stl.py" "$dir/torus.ascii.stl"
/usr/bin/python3 "$here/make_torus_stl.py" "$dir/torus.obj"
/usr/bin/python3 "$here/make_torus_stl.py" "$dir/torus.3mf"
echo "load: $(uptime | sed 's/.*load average: //')"
min() { awk -v a="$1" -v b="$2" 'BEGIN {print (a == "" || b + 0 < a + 0) ? b : a}'; }
declare -A best
run_bench() {  # file, label, LD_LIBRARY_PATH or ""
  local out
  out=$(LD_LIBRARY_PATH="$3" TRELLIS_BENCH_STL="$1" "$build/bench/bench_mesh_io" \
        --benchmark_filter="BM_(ReadFileOnly|LoadFloor|LoadAndCheckMesh|${STAGES:-Stage[A-Za-z]*/2})" --benchmark_min_time=0.2 \
        --benchmark_format=csv 2>/dev/null)
  while IFS=, read -r name iters real cpu _; do
    name="${name//\"/}"
    case "$name" in BM_*) ;; *) continue ;; esac
    name="${name%/real_time}"; name="${name%/process_time}"
    best["$2 $name cpu"]=$(min "${best["$2 $name cpu"]:-}" "$cpu")
    best["$2 $name wall"]=$(min "${best["$2 $name wall"]:-}" "$real")
  done <<<"$out"
}
for file in "$dir/torus.stl" "$dir/torus.ascii.stl" "$dir/torus.obj" "$dir/torus.3mf"; do
  f="$(basename "$file")"
  echo "== $f ($(stat -c %s "$file") bytes)"
  cat "$file" >/dev/null  # into the page cache
  for r in $(seq "$rounds"); do
    c=$(perf stat -x, -e task-clock cat "$file" 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}')
    best["$f cat cpu"]=$(min "${best["$f cat cpu"]:-}" "$c")
    t0=$(date +%s%N); cat "$file" >/dev/null; t1=$(date +%s%N)
    best["$f cat wall"]=$(min "${best["$f cat wall"]:-}" "$(( (t1 - t0) / 1000 ))e-3")
    [ -n "$base" ] && run_bench "$file" "$f before" "$base"
    run_bench "$file" "$f after" ""
  done
  printf 'cat: %.1f ms CPU, %.1f ms wall (min of %d)\n' "${best["$f cat cpu"]}" "${best["$f cat wall"]}" "$rounds"
  while IFS= read -r key; do
    k="${key% cpu}"
    awk -v n="${k#"$f "}" -v c="${best["$k cpu"]}" -v w="${best["$k wall"]}" -v cc="${best["$f cat cpu"]}" \
        -v cw="${best["$f cat wall"]}" 'BEGIN {
      printf "%-36s %8.1f ms CPU (%5.2f x cat) %8.1f ms wall (%5.2f x cat)\n", n, c, c / cc, w, w / cw }'
  done < <(printf '%s\n' "${!best[@]}" | grep "^$f " | grep ' cpu$' | grep -v " cat cpu" | sort)
done
echo "target: LoadAndCheckMesh <= 2 x cat (LoadFloor: reading in pieces and filling a mesh of that size, nothing else)"
echo "load after: $(uptime | sed 's/.*load average: //')"
