#!/usr/bin/env python3
"""A large closed mesh for the loading benchmarks: a torus of 2·NU·NV triangles as a binary STL
(or, by OUT's name, an ASCII STL: OUT.ascii.stl, an OBJ: OUT.obj, or a 3MF: OUT.3mf, the
model part deflated as the 3MF writers store it).

Every vertex is shared by six triangles, as in CAD exports, so welding and the closed-manifold
check do their full work. The default (1000 × 500) is 1,000,000 triangles, 50,000,084 bytes; the
same torus bench/bench_mesh_io.cpp builds in memory. Nothing is fetched.
Usage: bench/make_torus_stl.py OUT.stl|OUT.ascii.stl|OUT.obj|OUT.3mf [NU=1000] [NV=500]
"""
import sys
import zipfile

import numpy as np


def main():
    out = sys.argv[1]
    nu = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
    nv = int(sys.argv[3]) if len(sys.argv) > 3 else 500
    big_r, r = 60.0, 20.0
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    uu, vv = np.meshgrid(u, v, indexing="ij")
    pts = np.stack([(big_r + r * np.cos(vv)) * np.cos(uu), (big_r + r * np.cos(vv)) * np.sin(uu),
                    r * np.sin(vv)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    i, j = i.ravel(), j.ravel()

    def vid(a, b):
        return (a % nu) * nv + (b % nv)

    tris = np.empty((2 * nu * nv, 3), dtype=np.int64)
    tris[0::2] = np.stack([vid(i, j), vid(i + 1, j), vid(i + 1, j + 1)], axis=-1)
    tris[1::2] = np.stack([vid(i, j), vid(i + 1, j + 1), vid(i, j + 1)], axis=-1)
    if out.endswith(".obj"):
        with open(out, "w") as f:
            f.write("".join("v %.9g %.9g %.9g\n" % tuple(p) for p in pts.astype(np.float32)))
            f.write("".join("f %d %d %d\n" % tuple(t) for t in tris + 1))
        return
    if out.endswith(".3mf"):
        core = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
        model = "".join(
            ['<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" '
             'xmlns="%s">\n <resources>\n  <object id="1" type="model">\n   <mesh>\n'
             '    <vertices>\n' % core] +
            ['     <vertex x="%.9g" y="%.9g" z="%.9g"/>\n' % tuple(p) for p in pts.astype(np.float32)] +
            ['    </vertices>\n    <triangles>\n'] +
            ['     <triangle v1="%d" v2="%d" v3="%d"/>\n' % tuple(t) for t in tris] +
            ['    </triangles>\n   </mesh>\n  </object>\n </resources>\n <build>\n'
             '  <item objectid="1"/>\n </build>\n</model>\n'])
        types = ('<?xml version="1.0" encoding="UTF-8"?>\n<Types xmlns="http://schemas.openxmlformats'
                 '.org/package/2006/content-types"><Default Extension="rels" ContentType="application/'
                 'vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" '
                 'ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>\n')
        rels = ('<?xml version="1.0" encoding="UTF-8"?>\n<Relationships xmlns="http://schemas.'
                'openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.'
                'model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/'
                '3dmodel"/></Relationships>\n')
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("[Content_Types].xml", types)
            z.writestr("_rels/.rels", rels)
            z.writestr("3D/3dmodel.model", model)
        return
    if out.endswith(".ascii.stl"):
        corners = pts[tris].astype(np.float32)
        with open(out, "w") as f:
            f.write("solid torus\n")
            f.write("".join("facet normal 0 0 0\n outer loop\n  vertex %.9g %.9g %.9g\n"
                            "  vertex %.9g %.9g %.9g\n  vertex %.9g %.9g %.9g\n endloop\nendfacet\n"
                            % tuple(c.ravel()) for c in corners))
            f.write("endsolid torus\n")
        return
    rec = np.zeros(len(tris), dtype=[("n", "<f4", 3), ("p", "<f4", 9), ("attr", "<u2")])
    rec["p"] = pts[tris].reshape(-1, 9).astype(np.float32)
    with open(out, "wb") as f:
        f.write(b"trellis benchmark torus".ljust(80, b" "))
        f.write(np.uint32(len(tris)).tobytes())
        f.write(rec.tobytes())


if __name__ == "__main__":
    main()
