#!/usr/bin/env bash
# Issue 40, item 1 (two threads >= 1.7x one): where a `trellis slice` run cannot use a second
# thread, measured without a quiet machine. One callgrind run per mesh on one thread gives each
# phase's share of the instructions (load does not change them), each from callgrind's inclusive
# cost of the functions that do it: process start and the command line, the mesh read and
# checked, the slicing pipeline (outlines, walls, infill, linking: on every thread), the G-code
# writer's passes over the layers (placement, machine check), the print-time estimate (the
# scanner's entry points: GcodeScanner::plain_motion for the writer's own moves, move_words and
# feed for the rest; on one thread they are called from inside the formatting, so a split by the
# functions' own cost shows them as formatting), the thumbnails, and the formatting (the writer
# less the other three). From these the two-thread time is modelled (work-span, the slicing
# perfectly shared):
#   writer serial (everything of the writer's on one thread):
#     start + read + slicing / 2 + writer
#   writer overlapped (src/machine/estimate_pipe.hpp: the estimate on the second thread, the
#   thumbnails on whichever thread is free first):
#     start + read + slicing / 2 + passes + min(max(formatting + thumbnails, estimate),
#                                               max(formatting, estimate + thumbnails))
# and printed as the Amdahl bound on the speed-up (one thread's instructions over the modelled
# time) with its serial share s (bound = 1 / (s + (1 - s) / 2)), beside the measured wall
# speed-up of RUNS interleaved one- and two-thread runs (min, median, max), the median CPU
# seconds (user + sys) of one and of two threads (the second thread's waste shows as 2T CPU above
# 1T CPU) and the highest load seen: on a busy machine the measured column does not show what
# two threads give (it says so).
# Settings as bench/ratios.sh's. Meshes: made (or reused) in the work dir as bench/ratios.sh
# makes them.
#
# Usage: bench/threads_model.sh [--only a,b] [--runs N] [--trellis BIN] [--work DIR] [--build DIR]
#          [--reuse]
#   --only: torus_3k vase torus_1m tr12j_half held_sh1 held_sh2 held_shape (default: the first
#   four and held_shape); --runs: interleaved wall runs per mesh (default 5; 0: the model only);
#   --reuse: a mesh's callgrind profile already in the work dir (MESH.callgrind.txt) is used, not
#   made again (the same binary's one-thread run: it is not checked).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build/release"
bin=""
work="$root/out/bench_ratios"
runs=5
reuse=0
only="torus_3k,vase,torus_1m,tr12j_half,held_shape"
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift ;;
    --trellis) bin="$2"; shift ;;
    --work) work="$2"; shift ;;
    --build) build="$2"; shift ;;
    --only) only="$2"; shift ;;
    --reuse) reuse=1 ;;
    *) echo "usage: $0 [--only a,b] [--runs N] [--trellis BIN] [--work DIR] [--build DIR] [--reuse]" >&2; exit 2 ;;
  esac
  shift
done
bin="$(realpath "${bin:-$build/apps/trellis/trellis}")"
[ -x "$bin" ] || { echo "no trellis binary at $bin (build it, or --trellis)" >&2; exit 2; }
command -v valgrind >/dev/null && command -v callgrind_annotate >/dev/null ||
  { echo "valgrind (callgrind) is needed: apt-get install valgrind" >&2; exit 2; }
mkdir -p "$work"
cd "$work"
# shellcheck source=peers.sh
source "$root/bench/peers.sh"

want() { [[ ",$only," == *",$1,"* ]]; }
want torus_3k && { [ -f torus_3k.stl ] || /usr/bin/python3 "$root/bench/make_torus.py" 50 30 torus_3k.stl; }
want vase && { [ -f vase.stl ] || peers_place_stl "$root/examples/designs/Vase.stl" vase.stl; }
want torus_1m && { [ -f torus_1m.stl ] || /usr/bin/python3 "$root/bench/make_torus.py" 1000 500 torus_1m.stl; }
if want tr12j_half || want held_sh1 || want held_sh2 || want held_shape; then
  if peers_occt; then
    want tr12j_half && { [ -f tr12j_half.stl ] || peers_scale_stl "$(occt_stl TR12J_OCC.stl)" tr12j_half.stl 0.5; }
    for h in sh1 sh2 shape; do
      want "held_$h" && { [ -f "held_$h.stl" ] || peers_place_stl "$(occt_stl $h.stl)" "held_$h.stl"; }
    done
  fi
fi

args=(--machine "$root/profiles/voron_klipper.toml" --layer-height 0.2 --walls 2 --infill 0.2
  --infill-pattern rectilinear --top 4 --bottom 4 --force)

# The largest inclusive count of the functions whose names contain PATTERN (a fixed string).
incl() { grep -F -- "$2" "$1" | awk '{gsub(",", "", $1); if ($1 + 0 > m) m = $1 + 0} END {print m + 0}'; }

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "load before: $(load_now)"
echo "phases: % of one thread's instructions (callgrind); model: two-thread time with the slicing shared perfectly"
rows=()
for m in torus_3k vase torus_1m tr12j_half held_sh1 held_sh2 held_shape; do
  want "$m" && [ -f "$m.stl" ] || continue
  if [ $reuse = 0 ] || [ ! -s "$m.callgrind.txt" ]; then
    valgrind --tool=callgrind --callgrind-out-file="$m.callgrind" "$bin" slice "$m.stl" "${args[@]}" \
      --threads 1 -o "$m.model.gcode" >/dev/null 2>&1 || { echo "callgrind run failed on $m" >&2; exit 1; }
    callgrind_annotate --inclusive=yes --threshold=100 "$m.callgrind" 2>/dev/null >"$m.callgrind.txt"
  fi
  f="$m.callgrind.txt"
  total=$(grep 'PROGRAM TOTALS' "$f" | awk '{gsub(",", "", $1); print $1}')
  slicing=$(incl "$f" 'trellis::stream_slice(trellis::SliceJob')
  open=$(incl "$f" '::open_design(trellis::SliceJob')
  writer=$(incl "$f" 'trellis::routes::write_gcode_streamed(')
  thumbs=$(incl "$f" 'trellis::gcode_thumbnails(')
  estimate=$(($(incl "$f" 'trellis::GcodeScanner::plain_motion(') + $(incl "$f" 'trellis::GcodeScanner::move_words(') +
    $(incl "$f" 'trellis::GcodeScanner::feed(') + $(incl "$f" 'trellis::GcodeScanner::finish(')))
  passes=$(($(incl "$f" 'trellis::check_for_machine(') + $(incl "$f" 'Writer::placement(')))
  lmax=0 list='' c1s='' c2s=''
  for ((r = 0; r < runs; ++r)); do
    lmax=$(awk -v a="$lmax" -v b="$(load1)" 'BEGIN {print (b + 0 > a + 0) ? b : a}')
    c1=$(cpu "$bin" slice "$m.stl" "${args[@]}" --threads 1 -o "$m.t1.gcode"); w1=$(last_wall)
    c2=$(cpu "$bin" slice "$m.stl" "${args[@]}" --threads 2 -o "$m.t2.gcode"); w2=$(last_wall)
    cmp -s "$m.t1.gcode" "$m.t2.gcode" || { echo "$m: 1 and 2 threads wrote different G-code" >&2; exit 1; }
    list="$list $(awk -v a="$w1" -v b="$w2" 'BEGIN {printf "%.3f", (b > 0 ? a / b : 0)}')"
    c1s="$c1s $c1" c2s="$c2s $c2"
  done
  rows+=("$m|$total|$slicing|$open|$writer|$thumbs|$estimate|$passes|$lmax|$list|$c1s|$c2s")
  echo "$m done (load $(load1))" >&2
done

echo
echo "| mesh | 1T instructions | start + command | mesh read + check | slicing (shared) | writer passes | formatting | estimate | thumbnails | bound, writer serial | Amdahl bound, writer overlapped (serial share) | measured 2T wall speed-up min / median / max | CPU s 1T / 2T (medians) | machine |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
busy=0
for row in "${rows[@]}"; do
  IFS='|' read -r m total slicing open writer thumbs estimate passes lmax list c1s c2s <<<"$row"
  if [ -z "$list" ]; then
    measured="-" state="-" cpus="-"
  else
    measured=$(echo $list | tr ' ' '\n' | sort -g | awk '{a[NR] = $1} END {printf "%.2fx / %.2fx / %.2fx (%d runs)", a[1], a[int((NR + 1) / 2)], a[NR], NR}')
    median() { echo $1 | tr ' ' '\n' | sort -g | awk '{a[NR] = $1} END {printf "%.3f", a[int((NR + 1) / 2)]}'; }
    cpus="$(median "$c1s") / $(median "$c2s")"
    if is_quiet "$lmax"; then state="quiet (load <= $lmax)"; else state="busy (load up to $lmax)"; busy=1; fi
  fi
  awk -v m="$m" -v T="$total" -v S="$slicing" -v O="$open" -v W="$writer" -v Th="$thumbs" \
    -v E="$estimate" -v P="$passes" -v meas="$measured" -v st="$state" -v cpus="$cpus" 'BEGIN {
    start = T - S - W; slice = S - O; fmt = W - Th - E - P
    t2_serial = start + O + slice / 2 + W
    a = fmt + Th > E ? fmt + Th : E      # the thumbnails on the writing thread
    b = fmt > E + Th ? fmt : E + Th      # ... on the estimate thread
    side = a < b ? a : b
    t2_over = start + O + slice / 2 + P + side
    b1 = T / t2_serial; b2 = T / t2_over; s2 = 2 / b2 - 1
    pc = 100 / T
    printf "| %s | %.3g | %.1f %% | %.1f %% | %.1f %% | %.1f %% | %.1f %% | %.1f %% | %.1f %% | %.2fx | %.2fx (%.0f %%) | %s | %s | %s |\n",
      m, T, start * pc, O * pc, slice * pc, P * pc, fmt * pc, E * pc, Th * pc, b1, b2, 100 * s2, meas, cpus, st }'
done
if [ $busy = 1 ]; then
  echo "The machine was not quiet (1-minute load above $quiet_load before some runs): the measured speed-ups do not show what two threads give; the bounds (instruction shares) still hold."
fi
echo
echo "load after: $(load_now)"
