#!/usr/bin/env bash
# Issue 40 item 3: graded slicing on one thread, a baseline build and this one side by side in
# one run, interleaved ROUNDS times. Default job: examples/jobs/vase_graded_fgm.toml (the FGM
# paper's vase, 500 layers, Strategy 1 with a prime tower; target <= 10 s CPU). User + system
# CPU seconds per run (/usr/bin/time), minimum and median over the rounds; the load average is
# printed before and after (the machine is shared: a loaded machine inflates both columns).
# BASE: a folder holding a baseline trellis, libtrellis.so.0.1 and trellis_*.so (the binary finds
# its library through LD_LIBRARY_PATH there); empty to time this build only.
# Usage: bench/graded_vase.sh [BUILD=build/release] [ROUNDS=3] [BASE] [JOB] [-- extra trellis args]
#   e.g. bench/graded_vase.sh build/release 3 /tmp/base examples/jobs/palette_plate_fgm.toml
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-build/release}"; rounds="${2:-3}"; base="${3:-}"
job="${4:-$root/examples/jobs/vase_graded_fgm.toml}"
shift $(( $# < 4 ? $# : 4 ))
[ "${1:-}" = "--" ] && shift
extra=("$@")
dir="$(mktemp -d /tmp/trellis_graded_XXXXXX)"
trap 'rm -rf "$dir"' EXIT
echo "job: $job ${extra[*]:-} (one thread, $rounds rounds)"
echo "load: $(uptime | sed 's/.*load average: //')"
declare -A times
run() {  # label, trellis binary, LD_LIBRARY_PATH and TRELLIS_MODULE_DIR (or "")
  if ! LD_LIBRARY_PATH="$3" TRELLIS_MODULE_DIR="$4" /usr/bin/time -o "$dir/time" -f '%U %S' "$2" run "$job" -o "$dir/$1" \
       --set run.threads=1 --set output.png=false "${extra[@]}" >/dev/null 2>"$dir/err"; then
    echo "$1: trellis failed:"; cat "$dir/err"; exit 1
  fi
  times[$1]="${times[$1]:-} $(awk '{printf "%.2f", $1 + $2}' "$dir/time")"
}
for r in $(seq "$rounds"); do
  [ -n "$base" ] && run before "$base/trellis" "$base" "$base"
  run after "$build/apps/trellis/trellis" "" ""
done
for k in before after; do
  [ -n "${times[$k]:-}" ] || continue
  tr ' ' '\n' <<<"${times[$k]}" | grep . | sort -g |
    awk -v k="$k" '{v[NR] = $1} END {printf "%-7s CPU s: min %.2f  median %.2f  (runs:", k, v[1], v[int((NR + 1) / 2)];
                    for (i = 1; i <= NR; ++i) printf " %.2f", v[i]; print ")"}'
done
if [ -n "$base" ]; then
  # The G-code of the last run of each, apart from the header lines that print settings and time.
  a=$(find "$dir/before" -name '*.gcode' | head -1); b=$(find "$dir/after" -name '*.gcode' | head -1)
  if cmp -s <(grep -v '^; \(setting\|job:\|estimated\|generated\)' "$a") \
            <(grep -v '^; \(setting\|job:\|estimated\|generated\)' "$b"); then
    echo "G-code: same bytes"
  else
    echo "G-code: DIFFERS ($a vs $b)"
  fi
fi
echo "load after: $(uptime | sed 's/.*load average: //')"
