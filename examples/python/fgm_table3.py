"""FGM paper, Table 3: the palette plate sliced with Strategy 1 (16 colours) and Strategy 2
(48 colours) on the mixing hotend, with their run times (the paper: 99 s and 424 s in Python).

    python3 examples/python/fgm_table3.py [COLOURS_S2]
"""
import os
import sys
import time

import trellis

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
design = os.path.join(ROOT, "examples", "designs", "fgm_palette_plate.vcad")
machine = os.path.join(ROOT, "profiles", "geeetech_mizar_m_mixing.toml")
s2_colors = int(sys.argv[1]) if len(sys.argv) > 1 else 48
for strategy, colors in [(1, 16), (2, s2_colors)]:
    t0 = time.perf_counter()
    r = trellis.slice(design, machine=machine, strategy=strategy, colors=colors)
    tp = r.toolpath
    print(f"strategy {strategy}, {colors} colours: {tp.layer_count} layers, {tp.path_count} paths, "
          f"{len(set(map(tuple, tp.mixture.round(4))))} mixtures, {time.perf_counter() - t0:.2f} s")
