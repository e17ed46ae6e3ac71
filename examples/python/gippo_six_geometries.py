"""GIPPO paper, Table 1 / Fig. 2: the six 10 x 10 mm geometries planned with GIPPO (max mode),
paths, lower bound, score (Eq. 1), LTS (Eq. 2) and OE (Eq. 3) of the best of N iterations.

    python3 examples/python/gippo_six_geometries.py [ITERATIONS]
"""
import sys

import trellis

GEOMETRIES = [  # the paper's six, as in scripts/six_geometries.list
    dict(pattern="honeycomb", cell=1.0),
    dict(pattern="voronoi", density=1.0, seed=1),
    dict(pattern="penrose", cell=1.2),
    dict(pattern="snub-square", cell=1.2),
    dict(pattern="arrowhead", cell=1.5),
    dict(pattern="reentrant-honeycomb", cell=1.5),
]

iterations = int(sys.argv[1]) if len(sys.argv) > 1 else 500
print(f"{'geometry':22s} {'struts':>6s} {'paths':>6s} {'bound':>6s} {'score':>7s}")
for g in GEOMETRIES:
    lattice = trellis.lattice2d(size=(10, 10), **g).lattice
    r = trellis.plan("gippo", lattice, iterations=iterations, seed=1)
    # The summary line carries the numbers of the report; the paths come from the arrays.
    paths = r.toolpath.path_count
    bound = int(r.summary.split("lower bound ")[1].split(")")[0])
    score = float(r.summary.split("score ")[1].split(",")[0])
    print(f"{g['pattern']:22s} {lattice.edge_count:6d} {paths:6d} {bound:6d} {score:7.4f}")
