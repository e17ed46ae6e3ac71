#!/usr/bin/env bash
# Toolpath quality and slicing time of the planar slicer against PrusaSlicer 2.5, side by side on
# the same meshes with matched settings (issue 39): 0.2 mm layers, 2 walls, 20 % rectilinear,
# 4 top / 4 bottom layers, 0.4 mm beads everywhere, every speed 80 mm/s, travel 250 mm/s,
# retraction 0.6 mm at 40 mm/s with a 0.2 mm lift from 1.5 mm of travel (Trellis:
# profiles/voron_klipper.toml). Both G-code files are read back by `trellis analyze` with the
# same time model (3000 mm/s², no junction speeds): extrusion starts, retractions, travel (XY),
# estimated print time, filament. Slicing time is CPU time (user + sys), the minimum of RUNS
# interleaved runs of each; the machine's load average is printed before and after.
#
# Usage: bench/continuous_paths.sh [trellis binary] [work dir] [runs]
# Meshes: examples/designs/Vase.stl, and TR12J_OCC.stl from Debian's occt-misc (fetched with
# apt-get download into the work dir, scaled by 0.5 to fit a 350 mm bed).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="$(realpath "${1:-$root/build/release/apps/trellis/trellis}")"
work="${2:-$root/out/bench_continuous}"
runs="${3:-3}"
mkdir -p "$work"
cd "$work"
# shellcheck source=peers.sh
source "$root/bench/peers.sh"
command -v prusa-slicer >/dev/null || { echo "prusa-slicer is not installed (scripts/install-deps.sh installs it)" >&2; exit 2; }
profile="$root/profiles/voron_klipper.toml"

if [ ! -f tr12j_half.stl ] && peers_occt; then
  peers_scale_stl "$(occt_stl TR12J_OCC.stl)" tr12j_half.stl 0.5
fi
[ -f tr12j_half.stl ] || echo "TR12J is left out" >&2
cp "$root/examples/designs/Vase.stl" vase.stl
models=(vase)
[ -f tr12j_half.stl ] && models+=(tr12j_half)

echo "load before: $(cut -d' ' -f1-3 /proc/loadavg) ($(nproc) cores)"
for m in "${models[@]}"; do
  t_best=1e9 p_best=1e9
  for ((r = 0; r < runs; ++r)); do
    rm -f "$m.trellis.gcode" "$m.prusa.gcode"
    t=$(cpu "$bin" slice "$m.stl" --machine "$profile" --threads 1 -o "$m.trellis.gcode" --report "$m.trellis.json")
    p=$(cpu prusa-slicer "${prusa_args[@]}" -o "$m.prusa.gcode" "$m.stl")
    t_best=$(min_of "$t_best" "$t")
    p_best=$(min_of "$p_best" "$p")
    [ -s "$m.trellis.gcode" ] && [ -s "$m.prusa.gcode" ] || { echo "a slicer failed on $m" >&2; exit 1; }
    echo "$m run $((r + 1)): trellis ${t} s, prusa-slicer ${p} s CPU" >&2
  done
  "$bin" analyze "$m.trellis.gcode" --acceleration 3000 --report "$m.trellis.analyze.json" >/dev/null
  "$bin" analyze "$m.prusa.gcode" --acceleration 3000 --report "$m.prusa.analyze.json" >/dev/null
  /usr/bin/python3 - "$m" "$t_best" "$p_best" <<'PY'
import json, sys
m, t_cpu, p_cpu = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
t = json.load(open(f"{m}.trellis.analyze.json"))
p = json.load(open(f"{m}.prusa.analyze.json"))
rep = json.load(open(f"{m}.trellis.json"))
link = rep.get("linking", {})
print(f"\n## {m}: {t['layers']} layers (PrusaSlicer {p['layers']})")
print("| measure | Trellis | PrusaSlicer 2.5 | ratio |")
print("|---|---|---|---|")
rows = [("extrusion starts", "extrusion_starts", 1), ("retractions", "retractions", 1),
        ("travel (m)", "travel_length_mm", 1e-3), ("estimated print time (h)", "print_time_s", 1 / 3600),
        ("filament (m)", "filament_mm", 1e-3), ("extruded path (m)", "extruded_length_mm", 1e-3)]
for name, key, f in rows:
    a, b = t[key] * f, p[key] * f
    print(f"| {name} | {a:,.1f} | {b:,.1f} | {a / b if b else float('nan'):.3f} |")
print(f"| slicing CPU (s, one thread / PrusaSlicer's own) | {t_cpu:.2f} | {p_cpu:.2f} | {t_cpu / p_cpu:.3f} |")
if link:
    share = link["link_seconds"] / link["layer_plan_seconds"] if link["layer_plan_seconds"] else 0
    print(f"\nTrellis linking: {link['starts']:,} starts against a lower bound of "
          f"{link['starts_lower_bound']:,} ({link['starts'] / max(1, link['starts_lower_bound']):.2f}x); "
          f"{link['travels_inside_part']:,} of {link['travels_in_layers']:,} travels within layers kept "
          f"inside; connectors {link['connector_length_mm'] / 1000:.1f} m; linking "
          f"{link['link_seconds']:.2f} s of {link['layer_plan_seconds']:.2f} s planning the layers "
          f"({100 * share:.0f} %) and {100 * link['link_seconds'] / t_cpu:.0f} % of the slicing CPU time.")
PY
done
echo
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
