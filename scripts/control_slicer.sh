#!/usr/bin/env bash
# `make compare`: the GIPPO paper's control-slicer comparison, for real. For the six geometries
# (10 x 10 mm, one 0.148 mm layer) the lattice is exported as solid walls (STL), sliced by
# PrusaSlicer with one perimeter and 0 % infill (the paper's "wall structure"), and measured
# with `trellis compare` against the design, beside Trellis's own GIPPO output.
# Usage: scripts/control_slicer.sh [trellis binary] [output dir] [wall widths...]
set -euo pipefail
bin="${1:-build/release/apps/trellis/trellis}"
out="${2:-out/control}"
shift $(( $# > 2 ? 2 : $# )) || true
widths=("$@")
[ ${#widths[@]} -eq 0 ] && widths=(0.2 0.38)
command -v prusa-slicer >/dev/null || { echo "prusa-slicer is not installed (scripts/install-deps.sh installs it)" >&2; exit 2; }
mkdir -p "$out"
profile="$(dirname "$0")/../profiles/ender3_s1_pro_tpu.toml"
echo "| geometry | G-code | wall mm | ratio | double mm | missing struts | extrusion starts | GIPPO score (corrected) |"
echo "|---|---|---|---|---|---|---|---|"
while read -r spec; do
  case "$spec" in ""|"#"*) continue ;; esac
  name=${spec%% *}
  "$bin" lattice2d --pattern $spec --size 10,10 -o "$out/$name.json" >/dev/null
  "$bin" plan gippo "$out/$name.json" -o "$out/$name.toolpath.json" >/dev/null
  "$bin" gcode "$out/$name.toolpath.json" --machine "$profile" --center -o "$out/$name.trellis.gcode" >/dev/null
  files=("$out/$name.trellis.gcode")
  for w in "${widths[@]}"; do
    "$bin" walls "$out/$name.json" --bead-width "$w" --height 0.148 -o "$out/$name.walls$w.stl" >/dev/null
    prusa-slicer --export-gcode --layer-height 0.148 --first-layer-height 0.148 --nozzle-diameter 0.2 \
      --extrusion-width 0.2 --perimeter-extrusion-width 0.2 --external-perimeter-extrusion-width 0.2 \
      --first-layer-extrusion-width 0.2 --fill-density 0% --top-solid-layers 0 --bottom-solid-layers 0 \
      --perimeters 1 --skirts 0 --brim-width 0 -o "$out/$name.prusa$w.gcode" "$out/$name.walls$w.stl" >/dev/null 2>&1
    files+=("$out/$name.prusa$w.gcode")
  done
  "$bin" compare "$out/$name.json" "${files[@]}" --align --bead-width 0.2 --report "$out/$name.compare.json" \
    --preview "$out/$name" >/dev/null
  /usr/bin/python3 - "$out/$name.compare.json" "$name" <<'PY'
import json, re, sys
for r in json.load(open(sys.argv[1])):
    m = re.search(r"prusa([0-9.]+)\.gcode$", r["name"])
    who, wall = ("PrusaSlicer 2.5", m.group(1)) if m else ("Trellis (GIPPO max)", "-")
    print(f"| {sys.argv[2]} | {who} | {wall} | {r['extrusion_ratio']:.2f} | {r['double_length_mm']:.1f} | "
          f"{r['missing_edges']}/{r['design_edges']} | {r['extrusion_starts']} | {r['score']:.3f} ({r['score_corrected']:.3f}) |")
PY
done < "$(dirname "$0")/six_geometries.list"
