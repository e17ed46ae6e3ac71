#!/usr/bin/env python3
"""Writes examples/designs/Vase.stl: a closed vase-like solid, 135 x 175 x 100 mm (the size of the
FGM paper's vase, whose mesh is not published), centred at the origin like an OpenVCAD primitive.
A surface of revolution with an elliptical section: radius r(z) swells and necks, binary STL."""
import math, struct, sys

N, M = 96, 40               # points around, rings up
HALF_X, HALF_Y, H = 67.5, 87.5, 100.0

def radius(t):              # t in [0, 1] bottom to top, relative radius in (0, 1]
    return 0.62 + 0.38 * math.sin(math.pi * (0.15 + 0.85 * t)) ** 2 - 0.12 * t

rmax = max(radius(k / (M - 1)) for k in range(M))
rings = []
for k in range(M):
    t = k / (M - 1)
    z = -H / 2 + H * t
    r = radius(t) / rmax
    rings.append([(HALF_X * r * math.cos(2 * math.pi * i / N),
                   HALF_Y * r * math.sin(2 * math.pi * i / N), z) for i in range(N)])
tris = []
for k in range(M - 1):
    a, b = rings[k], rings[k + 1]
    for i in range(N):
        j = (i + 1) % N
        tris.append((a[i], a[j], b[j]))
        tris.append((a[i], b[j], b[i]))
bottom, top = (0.0, 0.0, -H / 2), (0.0, 0.0, H / 2)
for i in range(N):
    j = (i + 1) % N
    tris.append((bottom, rings[0][j], rings[0][i]))
    tris.append((top, rings[-1][i], rings[-1][j]))

def normal(p, q, r):
    u = [q[c] - p[c] for c in range(3)]
    v = [r[c] - p[c] for c in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    l = math.sqrt(sum(c * c for c in n)) or 1.0
    return tuple(c / l for c in n)

out = sys.argv[1] if len(sys.argv) > 1 else "examples/designs/Vase.stl"
with open(out, "wb") as f:
    f.write(b"trellis vase 135x175x100 mm".ljust(80, b" "))
    f.write(struct.pack("<I", len(tris)))
    for t in tris:
        f.write(struct.pack("<3f", *normal(*t)))
        for p in t:
            f.write(struct.pack("<3f", *p))
        f.write(b"\0\0")
print(f"{out}: {len(tris)} triangles")
