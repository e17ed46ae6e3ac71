"""AERO paper (Weeks et al., embedded 3D printing of lattices with Automated Eulerian Route
Optimization): Fig. 1b, Fig. S6, the BCC Print Paths 1 and 2 (Fig. 3b-d), the Stanford bunny
(Fig. 4b) and the two-nozzle octet (Fig. 4a), each value printed beside the paper's; pictures into
--out.

    python3 examples/papers/aero/reproduce.py [--out DIR] [--quick] [--only fig1b,figS6,bcc,bunny,octet2]

One command per table and figure:
    reproduce.py --only fig1b    Fig. 1b: the octet unit cell (14 vertices, 36 struts, 3 groups)
                                 printed in the paper's 8 steps (AERO's groups method, --method
                                 groups) against 18 semi-manual; one picture per step
    reproduce.py --only figS6    Fig. S6: the 3 x 3 x 3 octet (the AERO repository's own graph),
                                 AERO paths and travel motions, the longest path (paper: 35 edges)
    reproduce.py --only bcc      Fig. 3b-d: the 5 x 5 x 5 BCC lattice of Print Paths 1 and 2
    reproduce.py --only bunny    Fig. 4b: the Stanford bunny lattice (351 vertices, 1,091 edges)
    reproduce.py --only octet2   Fig. 4a: the two-material octet (rigid XY struts, flexible others)
                                 with two nozzles: G-code, nozzle changes, checked collisions

Every run is the paper's own size (these take well under a second each), so --quick changes
nothing here. The semi-manual periodic baseline (a hand-made unit-cell path repeated per cell) is
`--method periodic`: the paper gives its counts and describes the BCC Print Paths, not the paths,
so the cell paths are ours, written to those descriptions (plan/periodic.hpp).
"""
import glob
import json
import os
import re
import shutil
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import paperlib  # noqa: E402
from paperlib import row, run, path  # noqa: E402

FIGURES = ("fig1b", "figS6", "bcc", "bunny", "octet2")
OUR_PATH = ("the paper does not publish its hand-made paths: ours (--method periodic) are written "
            "to its description, a cell path repeated per cell, bottom-up")


def aero(out, lattice, tag, *extra):
    """`trellis plan aero`; returns its report."""
    rep = os.path.join(out, f"{tag}.report.json")
    run("plan", "aero", lattice, "-o", os.path.join(out, f"{tag}.toolpath.json"), "--report", rep,
        *extra)
    with open(rep) as f:
        return json.load(f)


def fig1b(out, quick):
    rows = []
    lattice = os.path.join(out, "octet_1x1x1.json")
    run("lattice3d", "--cell-type", "octet", "--cell", 7, "--count", "1,1,1", "-o", lattice)
    g = aero(out, lattice, "fig1b_groups", "--method", "groups", "--frames", 8,
             "--preview", os.path.join(out, "fig1b"))
    d = aero(out, lattice, "fig1b_dynamic")
    m = aero(out, lattice, "fig1b_periodic", "--method", "periodic")
    for k, f in enumerate(sorted(glob.glob(os.path.join(out, "fig1b", "step_*.png"))), 1):
        shutil.copy(f, os.path.join(out, f"fig1b_step_{k}.png"))
    item = "Fig. 1b, octet unit cell"
    rows.append(row(item, "vertices", 14, g["nodes"]))
    rows.append(row(item, "struts (edges)", 36, g["struts"]))
    rows.append(row(item, "collision groups", 3, g["groups"]))
    rows.append(row(item, "steps (trails), AERO", 8, g["trails"], "",
                    "the paper's groups method (--method groups): a trail per group's Fleury run"))
    rows.append(row(item, "steps (trails), Trellis default", 8, d["trails"], "",
                    f"--method dynamic (refreshes the groups after every trail) reaches the "
                    f"lower bound {d['lower_bound_trails']} (odd vertices / 2), collisions "
                    f"{d['collisions']}"))
    rows.append(row(item, "steps, semi-manual", 18, m["trails"], "",
                    f"{OUR_PATH}: two struts a step in three tiers (bottom diagonals, lower V's "
                    f"and side arches; the octahedron's middle; side V's, top arches and "
                    f"diagonals), collisions {m['collisions']}"))
    rows.append(row(item, "collisions (checked)", 0, g["collisions"]))
    return rows


def figS6(out, quick):
    rows = []
    lattice = path("tests", "data", "aero", "octet_3x3x3_vertices.csv")
    g = aero(out, lattice, "figS6_groups", "--method", "groups", "--preview",
             os.path.join(out, "figS6_groups"))
    d = aero(out, lattice, "figS6_dynamic", "--preview", os.path.join(out, "figS6_dynamic"))
    m = aero(out, lattice, "figS6_periodic", "--method", "periodic", "--periodic-cell", "octet",
             "--periodic-size", 7, "--preview", os.path.join(out, "figS6_periodic"))
    for tag in ("groups", "dynamic", "periodic"):
        shutil.copy(os.path.join(out, f"figS6_{tag}", "3d.png"),
                    os.path.join(out, f"figS6_{tag}_3d.png"))
    item = "Fig. S6, octet 3 x 3 x 3"
    rows.append(row(item, "struts", None, g["struts"], "",
                    "the AERO repository's octet_3x3x3 graph (172 vertices); the paper gives no count"))
    rows.append(row(item, "longest path, AERO (edges)", 35, g["max_trail_edges"], "",
                    "the paper's groups method; Trellis's Fleury runs chain further across cells "
                    "than the AERO program's (paper: paths of up to 35 edges)"))
    rows.append(row(item, "longest path, Trellis default (edges)", 35, d["max_trail_edges"], "",
                    "--method dynamic"))
    rows.append(row(item, "paths / travel motions, AERO", None,
                    f"{g['trails']} / {g['travel_moves']}", "",
                    "Fig. S6 plots them, no values in the text"))
    rows.append(row(item, "paths / travel motions, Trellis default", None,
                    f"{d['trails']} / {d['travel_moves']}", "",
                    f"lower bound {d['lower_bound_trails']} paths; collisions {d['collisions']}"))
    rows.append(row(item, "paths / travel motions, semi-manual", None,
                    f"{m['trails']} / {m['travel_moves']}", "",
                    f"{OUR_PATH}; the paper: more travel motions than AERO "
                    f"({m['travel_moves'] / max(1, g['travel_moves']):.1f} x AERO's here), "
                    f"collisions {m['collisions']}"))
    rows.append(row(item, "longest path, semi-manual (edges)", None, m["max_trail_edges"], "",
                    "the paper: AERO's paths are much longer than the semi-manual ones"))
    return rows


def bcc(out, quick):
    rows = []
    lattice = os.path.join(out, "bcc_5x5x5.json")
    run("lattice3d", "--cell-type", "bcc", "--cell", 7, "--count", "5,5,5", "-o", lattice)
    d = aero(out, lattice, "bcc_dynamic", "--preview", os.path.join(out, "bcc"))
    shutil.copy(os.path.join(out, "bcc", "3d.png"), os.path.join(out, "bcc_3d.png"))
    item = "Fig. 3b, BCC 5 x 5 x 5"
    how = {1: "nodes side by side: per diagonal plane an arch zigzag, then a V zigzag above it",
           2: "nodes from crossing traces: two straight zigzags per diagonal plane crossing at "
              "every centre; the second passes under the first's upper strut, which the nozzle "
              "model counts (the paper prints in a yield-stress bath)"}
    for k in (1, 2):
        p = aero(out, lattice, f"bcc_path{k}", "--method", "periodic", "--periodic-cell", "bcc",
                 "--periodic-size", 7, "--print-path", k,
                 "--preview", os.path.join(out, f"bcc_path{k}"))
        shutil.copy(os.path.join(out, f"bcc_path{k}", "3d.png"),
                    os.path.join(out, f"fig3b_print_path_{k}_3d.png"))
        rows.append(row(item, f"Print Path {k}: trails / collisions", None,
                        f"{p['trails']} / {p['collisions']}", "",
                        f"{OUR_PATH}; {how[k]}; the paper gives no count"))
    rows.append(row(item, "struts / trails / collisions, AERO (Trellis)", None,
                    f"{d['struts']} / {d['trails']} / {d['collisions']}", "",
                    f"the paper prints BCC with the semi-manual paths only; lower bound "
                    f"{d['lower_bound_trails']} trails"))
    rows.append(row("Fig. 3d, BCC", "specific modulus E/ρ, Print Path 1", 1.02e5, None,
                    "Pa/(kg/m³)", "physical: compression tests of printed epoxy lattices"))
    rows.append(row("Fig. 3d, BCC", "specific modulus E/ρ, Print Path 2", 1.34e5, None,
                    "Pa/(kg/m³)", "physical: compression tests of printed epoxy lattices"))
    return rows


def bunny(out, quick):
    rows = []
    lattice = path("tests", "data", "aero", "stanford_bunny_vertices.csv")
    k = aero(out, lattice, "bunny_keep", "--keep-graph", "--preview", os.path.join(out, "bunny"))
    s = aero(out, lattice, "bunny_split")
    shutil.copy(os.path.join(out, "bunny", "3d.png"), os.path.join(out, "fig4b_bunny_3d.png"))
    item = "Fig. 4b, Stanford bunny"
    rows.append(row(item, "vertices", 351, k["nodes"], "", "--keep-graph: the graph as published"))
    rows.append(row(item, "edges", 1091, k["struts"], "", "--keep-graph: the graph as published"))
    rows.append(row(item, "edges, default (T-junctions split)", 1091, s["struts"], "",
                    "by default a node lying on another strut splits it (two such T-junctions)"))
    rows.append(row(item, "trails / collisions (as published)", None,
                    f"{k['trails']} / {k['collisions']}", "",
                    f"the paper draws the path, no count; lower bound {k['lower_bound_trails']} "
                    "trails; collisions are strut pairs within the nozzle radius at a node, "
                    "unavoidable in either order"))
    return rows


def octet2(out, quick):
    rows = []
    lattice = os.path.join(out, "octet_two_material.json")
    run("lattice3d", "--cell-type", "octet", "--cell", 7, "--count", "3,3,3", "--materials",
        "xy-plane", "-o", lattice)
    profile = path("profiles", "embedded_aero_two_nozzle.toml")
    nc = os.path.join(out, "octet_two_nozzle.nc")
    d = aero(out, lattice, "octet2", "--machine", profile, "--gcode", nc, "--preview",
             os.path.join(out, "octet2"))
    shutil.copy(os.path.join(out, "octet2", "3d.png"), os.path.join(out, "fig4a_octet2_3d.png"))
    with open(nc) as f:
        tools = [ln.split()[0] for ln in f if re.match(r"T\d", ln)]
    changes = sum(1 for a, b in zip(tools, tools[1:]) if a != b)
    with open(lattice) as f:
        mats = sorted({e.get("material", 0) for e in json.load(f).get("edges", [])
                       if isinstance(e, dict)})
    item = "Fig. 4a, two-material octet 3 x 3 x 3"
    rows.append(row(item, "materials (nozzles)", 2, len(set(tools)), "",
                    "rigid XY struts on one nozzle, the others on the second"
                    + (f"; lattice materials {mats}" if mats else "")))
    rows.append(row(item, "struts / trails / collisions", None,
                    f"{d['struts']} / {d['trails']} / {d['collisions']}", "",
                    f"the paper gives no count; lower bound {d['lower_bound_trails']} trails"))
    rows.append(row(item, "nozzle changes in the G-code", None, changes, "",
                    "the paper gives no count; each group's material printed before the next"))
    rows.append(row(item, "stiffness ratio 0° / 90°", "~100", None, "",
                    "physical: compression tests of the printed lattice"))
    return rows


def reproduce(out, quick, only=FIGURES):
    rows = []
    for name in FIGURES:
        if name in only:
            rows += globals()[name](out, quick)
    return rows


if __name__ == "__main__":
    paperlib.main("AERO", reproduce, FIGURES)
