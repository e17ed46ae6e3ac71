#!/usr/bin/env bash
# The GIPPO paper's six geometries (10 x 10 mm, one layer), planned with gippo max, gippo min and
# euler; prints a Markdown table of paths, lower bound, score (Eq. 1), LTS (Eq. 2), OE (Eq. 3).
set -euo pipefail
bin="${1:-build/release/apps/trellis/trellis}"
out="${2:-out/six}"
mkdir -p "$out"
echo "| geometry | edges | lower bound | planner | paths | score | LTS % | OE % | travel mm |"
echo "|---|---|---|---|---|---|---|---|---|"
while read -r spec; do
  case "$spec" in ""|"#"*) continue ;; esac
  name=${spec%% *}
  "$bin" lattice2d --pattern $spec --size 10,10 -o "$out/$name.json" >/dev/null
  for planner in "gippo --mode max" "gippo --mode min" "euler"; do
    tag=$(echo "$planner" | tr -d ' -' | sed 's/gippomode/gippo-/')
    "$bin" plan $planner "$out/$name.json" -o "$out/$name.$tag.toolpath.json" --report "$out/$name.$tag.report.json" >/dev/null
    /usr/bin/python3 - "$out/$name.$tag.report.json" "$name" "$tag" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"| {sys.argv[2]} | {r['lattice_edges']} | {r['lower_bound_paths']} | {sys.argv[3]} | {r['paths']} | "
      f"{r['score']:.3f} | {r['lts']:.1f} | {r['oe']:.2f} | {r['travel_length_mm']:.0f} |")
PY
  done
done < "$(dirname "$0")/six_geometries.list"
