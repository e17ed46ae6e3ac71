#!/usr/bin/env bash
# `make demo`: runs the main job on a bundled example and says where the outputs went.
set -euo pipefail
cd "$(dirname "$0")/.."
bin="$1"
echo "== trellis run examples/honeycomb_tensile.toml"
"$bin" run examples/honeycomb_tensile.toml -o out/demo
echo
echo "Open out/demo/honeycomb_tensile.layer000.png for the first layer (paths coloured by print"
echo "order, travel dashed) and out/demo/honeycomb_tensile.scores.png for the GIPPO scores."
echo "The G-code is out/demo/honeycomb_tensile.gcode; the numbers are in out/demo/honeycomb_tensile.report.json."
