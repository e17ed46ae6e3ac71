"""PBF paper, Fig. 3(b) / Eq. 8: scan length per layer of the hybrid strategy (contour tracks on
thin walls, 67°-rotating hatch at joints) against the plain R67 hatch, for a gyroid sheet.

    python3 examples/python/pbf_fr_a.py
"""
import numpy as np

import trellis

for strategy in ("hybrid", "r67"):
    tp = trellis.pbf(strategy=strategy, cell_type="gyroid", cell=2.5, size=(5, 5, 1)).toolpath
    a = tp.arrays()
    seg = np.linalg.norm(np.diff(a["points"], axis=0), axis=1)
    keep = np.ones(len(seg), bool)
    keep[a["path_offsets"][1:-1] - 1] = False          # no jumps between vectors
    path_of_seg = np.repeat(np.arange(tp.path_count), np.diff(a["path_offsets"]))[:-1]
    layer_of_path = np.repeat(np.arange(tp.layer_count), np.diff(a["layer_offsets"]))
    per_layer = np.bincount(layer_of_path[path_of_seg[keep]], weights=seg[keep], minlength=tp.layer_count)
    print(f"{strategy:6s}: {tp.layer_count} layers, scan length per layer mean {per_layer.mean():.2f} mm, "
          f"CV {per_layer.std() / per_layer.mean():.3f}")
