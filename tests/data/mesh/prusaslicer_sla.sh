#!/bin/bash
# PrusaSlicer 2.5's SLA slice of a mesh: 0.1 mm pixels on a 600 mm display, no supports, pad or
# corrections, 0.2 mm layers. Layer i >= 1 of the archive is the section at z = zmin + 0.2 i + 0.1.
set -e
in=$1; out=$2
prusa-slicer --export-sla --printer-technology SLA --bed-shape 0x0,600x0,600x600,0x600 \
  --display-width 600 --display-height 600 --display-pixels-x 6000 --display-pixels-y 6000 \
  --display-orientation landscape --layer-height 0.2 --initial-layer-height 0.2 \
  --no-supports-enable --no-pad-enable --elefant-foot-compensation 0 --absolute-correction 0 \
  --gamma-correction 1 --max-print-height 400 --center 300,300 -o "$out" "$in" > "$out.log" 2>&1
