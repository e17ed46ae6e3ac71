#!/usr/bin/env bash
# Issue 40: `trellis analyze` (the G-code scanner behind analyze/view/check) against `cat` and
# `wc -l` on the same file, in one run, interleaved ROUNDS times; CPU time (user + system, from
# perf stat's task-clock, or GNU time when perf is missing), minimum over the rounds. Prints the
# load average first: the machine is shared, and CPU time is what neighbours disturb least.
# Usage: bench/scan_vs_cat.sh FILE.gcode [TRELLIS=build/release/apps/trellis/trellis] [ROUNDS=5]
set -euo pipefail
file="$1"; trellis="${2:-build/release/apps/trellis/trellis}"; rounds="${3:-5}"
cpu_ms() {  # CPU milliseconds of one run of "$@" (stdout discarded)
  if command -v perf >/dev/null 2>&1; then
    perf stat -x, -e task-clock "$@" 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}'
  else
    /usr/bin/time -f '%U %S' "$@" 2>&1 >/dev/null | tail -1 | awk '{print 1000 * ($1 + $2)}'
  fi
}
echo "file: $file ($(stat -c %s "$file") bytes, $(wc -l <"$file") lines)"
echo "load: $(uptime | sed 's/.*load average: //')"
cat "$file" >/dev/null  # into the page cache
best_cat=; best_wc=; best_scan=
min() { awk -v a="$1" -v b="$2" 'BEGIN {print (a == "" || b + 0 < a + 0) ? b : a}'; }
for r in $(seq "$rounds"); do
  best_cat=$(min "$best_cat" "$(cpu_ms cat "$file")")
  best_wc=$(min "$best_wc" "$(cpu_ms wc -l "$file")")
  best_scan=$(min "$best_scan" "$(cpu_ms "$trellis" analyze "$file" --report /dev/null)")
done
awk -v c="$best_cat" -v w="$best_wc" -v s="$best_scan" 'BEGIN {
  printf "cat %.1f ms, wc -l %.1f ms, trellis analyze %.1f ms (CPU, min of rounds)\n", c, w, s
  printf "analyze / cat = %.2f, analyze / wc -l = %.2f (target: analyze / cat <= 2)\n", s / c, s / w }'
echo "load after: $(uptime | sed 's/.*load average: //')"
