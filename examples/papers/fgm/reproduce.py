"""The FGM paper (Wade, Beck and MacCurdy, gradient-informed slicing): every table and figure
with a number or a picture we can compute, the paper's value beside ours.

    python3 examples/papers/fgm/reproduce.py --out OUT [--quick]       # all of them
    python3 examples/papers/fgm/reproduce.py --out OUT --only table3    # one of them

Tables and figures (--only NAME, comma-separated):
  table3  Table 3: the palette plate (Fig. 16) with Strategy 1 (4, 8, 12, 16 colours, and 16
          with zippering) and Strategy 2 (12, 24, 36, 48), the vase (Fig. 21, 500 layers) and
          the Benchy (Fig. 22): layers, colours, paths; the slicing times are printed, not
          tabulated (they depend on the machine)
  fig2    Fig. 2 / Appendix B: the listings of columns 1, 2, 3, 5 (and 6 without --quick) sliced
          into an 8-colour palette: how many colours each realises
  fig12   Fig. 12: a three-material palette of 9 colours and its traversal, flipped every layer
  fig14   Fig. 14 / Appendix A: the look-ahead calibration print (A.2), its mixture change
          with no look-ahead and with the paper's 960 mm; A.1's melt volume
  fig16   Figs. 16 and 17 / §4.1: purges, purge and part mass, print time of the palettes on
          the mixing hotend (16) and with foaming PLA (17)

--quick (the tests, docs/papers.md) slices the palette plate as the paper's 135 x 175 x 2 mm
box (examples/designs/fgm_palette_plate.vcad) at 4 and 16 colours with Strategy 1 only; without
it, the paper's object (the vase's cross-section, fgm_palette_vase_top.vcad) at every palette
size of both strategies, with zippering, and the vase. Pictures: OUT/<figure>/...png
(trellis slice --preview, coloured by mixture).
"""
import json
import math
import os
import re
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import paperlib  # noqa: E402
from paperlib import path, row, run  # noqa: E402

MIXING = path("profiles", "geeetech_mizar_m_mixing.toml")
FOAMING = path("profiles", "prusa_mk4s_lwpla.toml")
XL = path("profiles", "prusa_xl_5tools.toml")
MIXING3 = path("profiles", "geeetech_a20t_mixing.toml")
DESIGNS = path("examples", "designs")
UNPUBLISHED = ("depends on the purge per colour change, a calibration the paper does not "
               "publish (ours: purge.melt_volume of the profile, one purge per change)")


_DONE = {}


def slice_(out, name, design, machine, *args, preview=True):
    """Slice a design; returns (report, seconds). Pictures in OUT/name/. A slice already made
    with the same design, machine and settings is not made again."""
    key = (design, machine, tuple(map(str, args)), preview)
    if key in _DONE:
        return _DONE[key]
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    rep = os.path.join(d, "report.json")
    extra = ("--preview", d, "--preview-layers", 1, "--image-size", 600) if preview else ()
    t0 = time.perf_counter()
    run("slice", design, "--machine", machine, "-o", os.path.join(d, name + ".gcode"),
        "--report", rep, "--no-progress", *extra, *args)
    secs = time.perf_counter() - t0
    with open(rep) as f:
        _DONE[key] = json.load(f), secs
    return _DONE[key]


def table3(out, quick):
    plate = "fgm_palette_plate.vcad" if quick else "fgm_palette_vase_top.vcad"
    obj = "box" if quick else "vase section"
    design = os.path.join(DESIGNS, plate)
    s1 = (4, 16) if quick else (4, 8, 12, 16)
    s2 = () if quick else (12, 24, 36, 48)
    paper_s = {(1, 4, 0): 33, (1, 8, 0): 54, (1, 12, 0): 76, (1, 16, 0): 99, (1, 16, 1): 219,
               (2, 12, 0): 86, (2, 24, 0): 174, (2, 36, 0): 285, (2, 48, 0): 424}
    runs = [(1, c, 0) for c in s1] + ([] if quick else [(1, 16, 1)]) + [(2, c, 0) for c in s2]
    rows = []
    for strategy, colors, zipper in runs:
        args = ["--strategy", strategy, "--colors", colors, "--walls", 3, "--infill", 1]
        if strategy == 1:
            args += ["--order", "faces"]
        if zipper:
            args += ["--zipper", 0.02]
        name = f"table3_s{strategy}_{colors}" + ("_zipper" if zipper else "")
        r, secs = slice_(out, name, design, MIXING, *args)
        f = r["fgm"]
        label = f"Table 3, palette ({obj}), S{strategy}, {colors} colours" + (
            ", zippered" if zipper else "")
        print(f"  {label}: {secs:.1f} s here, {paper_s[(strategy, colors, zipper)]} s in the "
              "paper (Python, one thread, Ryzen 7 7700X): run times are not compared in rows")
        rows.append(row(label, "layers", 10, r["layers"]))
        rows.append(row(label, "colours realised", colors, f["colors_used"],
                        why="zipper β = 2 % (the paper's Table 3 gives none)" if zipper else ""))
        rows.append(row(label, "paths", None, r["paths"],
                        why="the paper gives no count"))
    if quick:
        rows.append(row(f"Table 3, palette ({obj}), S1, 16 colours, zippered", "layers", 10,
                        None, why="zippering doubles the paths: not in --quick, run without it"))
        for c in (12, 24, 36, 48):
            rows.append(row(f"Table 3, palette ({obj}), S2, {c} colours", "colours realised", c,
                            None, why="Strategy 2 at the paper's size takes minutes on a "
                                      "shared machine: not in --quick, run without it"))
        rows.append(row("Table 3, vase (Fig. 21), S1, 16 colours", "layers", 500, None,
                        why="500 layers take too long for --quick: run without it"))
    else:
        r, secs = slice_(out, "table3_vase", os.path.join(DESIGNS, "fgm_column6_vase.vcad"),
                         MIXING, "--strategy", 1, "--colors", 16, "--walls", 10, "--infill", 0)
        print(f"  Table 3, vase: {secs:.1f} s here, 1271 s in the paper")
        rows.append(row("Table 3, vase (Fig. 21), S1, 16 colours", "layers", 500, r["layers"],
                        why="10 walls, no infill (§7.4)"))
        rows.append(row("Table 3, vase (Fig. 21), S1, 16 colours", "colours realised", 16,
                        r["fgm"]["colors_used"]))
    rows += benchy(out, quick)
    return rows


def benchy(out, quick):
    """Table 3's Benchy row: Eq. 2 (alpha = 25 mm) on the Benchy's bounding box, a stand-in."""
    label = "Table 3, Eq. 2 on the 3D Benchy's 60 x 31 x 48 mm box (Fig. 22), 5 colours"
    stand_in = ("the Benchy mesh is not in the repository: Eq. 2 (α = 25 mm) fills its 60 × 31 "
                "× 48 mm box instead (examples/designs/fgm_eq2_box.vcad), Strategy 1 on the "
                "Prusa XL as the paper's text says (its Table 3 says Strategy 2)")
    if quick:
        return [row(label, "layers", 240, None,
                    why="240 layers take too long for --quick: run without it; " + stand_in)]
    r, secs = slice_(out, "table3_eq2_box", os.path.join(DESIGNS, "fgm_eq2_box.vcad"), XL,
                     "--strategy", 1, "--colors", 5, "--layer-height", 0.2)
    print(f"  {label}: {secs:.1f} s here, 754 s in the paper (the Benchy itself)")
    return [row(label, "layers", 240, r["layers"], why=stand_in),
            row(label, "colours realised", 5, r["fgm"]["colors_used"],
                why="Eq. 2's fraction spans 0..1 over the box"),
            row(label, "Benchy geometry", "3D Benchy", None,
                why="not reproduced: no Benchy mesh in the repository")]


def fig2(out, quick):
    cols = [("column 1", "fgm_column1_cylinder.vcad", "z/70 on cylinder(15, 70)"),
            ("column 2", "fgm_column2_plate.vcad", "y/75 + 0.5 on rectprism(150, 75, 2.5)"),
            ("column 3", "fgm_column3_ring_angular.vcad", "abs(phi)/pi on a ring"),
            ("column 5", "fgm_column5_ring_radial.vcad", "(rho-15)/35 on a ring")]
    if not quick:
        cols.append(("column 6", "fgm_column6_vase.vcad", "Listing 5's sine gradient on the vase"))
    rows = []
    for col, design, what in cols:
        r, _ = slice_(out, "fig2_" + col.replace(" ", ""), os.path.join(DESIGNS, design), MIXING,
                      "--strategy", 1, "--colors", 8)
        used = r["fgm"]["colors_used"]
        why = what
        if col == "column 1":
            why = ("our cylinder is centred, as rectprism is (Listing 2's y/75 + 0.5 needs "
                   "that): z runs -35..35, z/70 from -0.5 to 0.5, clamped to 0..0.5; the paper "
                   "does not say where its cylinder stands")
        else:
            why += "; fractions span 0..1, all 8 colours (the paper names no palette size)"
        rows.append(row(f"Fig. 2 {col}, Listing", "colours of 8 realised", 8, used, why=why))
    # Listing 1 with the cylinder standing on z = 0 (z from 0 to 70): the whole gradient.
    d = os.path.join(out, "fig2_column1_base0")
    os.makedirs(d, exist_ok=True)
    v = os.path.join(d, "column1_base0.vcad")
    with open(v, "w") as f:
        f.write('// Listing 1 with the cylinder standing on z = 0 (z from 0 to 70)\n'
                'fgrade(["z/70", "1-z/70"], ["blue", "yellow"]) {\n'
                '  translate(0, 0, 35) { cylinder(15, 70) }\n}\n')
    r, _ = slice_(out, "fig2_column1_base0", v, MIXING, "--strategy", 1, "--colors", 8)
    rows.append(row("Fig. 2 column 1, cylinder on z = 0", "colours of 8 realised", 8,
                    r["fgm"]["colors_used"], why="translate(0, 0, 35) around the cylinder"))
    return rows


def fig12(out, quick):
    d = os.path.join(out, "fig12")
    os.makedirs(d, exist_ok=True)
    tp = os.path.join(d, "three_materials.json")
    r, _ = slice_(out, "fig12", os.path.join(DESIGNS, "fgm_three_materials.vcad"), MIXING3,
                  "--strategy", 1, "--colors", 9, "--order", "faces", "--toolpath", tp)
    with open(tp) as f:
        layers = json.load(f)["layers"]
    orders = []
    for layer in layers:
        seq = []
        for p in layer["paths"]:
            m = tuple(round(x, 3) for x in p["mixture"])
            if not seq or seq[-1] != m:
                seq.append(m)
        orders.append(seq)
    flips = sum(1 for a, b in zip(orders, orders[1:]) if a and b and a[-1] == b[0])
    changes = [len(s) - 1 for s in orders]
    return [
        row("Fig. 12b/c", "colours of a three-material palette", 9, r["fgm"]["colors_used"]),
        row("Fig. 12b/c", "materials", 3, r["fgm"]["materials"]),
        row("Fig. 12", "colour changes per layer (colour by colour)", 8, max(changes),
            why="nine colours printed one after another: eight changes"),
        row("Fig. 12 caption", "layers starting with the colour the layer below ended with",
            len(layers) - 1, flips, why="the traversal is flipped on odd layers"),
    ]


def change_lead(gcode, mid_x):
    """Printed path (mm) between the mixture command that switches to the second material and
    the first extrusion at x >= mid_x (the design's change)."""
    pos = [0.0, 0.0]
    lead, counting = 0.0, False
    for line in open(gcode):
        s = line.split(";")[0].strip()
        if s.startswith("M165") and "A0.25" in s:
            counting, lead = True, 0.0
            continue
        if not s.startswith(("G0 ", "G1 ")):
            continue
        new = list(pos)
        for k, val in re.findall(r"([XY])(-?[\d.]+)", s):
            new["XY".index(k)] = float(val)
        if counting and s.startswith("G1") and "E" in s:
            if new[0] >= mid_x - 1e-6:  # the part of this move up to x = mid_x
                t = (mid_x - pos[0]) / (new[0] - pos[0]) if new[0] != pos[0] else 0.0
                return round(lead + t * math.hypot(new[0] - pos[0], new[1] - pos[1]), 1)
            lead += math.hypot(new[0] - pos[0], new[1] - pos[1])
        pos = new
    return None


def fig14(out, quick):
    """Appendix A.2's calibration print: a 60 x 30 mm layer, white then blue at the middle of
    X, printed as lines along Y stepping along X (a serpentine), on the mixing hotend."""
    v = path("examples", "designs", "fgm_calibration_a2.vcad")  # examples/jobs/fgm_calibration_a2
    leads = {}
    for la in (0, 960):
        r, _ = slice_(out, f"fig14_lookahead_{la}", v, MIXING, "--strategy", 1, "--colors", 2,
                      "--walls", 0, "--top", 0, "--bottom", 0, "--infill", 1,
                      "--infill-angle", 90, "--layer-height", 0.2, "--lookahead", la)
        g = os.path.join(out, f"fig14_lookahead_{la}", f"fig14_lookahead_{la}.gcode")
        leads[la] = change_lead(g, mid_x=255 / 2)
    h, w = 0.2, 0.4
    area = h * (w - h) + math.pi * h * h / 4
    prof = open(MIXING).read()
    melt = float(re.search(r"melt_volume\s*=\s*([\d.]+)", prof).group(1))
    la_xl = float(re.search(r"lookahead\s*=\s*([\d.]+)", open(XL).read()).group(1))
    la_mix = float(re.search(r"lookahead\s*=\s*([\d.]+)", prof).group(1))
    return [
        row("Fig. 14b, A.2 step 1", "mixture change issued before the midpoint, no look-ahead",
            0, leads[0], "mm", why="printed path from the command to x = midpoint"),
        row("Fig. 14c", "… with the look-ahead of 960 mm", 960, leads[960], "mm"),
        row("Fig. 14 caption", "look-ahead, Geeetech Mizar M (our profile)", 960, la_mix, "mm"),
        row("Fig. 14 caption", "look-ahead, Prusa XL (our profile)", 450, la_xl, "mm"),
        row("Appendix A.1", "melt volume purged by 960 mm at h 0.2, w 0.4", None,
            round(960 * area, 2), "mm³",
            why=f"Eq. A.1 inverted; our profile's purge.melt_volume is {melt:g} mm³ "
                "(the paper publishes the distance, not the volume)"),
        row("Fig. 14b, A.2 step 2", "observed error distance e_x", None, None, "mm",
            why="physical (seen on the print); L = ceil(e_x / w) × L_y then follows"),
    ]


def fig16(out, quick):
    rows = []
    plate = os.path.join(DESIGNS, "fgm_palette_plate.vcad" if quick else
                         "fgm_palette_vase_top.vcad")
    sizes = (4, 16) if quick else (4, 8, 12, 16)
    mass = {}
    for c in sizes:
        r, _ = slice_(out, f"fig16a_s1_{c}", plate, MIXING, "--strategy", 1, "--colors", c,
                      "--order", "faces", "--walls", 3, "--infill", 1)
        f = r["fgm"]
        mass[c] = f
        rows.append(row(f"§4.1, Fig. 16a S1 {c} colours", "prime tower colours (purged)",
                        c, len({tuple(p["mixture"]) for p in f["part_colours"]}),
                        why=f"{f['purges']} purges over {r['layers']} layers, one per colour "
                            "change, order flipped every layer"))
    big = mass[sizes[-1]]
    rows.append(row("§4.1, Fig. 16a", "part mass without purging", 25.56,
                    round(big["part_mass_g"], 2), "g",
                    why="3 walls, 100 % infill of the " + (
                        "135 × 175 × 2 mm box (--quick)" if quick else "vase's section") +
                        " at 1.24 g/cm³; the paper weighed its print"))
    per = (big["purge_mass_g"] - mass[sizes[0]]["purge_mass_g"]) / (sizes[-1] - sizes[0])
    rows.append(row("§4.1, Fig. 16a", "purge mass per added colour", 1.9, round(per, 3), "g",
                    why=UNPUBLISHED))
    rows.append(row("§4.1, Fig. 16a, 16 colours", "purge mass", 30.4,
                    round(mass[16]["purge_mass_g"], 2), "g", why=UNPUBLISHED))
    for c in (() if quick else (12, 24, 36, 48)):
        r, _ = slice_(out, f"fig16b_s2_{c}", plate, MIXING, "--strategy", 2, "--colors", c,
                      "--walls", 3, "--infill", 1)
        rows.append(row(f"§4.1, Fig. 16b S2 {c} colours", "purges", 0, r["fgm"]["purges"]))
    # Fig. 17: the same with foaming PLA (temperature 190..225 °C, M104 + M221).
    c = sizes[0]
    name = f"fig17a_s1_{c}"
    r, _ = slice_(out, name, plate, FOAMING, "--strategy", 1, "--colors", c, "--order", "faces",
                  "--walls", 3, "--infill", 1)
    temps = [float(m) for line in open(os.path.join(out, name, name + ".gcode"))
             for m in re.findall(r"^M104 S([\d.]+)", line)]
    temps = sorted({t for t in temps[1:] if t > 0})  # not the start's preheat nor the end's 0
    rows.append(row(f"§7.1, Fig. 17a S1 {c} colours", "nozzle temperatures", None,
                    ", ".join(f"{t:g}" for t in temps), "°C",
                    why="the paper gives none per colour; 190–225 °C linearly (§7.1), each "
                        "colour at its band's centre"))
    rows.append(row("§4.1, Fig. 17a", "purge mass per added colour, foaming PLA", 0.16,
                    round(r["fgm"]["purge_mass_g"] / r["fgm"]["purges"], 3)
                    if r["fgm"]["purges"] else 0, "g",
                    why=UNPUBLISHED + ("" if r["fgm"]["purges"] else "; the MK4S profile "
                                       "sets no melt volume, so no tower")))
    rows.append(row("§4.1, Fig. 16", "print time, 16 colours, without purging", 253,
                    round(big["part_time_s"] / 60, 1), "min",
                    why="our estimate from the profile's speeds (40 mm/s)" + (
                        " on the box (--quick), not the paper's vase section" if quick else "")))
    rows.append(row("Figs. 19–20", "ΔE of the printed palettes", None, None,
                    why="physical (photographs of the prints)"))
    return rows


FIGURES = {"table3": table3, "fig2": fig2, "fig12": fig12, "fig14": fig14, "fig16": fig16}


def reproduce(out, quick, only=None):
    rows = []
    for name in (only or FIGURES):
        rows += FIGURES[name](out, quick)
    return rows


if __name__ == "__main__":
    paperlib.main("fgm", reproduce, FIGURES)
