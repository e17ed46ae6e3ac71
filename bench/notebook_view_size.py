"""Bytes of the inline viewer in a notebook showing the five paper notebooks' toolpaths, before
(each view the whole page, HTML-escaped into an iframe's srcdoc) and now (the viewer's script once,
each view its packed data). Usage: PYTHONPATH=build/release/python python3 bench/notebook_view_size.py"""
import html
import os

import trellis

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
P = lambda *a: os.path.join(ROOT, *a)
toolpaths = {
    "gippo penrose": trellis.plan("gippo", trellis.lattice2d(pattern="penrose", cell=1.2, size=(10, 10)).lattice,
                                  iterations=100, seed=1).toolpath,
    "aero octet 3x3x3": trellis.plan("aero", trellis.lattice3d(cell_type="octet", cell=7, count=(3, 3, 3)).lattice).toolpath,
    "fgm plate 16 colours": trellis.slice(P("examples", "designs", "fgm_palette_plate.vcad"), strategy=1, colors=16,
                                          machine=P("profiles", "geeetech_mizar_m_mixing.toml")).toolpath,
    "non-planar M": trellis.nonplanar(trellis.surface("m-curve", "/tmp/trellis_m.stl").files[0], layers=9,
                                      layer_tools="3:0,3:1,3:0", angles=[0],
                                      machine=P("profiles", "fresh_nonplanar_2syringe.toml")).toolpath,
    "pbf gyroid": trellis.pbf(strategy="hybrid", cell_type="gyroid", cell=2.5, size=(5, 5, 1)).toolpath,
}
script = len(trellis._trellis.viewer_notebook_script().encode())
before = now = 0
print(f"{'toolpath':22s} {'points':>8s} {'before':>10s} {'now':>10s}")
for name, tp in toolpaths.items():
    b = len(html.escape(tp.view_html(), quote=True).encode()) + 120
    n = len(tp.view_notebook().encode())
    before, now = before + b, now + n
    print(f"{name:22s} {tp.point_count:8d} {b:10d} {n:10d}")
print(f"{'five views':22s} {'':8s} {before:10d} {now + script:10d}  (viewer script {script} once)")
