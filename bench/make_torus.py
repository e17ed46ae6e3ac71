#!/usr/bin/env python3
"""A closed torus as a binary STL, for the slicer benchmarks (bench/ratios.sh).

The same torus as bench_mesh_io.cpp's (R = 60 mm, r = 20 mm, 2·nu·nv triangles, every vertex
shared by six triangles), moved to stand on z = 0 at the centre of a 350 mm bed.
Usage: bench/make_torus.py NU NV OUT.stl   (50 30: 3,000 triangles; 1000 500: 1,000,000)
"""
import sys

import numpy as np


def torus(nu, nv, R=60.0, r=20.0, centre=(175.0, 175.0)):
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    uu, vv = np.meshgrid(u, v, indexing="ij")
    verts = np.stack([(R + r * np.cos(vv)) * np.cos(uu) + centre[0],
                      (R + r * np.cos(vv)) * np.sin(uu) + centre[1],
                      r * np.sin(vv) + r], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    ident = lambda a, b: (a % nu) * nv + (b % nv)
    t1 = np.stack([ident(i, j), ident(i + 1, j), ident(i + 1, j + 1)], axis=-1).reshape(-1, 3)
    t2 = np.stack([ident(i, j), ident(i + 1, j + 1), ident(i, j + 1)], axis=-1).reshape(-1, 3)
    tris = np.stack([t1, t2], axis=1).reshape(-1, 3)
    return verts, tris


def write_stl(path, verts, tris):
    p = verts[tris]  # (n, 3, 3)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-30)[:, None]
    rec = np.zeros(len(tris), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"], rec["v"] = n, p
    with open(path, "wb") as f:
        f.write(b"trellis bench torus".ljust(80, b" "))
        f.write(np.uint32(len(tris)).tobytes())
        f.write(rec.tobytes())


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    write_stl(sys.argv[3], *torus(int(sys.argv[1]), int(sys.argv[2])))
