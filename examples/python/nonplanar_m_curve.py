"""Non-planar paper, Fig. 3: the two-material "M" — three layers black, three clear, three
black — as continuous serpentines on the surface, one path per layer.

    python3 examples/python/nonplanar_m_curve.py
"""
import os
import tempfile

import numpy as np

import trellis

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
machine = os.path.join(ROOT, "profiles", "fresh_nonplanar_2syringe.toml")
with tempfile.TemporaryDirectory() as d:
    stl = os.path.join(d, "m.stl")
    trellis.surface("m-curve", stl)
    r = trellis.nonplanar(stl, machine=machine, layers=9, layer_tools="3:0,3:1,3:0", angles=[0])
tp = r.toolpath
print(f"{tp.layer_count} layers, {tp.path_count} paths, tools per layer {list(tp.tool)}")
print(f"height range {np.ptp(tp.points[:, 2]):.2f} mm; {r.summary.split(', ')[4]}")
