#!/usr/bin/env bash
# Integration test: Trellis and PrusaSlicer on the same lattice, measured by `trellis compare`.
set -euo pipefail
bin="$1"; out="$2"
mkdir -p "$out"
command -v prusa-slicer >/dev/null || { echo "FAIL: prusa-slicer missing (scripts/install-deps.sh installs it)"; exit 1; }
export HOME="${HOME:-$out}"  # PrusaSlicer keeps its settings there
src="$(cd "$(dirname "$0")/../.." && pwd)"
"$bin" lattice2d --pattern penrose --cell 1.2 --size 10,10 -o "$out/p.json" >/dev/null
"$bin" plan gippo "$out/p.json" -o "$out/p.tp.json" --iterations 100 >/dev/null
"$bin" gcode "$out/p.tp.json" --machine "$src/profiles/ender3_s1_pro_tpu.toml" --center -o "$out/trellis.gcode" >/dev/null
"$bin" walls "$out/p.json" --bead-width 0.38 --height 0.148 -o "$out/p.stl" >/dev/null
prusa-slicer --export-gcode --layer-height 0.148 --first-layer-height 0.148 --nozzle-diameter 0.2 \
  --extrusion-width 0.2 --perimeter-extrusion-width 0.2 --external-perimeter-extrusion-width 0.2 \
  --first-layer-extrusion-width 0.2 --fill-density 0% --top-solid-layers 0 --bottom-solid-layers 0 \
  --perimeters 1 --skirts 0 --brim-width 0 -o "$out/prusa.gcode" "$out/p.stl" >/dev/null 2>&1
"$bin" compare "$out/p.json" "$out/trellis.gcode" "$out/prusa.gcode" --align --bead-width 0.2 --report "$out/r.json"
/usr/bin/python3 - "$out/r.json" <<'PY'
import json, sys
ours, prusa = json.load(open(sys.argv[1]))
checks = [
    ("trellis ratio 1.00", abs(ours["extrusion_ratio"] - 1) < 2e-3),
    ("trellis no double deposit", ours["double_length_mm"] == 0),
    ("trellis no missing strut", ours["missing_edges"] == 0),
    ("trellis no off-design deposit", ours["off_design_length_mm"] == 0),
    ("prusa G-code read", prusa["extruded_length_mm"] > 0.5 * prusa["nominal_length_mm"]),
    ("prusa deposits more than the design (walls 2 lines wide)", prusa["extrusion_ratio"] > 1.2),
    ("prusa deposits some struts twice", prusa["double_length_mm"] > 0),
]
failed = [name for name, ok in checks if not ok]
print(f"{len(checks) - len(failed)} passed, {len(failed)} failed")
for name in failed:
    print("FAILED:", name)
sys.exit(1 if failed else 0)
PY
