"""AERO paper, §3: an octet cell printed in fewer steps than the paper's 8 (vs 18 semi-manual;
the paper's own groups method, method="groups", gives its 8; its semi-manual baseline,
method="periodic", the 18), and a 3 x 3 x 3 octet lattice, collision-free, checked
independently. examples/papers/aero/reproduce.py has every figure.

    python3 examples/python/aero_octet_trails.py
"""
import os

import numpy as np

import trellis

for count in [(1, 1, 1), (3, 3, 3)]:
    lattice = trellis.lattice3d(cell_type="octet", cell=7, count=count).lattice
    r = trellis.plan("aero", lattice)
    tp = r.toolpath
    struts_per_trail = np.diff(tp.path_offsets) - 1
    print(f"octet {count}: {lattice.edge_count} struts, {tp.path_count} trails, "
          f"longest {struts_per_trail.max()} struts; {r.summary.split('collisions ')[1]}")
    # The paper's semi-manual baseline: a hand-made cell path repeated per cell (18 steps a cell).
    m = trellis.plan("aero", lattice, method="periodic", periodic_cell="octet", periodic_size=7)
    print(f"  semi-manual (method periodic): {m.toolpath.path_count} trails; "
          f"{m.summary.split('collisions ')[1]}")

# The paper's Stanford bunny lattice (351 nodes, 1,091 struts), from its vertex and edge files,
# planned as published (keep_graph: by default two nodes lying on other struts split them, 1,093).
bunny = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "aero", "stanford_bunny_vertices.csv")
lattice = trellis.read_lattice(bunny)
r = trellis.plan("aero", bunny, keep_graph=True)
struts = int(r.summary.split(" struts")[0].split()[-1])
print(f"bunny: {lattice.node_count} nodes, {struts} struts, {r.toolpath.path_count} trails; "
      f"{r.summary.split('collisions ')[1]}")
