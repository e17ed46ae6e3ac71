"""PBF paper (STL-free hybrid laser toolpaths for TPMS shell lattices): Fig. 3(b) i–ii, Fig. 4's
35 SL/LHD combinations, the hybrid path's scan time against R67 with scanner delays, and the
direct route's time and memory against the STL route's.

    python3 examples/papers/pbf/reproduce.py --out OUT [--quick]   # all of them
    python3 examples/papers/pbf/reproduce.py --only fig3b          # Fig. 3(b) i–ii: FR_a of 200 and
                                                                   # 70 µm walls over 1,000 layers
    python3 examples/papers/pbf/reproduce.py --only fig4           # Fig. 4: 35 SL/LHD combinations
    python3 examples/papers/pbf/reproduce.py --only scantime       # hybrid vs R67 with delays
    python3 examples/papers/pbf/reproduce.py --only routes         # direct vs STL route (printed)

Fig. 3(b) uses the paper's own sizes in --quick too (1,000 layers of 20 µm, hatch 40 µm, beam
compensation 30 µm). Fig. 4's lattice is the paper's (Schwarz D, 2.5 mm cells, 4 × 4 cells across)
with 5 layers in --quick and 50 (a fifth of a cell) otherwise. Pictures (PNG, matplotlib) go into
OUT: fig3b_i.png, fig3b_ii.png, fig3b_ii_angle.png, fig4.png, scantime.png.
"""
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import paperlib  # noqa: E402
from paperlib import path, row, run  # noqa: E402

PROFILE = path("profiles", "pbf_316l_25um.toml")


class NoPlots:
    """Stands in for pyplot when matplotlib is missing: every picture is skipped, said once."""

    def __getattr__(self, name):
        return self

    def __call__(self, *a, **k):
        return self

    def __iter__(self):
        return iter((self, self))


def plt():
    try:
        import matplotlib
    except ImportError:
        if not getattr(plt, "warned", False):
            print(f"warning: matplotlib is not installed for {sys.executable} "
                  "(Debian: python3-matplotlib): no pictures, rows only", file=sys.stderr)
            plt.warned = True
        return NoPlots()
    matplotlib.use("Agg")
    import matplotlib.pyplot as p
    return p


def pbf(out, name, *args):
    """trellis pbf with the paper's laser profile; returns the JSON report."""
    report = os.path.join(out, name + ".json")
    run("pbf", "--machine", PROFILE, "-o", os.path.join(out, name + ".cli"), "--report", report,
        *args)
    with open(report) as f:
        return json.load(f)


def wall_angle(hatch_deg):
    """Angle between the hatch and a wall along X, 0–90°."""
    a = hatch_deg % 180
    return min(a, 180 - a)


def fig3b(out, quick):
    """Fig. 3(b): FR_a (Eq. 8) of the hybrid path and of R67 over 1,000 layers of a 200 µm and a
    70 µm vertical wall, the R67 hatch fixed to the machine origin (as machines hatch) and, for
    comparison, to the wall's centre line."""
    rows = []
    wall = ["--size", "2,1,20"]
    thick = pbf(out, "wall200", "--wall-thickness", "0.2", "--hatch-phase", "origin", *wall)
    # The paper does not say where its wall stood on the plate: four places a quarter of the
    # hatch distance apart across the wall (its centre on a hatch line of the plate's grid, then
    # 10, 20, 30 µm off it), each fixed to the machine origin as machines hatch.
    shifts = [0, 10, 20, 30]
    thins = [pbf(out, f"wall70_{d}", "--wall-thickness", "0.07", "--hatch-phase", "origin",
                 "--plate-position", f"50,{50 + d / 1000}", *wall) for d in shifts]
    thin = thins[1]
    centred = pbf(out, "wall70_centred", "--wall-thickness", "0.07", "--hatch-phase", "wall", *wall)
    h, b = thick["fr_a"], thick["fr_a_r67_baseline"]
    why_plot = "the paper plots it without a number ('comparable, minimal variation')"
    rows += [
        row("Fig. 3(b-i), 200 µm wall, 1,000 layers", "R67 FR_a mean", None, round(b["mean"], 3),
            why=why_plot),
        row("Fig. 3(b-i), 200 µm wall, 1,000 layers", "R67 FR_a CV", None, round(100 * b["cv"], 2),
            "%", why_plot),
        row("Fig. 3(b-i), 200 µm wall, 1,000 layers", "hybrid FR_a CV", None,
            round(100 * h["cv"], 2), "%", why_plot + "; a 200 µm wall is a joint, hatched as R67"),
    ]
    hi = max(t["fr_a_r67_baseline"]["max"] for t in thins)
    lo = min(t["fr_a_r67_baseline"]["min"] for t in thins)
    hi_eq = max(t["fr_a_eq_r67_baseline"]["max"] for t in thins)
    lo_eq = min(t["fr_a_eq_r67_baseline"]["min"] for t in thins)
    c67 = centred["fr_a_r67_baseline"]
    item = "Fig. 3(b-ii), 70 µm wall, R67 (origin phase, 4 plate positions)"
    rows += [
        row(item, "highest FR_a", 103, round(100 * hi, 1), "%",
            "Eq. 8 with the plain scan length: a hatch line along the 10 µm strip the 30 µm "
            "compensation leaves gives D/t = 91 % at most"),
        row(item, "lowest FR_a", 1.7, round(100 * lo, 1), "%",
            "where the wall stood on the paper's plate is not given: ours is the lowest of four "
            "places; a parallel line that misses the strip leaves nothing"),
        row(item, "lowest FR_a above 0", 1.7,
            round(100 * min(v for t in thins for v in t["per_layer"]["fr_a_r67"] if v > 0), 1),
            "%", "a nearly parallel line that clips the strip; which layers do depends on the "
            "wall's place on the plate"),
        row(item, "highest FR_a with L̃_p", 103, round(100 * hi_eq, 1), "%",
            "L̃_p = L + πD/4 (the melt track's round ends; Supplementary Text 3 is not in our copy)"),
        row(item, "lowest FR_a with L̃_p", 1.7, round(100 * lo_eq, 1), "%",
            "L̃_p adds each vector's ends, so a short clipped vector counts more than its length"),
        row("Fig. 3(b-ii), 70 µm wall, R67 fixed to the wall's centre", "lowest FR_a", 1.7,
            round(100 * c67["min"], 1), "%",
            "a line always runs down the wall's middle when parallel: the minimum is never reached"),
        row("Fig. 3(b-ii), 70 µm wall, hybrid", "FR_a CV over 1,000 layers", None,
            round(100 * thin["fr_a"]["cv"], 2), "%",
            "the paper shows a flat curve without a number"),
    ]
    # FR_a against the angle between hatch and wall (the paper's explanation of the drop).
    per = thin["per_layer"]
    angles = [wall_angle(a) for a in per["hatch_angle_deg"]]
    near = [f for t in thins for a, f in zip(angles, t["per_layer"]["fr_a_r67"]) if a < 2]
    across = [f for t in thins for a, f in zip(angles, t["per_layer"]["fr_a_r67"]) if a >= 30]
    rows.append(row("Fig. 3(b-ii), 70 µm wall, R67 (origin phase)",
                     "FR_a spread, hatch within 2° of the wall / 30–90°", None,
                     round((max(near) - min(near)) / max(1e-9, max(across) - min(across)), 1),
                     "×", "the paper: FR_a drops as the hatch turns parallel; no number"))
    p = plt()
    for name, rep, title in (("fig3b_i", thick, "200 µm wall"), ("fig3b_ii", thin, "70 µm wall")):
        fig, ax = p.subplots(figsize=(8, 3.2))
        s = rep["per_layer"]
        ax.plot(range(1, len(s["fr_a_r67"]) + 1), [100 * v for v in s["fr_a_r67"]], lw=0.6,
                label="R67 (origin phase)" + ("" if rep is thick else ", wall 10 µm off the grid"))
        ax.plot(range(1, len(s["fr_a"]) + 1), [100 * v for v in s["fr_a"]], lw=0.8, label="hybrid")
        ax.set(xlabel="layer", ylabel="FR_a (%)", title=f"Fig. 3(b): {title}, 1,000 layers")
        ax.legend()
        fig.tight_layout()
        fig.savefig(os.path.join(out, name + ".png"), dpi=110)
        p.close(fig)
    fig, ax = p.subplots(figsize=(6, 4))
    for d, t in zip(shifts, thins):
        ax.scatter([wall_angle(a) for a in t["per_layer"]["hatch_angle_deg"]],
                   [100 * v for v in t["per_layer"]["fr_a_r67"]], s=4,
                   label=f"R67, origin phase, wall {d} µm off the grid")
    ax.scatter([wall_angle(a) for a in centred["per_layer"]["hatch_angle_deg"]],
               [100 * v for v in centred["per_layer"]["fr_a_r67"]], s=5, marker="x",
               label="R67, fixed to the wall's centre")
    ax.scatter(angles, [100 * v for v in per["fr_a"]], s=5, label="hybrid")
    ax.set(xlabel="angle between hatch and wall (°)", ylabel="FR_a (%)",
           title="70 µm wall: FR_a against hatch-to-wall angle")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig3b_ii_angle.png"), dpi=110)
    p.close(fig)
    return rows


SL = [5, 10, 20, 50, 100, 200, 400]  # µm
LHD = [0, 30, 60, 90, 120]           # µm


def fig4(out, quick):
    """Fig. 4: the D-type lattice (2.5 mm cells, 4 × 4 across) with each of 35 SL/LHD pairs. The
    paper measures printed relative density (physical); ours is the hybrid path's FR_a and its
    contour vectors, against the line-filling ratio SL/(SL + LHD) the paper explains it by."""
    rows = []
    height = 0.1 if quick else 1.0
    fr = {}
    why = ("the paper's Fig. 4(d) is printed/designed relative density, a physical result; the "
           "grid of 7 SL × 5 LHD is ours (the text gives only the ranges 5–400 and 0–120 µm)")
    for sl in SL:
        for lhd in LHD:
            r = pbf(out, f"d_{sl}_{lhd}", "--cell-type", "schwarz_d", "--cell", "2.5", "--size",
                    f"10,10,{height}", "--sl", sl / 1000, "--lhd", lhd / 1000)
            fr[sl, lhd] = r["fr_a"]["mean"]
            rows.append(row(f"Fig. 4, SL {sl} µm, LHD {lhd} µm", "hybrid FR_a (Eq. 8)", None,
                            round(r["fr_a"]["mean"], 3), why=why))
    hi = max(fr, key=fr.get)
    lo = min(fr, key=fr.get)
    drop = {sl: fr[sl, 0] - fr[sl, 120] for sl in SL}
    rows += [
        row("Fig. 4(d)", "highest (RD; ours FR_a) at SL, LHD", "5, 0", f"{hi[0]}, {hi[1]}", "µm",
            "" if hi == (5, 0) else "FR_a is the scan length's share; RD also counts the melt"),
        row("Fig. 4(d)", "lowest (RD; ours FR_a) at SL, LHD", "5, 120", f"{lo[0]}, {lo[1]}", "µm"),
        row("Fig. 4(d)", "SL with the steepest fall as LHD grows", 5, max(drop, key=drop.get), "µm",
            "the line-filling ratio SL/(SL + LHD) falls fastest for the smallest SL"),
    ]
    p = plt()
    fig, ax = p.subplots(figsize=(6.5, 4))
    for sl in SL:
        ax.plot(LHD, [fr[sl, l] for l in LHD], marker="o", label=f"SL {sl} µm")
    ax.set(xlabel="LHD (µm)", ylabel="hybrid FR_a", title="Fig. 4: D lattice, 35 SL/LHD pairs")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig4.png"), dpi=110)
    p.close(fig)
    return rows


def scantime(out, quick):
    """Scan time per layer of the hybrid path against R67 (the paper: 38.6–50 % less per layer),
    with the profile's scanner delays and without any: the paper's gyroid (2.5 mm cells, c = 0.15)
    and 1.5 mm cells (a cold plate's), with c = 0.15 and with uniform 70 µm walls; 4 × 4 cells
    across, one cell high with --quick (four otherwise)."""
    rows = []
    zero = ["--set", "timing.jump_delay=0", "--set", "timing.mark_delay=0",
            "--set", "timing.polygon_delay=0"]
    cases = [("2.5 mm cells, c 0.15", "2.5", ["--c", "0.15"]),
             ("1.5 mm cells, c 0.15", "1.5", ["--c", "0.15"]),
             ("1.5 mm cells, 70 µm walls", "1.5", ["--thickness", "0.07"])]
    saving = {}
    for label, cell, sheet in cases:
        side = 4 * float(cell)
        height = float(cell) if quick else side
        for delays in (False, True):
            name = f"gyroid_{cell}_{sheet[0][2:]}_{'delays' if delays else 'nodelay'}"
            r = pbf(out, name, "--cell", cell, *sheet, "--size", f"{side},{side},{height}",
                    *([] if delays else zero))
            s = r["scan_time_s"]
            saving[label, delays] = 100 * (1 - s["hybrid"] / s["r67_baseline"])
            why = "" if delays else "marks and jumps only"
            if delays and saving[label, delays] < 0:
                why = (f"hybrid loses to the delays: its many short contour vectors each pay a jump "
                       f"and a mark delay (without delays it saves "
                       f"{saving[label, False]:.0f} %); R67 scans little here, walls thinner than "
                       f"twice the compensation (its FR_a "
                       f"{r['fr_a_r67_baseline']['mean']:.2f})")
            rows.append(row(f"§4 (Movie S2), gyroid {label}",
                            "scan time saved by hybrid vs R67, "
                            + ("profile delays" if delays else "no delays"),
                            "38.6–50", round(saving[label, delays], 1), "%", why))
    p = plt()
    fig, ax = p.subplots(figsize=(7, 3.8))
    labels = [f"{c}\n{'delays' if d else 'no delays'}" for c, d in saving]
    ax.bar(labels, list(saving.values()))
    ax.axhspan(38.6, 50, alpha=0.2, color="green", label="paper 38.6–50 %")
    ax.axhline(0, color="k", lw=0.6)
    ax.tick_params(axis="x", labelsize=6)
    ax.set(ylabel="scan time saved vs R67 (%)", title="hybrid against R67, per the scan-time model")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "scantime.png"), dpi=110)
    p.close(fig)
    return rows


def routes(out, quick):
    """Fig. 1(f): the direct route against the STL route (marching cubes, then slicing). Time and
    memory ratios depend on the machine: printed, not rows."""
    size = "5,5,1" if quick else "10,10,10"
    res = {}
    for route in ("direct", "stl"):
        t = time.perf_counter()
        r = pbf(out, f"route_{route}", "--size", size, "--route", route, "--strategy", "r67")
        res[route] = (time.perf_counter() - t, r.get("peak_memory_mb", math.nan))
    (td, md), (ts, ms) = res["direct"], res["stl"]
    print(f"Fig. 1(f), gyroid {size} mm: direct {td:.2f} s / {md:.0f} MB, STL {ts:.2f} s / "
          f"{ms:.0f} MB: time {td / ts:.2f}×, memory {md / ms:.2f}× (paper: up to 90 % less of "
          f"both; machine-dependent, so printed, not a row)")
    return []


FIGURES = {"fig3b": fig3b, "fig4": fig4, "scantime": scantime, "routes": routes}


def reproduce(out, quick, only):
    rows = []
    for name, f in FIGURES.items():
        if name in only:
            rows += f(out, quick)
    return rows


if __name__ == "__main__":
    paperlib.main("PBF", reproduce, FIGURES)
