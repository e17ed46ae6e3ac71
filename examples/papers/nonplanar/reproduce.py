"""The non-planar embedded bioprinting paper (Albert et al., Bioprinting 2022): every figure with a
number or a picture we can compute, the paper's value beside ours.

    python3 examples/papers/nonplanar/reproduce.py --out OUT             # all figures
    python3 examples/papers/nonplanar/reproduce.py --out OUT --only fig3  # one figure

Figures (--only NAME, comma-separated):
  method  §2.1/§2.6, Fig. 1: the 45° corrugation, six cross-hatched layers of 0.4 mm paths
  fig2    §2.5, Fig. 2: the print-angle test path, and extrusion per mm by angle
  fig3    §2.4, Fig. 3: the two-material "M" curve, non-planar (B/D) and its planar control (C/E)
  fig4    §2.7, Fig. 4: corrugation amplitude 1, 0.5, 0.25, 0
  fig5    §2.7, Fig. 5: fillet diameter 0, 0.5, 1, 2 mm
  fig6    §2.7, Fig. 6: 0, 2.5, 5, 10 periods at 45°
  fig7    §2.8, Fig. 7: 0, 2, 3, 4, 6 of the six layers along the stretch
  fig8    §2.9, Fig. 8: Miura-Ori fold depths 0, 2, 4, 6 mm

Every run uses the paper's printer (profiles/fresh_nonplanar_2syringe.toml) with the paper's
constant extrusion scalar (§2.1: E = distance × one scalar), i.e. the profile's down-angle flow
factors switched off (extrusion.down_flow = ""); Fig. 2's rows show what the factors change.
The mechanical results (moduli, strength, strain, Poisson's ratio, filament widths) are
physical: their rows give the paper's finding and say that a toolpath cannot reproduce it.
Pictures: OUT/<figure>_<case>/3d.png (trellis nonplanar --preview) and the planar control's
(OUT/fig3_planar/3d.png and layer_*.png, trellis render); Fig. 2's test path is numbers only
(OUT/fig2/*.gcode). All sizes are the paper's; --quick changes nothing here.
"""
import math
import os
import re
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import paperlib  # noqa: E402
from paperlib import path, row, run  # noqa: E402

MACHINE = path("profiles", "fresh_nonplanar_2syringe.toml")
PAPER_FLOW = ("--set", "extrusion.down_flow=")  # the paper's constant extrusion scalar
PHYSICAL = "physical (measured on printed alginate); a toolpath cannot reproduce it"


def surface(out, name, kind, *args):
    stl = os.path.join(out, name + ".stl")
    run("surface", kind, "-o", stl, "--no-progress", *args)
    return stl


def nonplanar(out, name, stl, *args, flow=PAPER_FLOW):
    """Slice `stl` for the paper's printer; returns the report. Picture: OUT/name/3d.png."""
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    rep = os.path.join(d, "report.json")
    run("nonplanar", stl, "--machine", MACHINE, "-o", os.path.join(d, name + ".gcode"),
        "--report", rep, "--preview", d, "--preview-layers", 1, "--image-size", 600,
        "--no-progress", *flow, *args)
    return paperlib.json.load(open(rep))


def stl_z_range(stl):
    with open(stl, "rb") as f:
        data = f.read()
    n = struct.unpack_from("<I", data, 80)[0]
    zs = [struct.unpack_from("<f", data, 84 + 50 * i + 12 + 12 * k + 8)[0]
          for i in range(n) for k in range(3)]
    return max(zs) - min(zs)


def per_layer_paths(rep):
    return max(l["paths"] for l in rep["per_layer"])


def method(out):
    stl = surface(out, "corrugation", "corrugation")
    r = nonplanar(out, "method", stl)
    w, h = r["footprint_mm"]
    return [
        row("§2.6, corrugation", "footprint length", 44, round(w, 3), "mm"),
        row("§2.6, corrugation", "footprint width", 16, round(h, 3), "mm"),
        row("§2.1, slicing", "layers", 6, r["layers"]),
        row("§2.1, slicing", "path width", 0.4, r["path_width_mm"], "mm"),
        row("§2.1, slicing", "layer height", 0.3, r["layer_height_mm"], "mm"),
        row("§2.1, Fig. 1B", "paths per layer", 1, per_layer_paths(r),
            why="one continuous serpentine per layer"),
        row("§2.1, Fig. 1B", "travel moves within layers", 0, r["travel_moves_within_layers"]),
        row("§2.1, Fig. 1B", "lines per layer, along / across", "40 / 110",
            f"{r['per_layer'][0]['lines']} / {r['per_layer'][1]['lines']}",
            why="the paper gives no count; 16 and 44 mm at one 0.4 mm width apart"),
        row("§2.6, corrugation", "steepest descent", 45.0, round(r["max_descent_deg"], 2), "deg"),
        step_row(out),
        row("§3.1, slicer", "deviation of path points from the lifted surface", 0,
            round(r["max_deviation_mm"], 6), "mm",
            why="points on the surface lifted by k × 0.3 mm; chords within "
                f"{r['chord_tolerance_mm']} mm"),
    ]


def step_row(out):
    """§3.1: a discontinuous surface (a 3 mm step across the lines) is sliced too."""
    d = os.path.join(out, "method_step")
    os.makedirs(d, exist_ok=True)
    rep = os.path.join(d, "report.json")
    run("nonplanar", "--height-fn", "x < 0 ? 0 : 3", "--domain", "-10,-5,10,5", "--machine",
        MACHINE, "-o", os.path.join(d, "step.gcode"), "--report", rep, "--preview", d,
        "--preview-layers", 1, "--image-size", 600, "--no-progress", *PAPER_FLOW)
    r = paperlib.json.load(open(rep))
    return row("§3.1, discontinuous surface (a 3 mm step)", "travel moves per layer, most", None,
               max(l["travel_moves"] for l in r["per_layer"]),
               why="the paper: discontinuous surfaces are sliced, no count; one travel crosses "
                   f"the step ({r['surface_jumps']} jumps split the lines)")


def gcode_e_per_mm(gcode):
    """Extrusion per mm of path in the G-code, grouped by the segment's angle (deg, rounded):
    {angle: E/mm}. Positive angles rise, negative descend."""
    pos = {"X": 0.0, "Y": 0.0, "Z": 0.0, "E": 0.0}
    by = {}
    for line in open(gcode):
        line = line.split(";")[0].strip()
        if line.startswith("G92"):
            pos["E"] = 0.0
        if not line.startswith(("G0 ", "G1 ")):
            continue
        new = dict(pos)
        for k, v in re.findall(r"([XYZE])(-?[\d.]+)", line):
            new[k] = float(v)
        dx = math.hypot(new["X"] - pos["X"], new["Y"] - pos["Y"])
        dz = new["Z"] - pos["Z"]
        de = new["E"] - pos["E"]
        l = math.hypot(dx, dz)
        if de > 0 and l > 1e-6:
            a = round(math.degrees(math.atan2(dz, dx)), 1)
            s = by.setdefault(a, [0.0, 0.0])
            s[0] += de
            s[1] += l
        pos = new
    return {a: e / l for a, (e, l) in by.items()}


def fig2(out):
    d = os.path.join(out, "fig2")
    os.makedirs(d, exist_ok=True)
    tp = os.path.join(d, "angle_test.json")
    run("surface", "angle-test", "-o", tp, "--no-progress")
    paths = paperlib.json.load(open(tp))["layers"][0]["paths"]
    angles = []
    for p in paths:
        pts = p["points"]
        first = 0.0  # the first move off the horizontal is at the programmed angle
        for a, b in zip(pts, pts[1:]):
            dx, dz = math.hypot(b[0] - a[0], b[1] - a[1]), b[2] - a[2]
            if abs(dz) > 1e-9:
                first = math.degrees(math.atan2(dz, dx))
                break
        angles.append(round(first, 1))
    paper = [0, 22.5, 45, 67.5, 90, -22.5, -45, -67.5, -80]
    rows = [row("§2.5, Fig. 2", "angle lines", len(paper), len(paths)),
            row("§2.5, Fig. 2", "programmed angles", ", ".join(f"{a:g}" for a in paper),
                ", ".join(f"{a:g}" for a in angles), "deg",
                why="each line's first move off the horizontal; it then returns at the "
                    "opposite angle, cycle after cycle")]
    e = {}
    for label, flow in [("paper", PAPER_FLOW), ("profile", ())]:
        g = os.path.join(d, f"angle_test_{label}.gcode")
        run("surface", "angle-test", "-o", g, "--machine", MACHINE, "--no-progress", *flow)
        e[label] = gcode_e_per_mm(g)
    flat = {k: v[0.0] for k, v in e.items()}
    for a in (-45.0, -67.5, -80.0):
        rows.append(row(f"§2.1, Fig. 2 at {a:g}°", "extrusion per mm / horizontal", 1.0,
                        round(e["paper"][a] / flat["paper"], 3),
                        why="the paper's constant scalar (down_flow off)"))
        rows.append(row(f"§2.1, Fig. 2 at {a:g}°", "… with the shipped profile's down_flow",
                        1.0, round(e["profile"][a] / flat["profile"], 3),
                        why="the profile narrows steep downward moves (Fig. 2E: wider "
                            "filaments from 45° down); a calibration, not the paper's slicer"))
    rows.append(row("§3.2, Fig. 2E", "filament width at -45° and steeper", "> nozzle", None,
                    why=PHYSICAL))
    return rows


def gcode_counts(gcode):
    """Tool changes and travel moves (G0) between the first and last extrusion."""
    tools = travel = 0
    for line in open(gcode):
        s = line.split(";")[0].strip()
        if re.match(r"T\d+$", s):
            tools += 1
        elif s.startswith("G0 ") and ("X" in s or "Y" in s):
            travel += 1
    return tools, travel


def fig3(out):
    stl = surface(out, "m_curve", "m-curve")
    r = nonplanar(out, "fig3_nonplanar", stl, "--layers", 9, "--layer-tools", "3:0,3:1,3:0",
                  "--angles", 0)
    tools = [l["tool"] for l in r["per_layer"]]
    rows = [
        row("§2.4, Fig. 3B/D non-planar", "layers (black, clear, black)", "3 + 3 + 3",
            " + ".join(str(sum(1 for _ in g)) for g in _groups(tools))),
        row("§3.3, Fig. 3D non-planar", "extruder changes", 2, r["tool_changes"]),
        row("§3.3, Fig. 3D non-planar", "travel moves within layers", 0,
            r["travel_moves_within_layers"]),
        row("§3.3, Fig. 3D non-planar", "paths per layer", 1, per_layer_paths(r)),
    ]
    # The planar control: the same nine layers as a solid cut flat, each layer group's band in
    # its syringe (trellis nonplanar --planar-control).
    d = os.path.join(out, "fig3_planar")
    os.makedirs(d, exist_ok=True)
    g = os.path.join(d, "m_planar.gcode")
    tp = os.path.join(d, "m_planar.json")
    rep = os.path.join(d, "report.json")
    run("nonplanar", stl, "--machine", MACHINE, "-o", g, "--toolpath", tp, "--report", rep,
        "--layers", 9, "--layer-tools", "3:0,3:1,3:0", "--angles", 0, "--planar-control",
        "--preview", d, "--image-size", 600, "--no-progress", *PAPER_FLOW)
    p = paperlib.json.load(open(rep))
    layers = p["layers"]
    changes, travel = gcode_counts(g)
    changes -= 1  # the first T selects the starting syringe
    for k in (layers // 4, layers // 2):
        run("render", tp, "--layer", k, "-o", os.path.join(d, f"layer_{k:04d}.png"),
            "--colour", "tool", "--image-size", 600, "--no-progress")
    layers_with_both = p["layers_with_several_tools"]
    rows += [
        row("§2.4, Fig. 3C/E planar", "layers (flat, 0.3 mm)", None, layers,
            why="the paper's Cura slice gives no count; ours: the 2.7 mm band over the 8 mm M"),
        row("§4.2, Fig. 3E planar", "extruder changes", "every layer", changes,
            why=f"{layers_with_both} of {layers} layers need both syringes (the paper: the "
                "printer must switch to complete each layer); 2 non-planar"),
        row("§3.3, Fig. 3C planar", "travel moves", "many", travel,
            why="the paper gives no count; 0 within the non-planar layers"),
    ]
    return rows


def _groups(seq):
    out, cur = [], []
    for t in seq:
        if cur and t != cur[-1]:
            out.append(cur)
            cur = []
        cur.append(t)
    return out + [cur]


def fig4(out):
    rows, base = [], None
    for s in (1, 0.5, 0.25, 0):
        stl = surface(out, f"amplitude_{s:g}", "corrugation", "--amplitude-scale", s)
        r = nonplanar(out, f"fig4_amplitude_{s:g}", stl)
        amp = stl_z_range(stl)
        base = base or amp
        rows.append(row(f"§2.7, Fig. 4B amplitude {s:g}", "amplitude / the 45° one", s,
                        round(amp / base, 4),
                        why="" if s in (0, 1) else "peak to valley of the surface; the 0.5 mm "
                            "fillets round every amplitude by the same amount"))
        rows.append(row(f"§2.7, Fig. 4B amplitude {s:g}", "steepest descent",
                        45.0 if s == 1 else None, round(r["max_descent_deg"], 2), "deg",
                        why="" if s == 1 else "the paper gives the 45° one only; "
                            f"atan({s:g} × tan 45°) = {math.degrees(math.atan(s)):.2f}°"))
        rows.append(row(f"§2.7, Fig. 4 amplitude {s:g}", "paths / travel per layer", "1 / 0",
                        f"{per_layer_paths(r)} / {r['travel_moves_within_layers']}"))
    rows.append(row("§3.4, Fig. 4D–H", "initial modulus falls with amplitude", "yes", None,
                    why=PHYSICAL))
    return rows


def fig5(out):
    rows, lengths = [], []
    for f in (0, 0.5, 1, 2):
        stl = surface(out, f"fillet_{f:g}", "corrugation", "--fillet", f)
        r = nonplanar(out, f"fig5_fillet_{f:g}", stl)
        line = r["per_layer"][0]["length_mm"] / r["per_layer"][0]["lines"]
        lengths.append(line)
        rows.append(row(f"§2.7, Fig. 5B fillet {f:g} mm", "path length of one line along the "
                        "corrugation", None, round(line, 3), "mm",
                        why="the paper: a larger fillet shortens the sample's length (§4.3), "
                            "no number"))
    rows.append(row("§4.3, Fig. 5", "line length falls as the fillet grows", "yes",
                    "yes" if all(a > b for a, b in zip(lengths, lengths[1:])) else "no"))
    rows.append(row("§3.4, Fig. 5C–G", "larger fillet: higher initial modulus", "yes", None,
                    why=PHYSICAL))
    return rows


def fig6(out):
    rows, amps = [], []
    for p in (0, 2.5, 5, 10):
        stl = surface(out, f"periods_{p:g}", "corrugation", "--periods", p)
        r = nonplanar(out, f"fig6_periods_{p:g}", stl)
        amps.append(stl_z_range(stl))
        rows.append(row(f"§2.7, Fig. 6A {p:g} periods", "steepest descent",
                        0.0 if p == 0 else 45.0, round(r["max_descent_deg"], 2), "deg"))
        rows.append(row(f"§2.7, Fig. 6A {p:g} periods", "peak-to-valley height", None,
                        round(amps[-1], 3), "mm",
                        why="the paper: higher amplitude at lower periodicity, no number"))
    rows.append(row("§3.4, Fig. 6A", "height falls as periods grow (2.5, 5, 10)", "yes",
                    "yes" if amps[1] > amps[2] > amps[3] else "no"))
    rows.append(row("§3.4, Fig. 6B–F", "lower periodicity: lower initial modulus", "yes", None,
                    why=PHYSICAL))
    return rows


def fig7(out):
    stl = surface(out, "corrugation_fig7", "corrugation")
    rows = []
    # Layers along the stretch (0°, along the length), the rest across (90°), alternated.
    for n, angles in [(0, "90"), (2, "0,90,90"), (3, "0,90"), (4, "0,0,90"), (6, "0")]:
        r = nonplanar(out, f"fig7_{n}_along", stl, "--angles", angles)
        along = sum(1 for l in r["per_layer"] if abs(l["angle_deg"]) < 1e-9)
        rows.append(row(f"§2.8, Fig. 7A {n} of 6 along", "layers along the stretch", n, along,
                        why=f"--angles {angles}"))
    rows.append(row("§3.5, Fig. 7D–G", "more layers along: stiffer, stronger", "yes", None,
                    why=PHYSICAL))
    return rows


def fig8(out):
    rows = []
    for depth in (0, 2, 4, 6):
        stl = surface(out, f"miura_{depth}", "miura", "--depth", depth)
        r = nonplanar(out, f"fig8_miura_{depth}", stl)
        rows.append(row(f"§2.9, Fig. 8 depth {depth} mm", "fold depth", depth,
                        round(stl_z_range(stl), 3), "mm"))
        rows.append(row(f"§2.9, Fig. 8 depth {depth} mm", "paths / travel per layer", "1 / 0",
                        f"{per_layer_paths(r)} / {r['travel_moves_within_layers']}"))
    rows.append(row("§3.6, Fig. 8E", "Poisson's ratio at 4 / 6 mm depth", "≈ 0 / < 0", None,
                    why=PHYSICAL))
    return rows


FIGURES = {"method": method, "fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5,
           "fig6": fig6, "fig7": fig7, "fig8": fig8}


def reproduce(out, quick, only=None):
    rows = []
    for name in (only or FIGURES):
        rows += FIGURES[name](out)
    return rows


if __name__ == "__main__":
    paperlib.main("nonplanar", reproduce, FIGURES)
