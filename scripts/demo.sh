#!/usr/bin/env bash
# `make demo`: runs the main job on a bundled example and says where the outputs are.
set -euo pipefail
cd "$(dirname "$0")/.."
bin="$1"
echo "== trellis run examples/honeycomb_tensile.toml -o out/demo"
"$bin" run examples/honeycomb_tensile.toml -o out/demo
echo
echo "Open out/demo/honeycomb_tensile_preview/layer_0000.png for the first layer (paths coloured by"
echo "print order, travel dashed) and out/demo/honeycomb_tensile_preview/scores.png for the GIPPO"
echo "scores. The G-code is out/demo/honeycomb_tensile.gcode; the numbers are in"
echo "out/demo/honeycomb_tensile.report.json. Every example job: ls examples/*.toml examples/jobs/."
