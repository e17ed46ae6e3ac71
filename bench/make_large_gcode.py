#!/usr/bin/env python3
"""Writes a large PrusaSlicer-style G-code file (for the viewer benchmark): a 100 x 100 mm block,
layers of a perimeter loop plus zigzag infill, until the file reaches the requested size.
Usage: make_large_gcode.py OUT.gcode [MEGABYTES=100]"""
import math
import sys

out, mb = sys.argv[1], float(sys.argv[2]) if len(sys.argv) > 2 else 100.0
limit = int(mb * 1e6)
size = 0

with open(out, "w") as f:
    f.write("G21\nG90\nM83 ; relative E: short lines, as slicers write them\nM104 S215\n")
    layer = 0
    while size < limit:
        z = 0.2 * (layer + 1)
        buf = [f";LAYER_CHANGE\n;Z:{z:.2f}\nG1 Z{z:.2f} F600\n", ";TYPE:External perimeter\n",
               "G1 X0 Y0 F9000\n"]
        for x, y in ((100, 0), (100, 100), (0, 100), (0, 0)):
            buf.append(f"G1 X{x} Y{y} E3.3 F1800\n")
        buf.append(";TYPE:Solid infill\n")
        buf.append("G1 X0.5 Y0.5 F9000\n")
        # zigzag of short segments (a wavy infill as slicers write for Arachne / gyroid)
        n = 0
        for row in range(200):
            y = 0.5 + row * 0.495
            xs = range(0, 200) if row % 2 == 0 else range(199, -1, -1)
            for i in xs:
                x = 0.5 + i * 0.495
                yy = y + 0.1 * math.sin(i * 0.7 + layer)
                buf.append(f"G1 X{x:.2f} Y{yy:.2f} E.0163\n")
                n += 1
        text = "".join(buf)
        f.write(text)
        size += len(text)
        layer += 1
print(f"{out}: {layer} layers, {size / 1e6:.1f} MB")
