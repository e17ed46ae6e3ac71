#!/usr/bin/env python3
"""No setting without an effect: every setting of every route, given on the command line, either
changes that route's output or is refused (exit 2, naming the setting).

Generated from the schema: for each route, the settings of the sections it reads (`trellis
settings ROUTE`), each given a few other values (the other choices, the number scaled and its range
ends, the boolean flipped) over a handful of small scenarios of that route. A run's outputs are
compared with the scenario's own outputs, less the job header that records every setting and the
report's run times. Verdicts per route and setting:
  changed   - some value changed the output of some scenario;
  refused   - every scenario refused it (a setting the run does not use: "does not use K in this
              run", or a limit the run exceeds, naming the setting);
  SILENT    - accepted and ignored everywhere: the failure this test exists for.
Where a refusal says "used only when K = V", the setting is given again with K = V and must then
change the output: the declared condition (Setting::when, src/settings/schema.cpp) is checked
both ways.

Usage: settings_matrix_test.py [ROUTE...]   (env TRELLIS_CLI, TRELLIS_SOURCE_DIR)
"""
import concurrent.futures as cf
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
T = os.environ.get("TRELLIS_CLI", os.path.join(ROOT, "build/release/apps/trellis/trellis"))
P = os.path.join(ROOT, "profiles") + "/"
D = os.path.join(ROOT, "examples/designs") + "/"
TINY = os.path.join(ROOT, "examples/lattices/tiny.json")
OCTET = os.path.join(ROOT, "examples/lattices/octet_3x3x2_edges.csv")

# Settings whose effect is not on the output by design, each with where that effect is tested.
EXEMPT = {
    "run.threads": "outputs are byte-identical at any thread count (tests/hostile, test_job)",
    "run.force": "acts only when an estimate is over run.max_time/max_memory (test_job budgets)",
    "run.follow_symlinks": "acts only on an output that is a symbolic link (tests/hostile)",
    "run.max_memory": "refuses only a run whose estimate exceeds it (test_job budgets)",
    "run.progress": "the command line's stderr only, never the outputs (tests/cli/progress_test.py)",
    "machine.name": "names the printer in the output's header (the job header this test leaves out)",
    "machine.bed_shape": "a limit: refuses a part outside the circle (test_cli_machine, "
                         "PartBiggerThanTheBedIsRefusedOnEveryRoute)",
}

# Settings still accepted without an effect in these scenarios, each with why (issue 46 keeps
# them open). Listed, not skipped: they are run and reported, and the test fails when one of them
# starts to change its output or to be refused, so that the list stays true.
KNOWN_GAPS = {
    "plan:speed.jerk": "corner speeds in the print-time estimate: on the plan scenarios' small "
                       "prints at 12 mm/s the change is below the estimate's 1 s resolution (it "
                       "changes the gcode route's estimate)",
    # Bound to what the part is, not to the route (issue 47 brought booleans into this test):
    "plan:placement.lift": "acts only on a toolpath reaching below Z 0; the plan scenarios' lattices "
                           "lie on the bed (it changes the nonplanar route's output here; test_cli_machine)",
    "plan:embedded.firmware_offsets": "acts only on a machine of several nozzles; the plan aero "
                                      "scenarios' embedded machine has one (test_machine_setup)",
    "plan:gcode.label_objects": "labels each part of a build plate; a plan prints one lattice, "
                                "nothing to label (test_gcode_objects)",
    "plan:lattice.keep_graph": "keeps duplicate nodes and T-junctions as given; the plan scenarios' "
                               "lattices have none (test_io, test_beam3mf)",
    "plan:aero.exact_struts": "solves obstruction cycles exactly up to this many struts; the small "
                              "lattices here have none, and no test lattice with such a cycle exists yet",
}

# Values for text and list settings (numbers, choices and booleans are generated).
TEXT = {
    "machine.name": ["matrix printer"],
    "machine.printer_model": ["MK4S"],
    "lattice2d.target_porosity": ["60"],
    "lattice.merge_tolerance": ["1", "0.5"],
    "extrusion.down_flow": ["10,0.5"],
    "pneumatic.pressure_command": ["M42 P{pressure}"],
    "pneumatic.valve_on": ["M42 P1 S1"],
    "pneumatic.valve_off": ["M42 P1 S0"],
    "embedded.tool_offsets": ["0,0;30,0"],
    "embedded.tool_pressures": ["50,60"],
    "embedded.tool_change": ["T{tool} ; matrix"],
    "embedded.raise_idle": ["G1 Z20 ; raise {tool}"],
    "gradient.template": ["MIX A{a} B{b}"],
    "gcode.start": ["G28\nM117 matrix"],
    "gcode.end": ["M84\nM117 matrix"],
    "gcode.extension": [".g"],
    "gcode.thumbnails": ["32x32", ""],
    "lattice2d.size": ["12,8"],
    "lattice2d.center": ["3,1"],
    "lattice3d.count": ["2,1,1", "1,2,1"],
    "lattice3d.box": ["10,10,12"],
    "onto.height_fn": ["0.05*x*x"],
    "onto.domain": ["-6,-6,6,6"],
    "laser.fields": ["-100,-100,100,100", "-100,-100,0,100"],
    "laser.contour_powers": ["70"],
    "laser.contour_speeds": ["700"],
    "lasers.contour_power": ["90,50"],
    "lasers.contour_speed": ["1200,700"],
    "lasers.hatch_power": ["150,90"],
    "lasers.hatch_speed": ["1500,900"],
    "lasers.spot_diameter": ["0.03,0.05"],
    "lasers.jump_speed": ["7000,3000"],
    "lasers.jump_delay": ["100,400"],
    "lasers.mark_delay": ["50,300"],
    "lasers.polygon_delay": ["20,90"],
    "lasers.laser_on_delay": ["5,20"],
    "lasers.laser_off_delay": ["5,20"],
    "lasers.skywriting": ["false,true"],
    "lasers.skywriting_time": ["100,200"],
    "pbf.core_hatch_rotation": ["10"],
    "pbf.upskin_hatch_rotation": ["10"],
    "pbf.downskin_hatch_rotation": ["10"],
    "pbf.c": ["0.3"],
    "pbf.size": ["3,3,0.4"],
    "pbf.plate_position": ["20,30"],
    "pbf.grade_to": ["schwarz_p:3"],
    "pbf.hierarchical": ["schwarz_p:1.25:0.5"],
    "nonplanar.angles": ["0,45"],
    "nonplanar.layer_tools": ["0,1"],
    "nonplanar.height_fn": ["0.1*x"],
    "nonplanar.domain": ["0,0,10,8"],
    # Files made by setup() ({w}: its folder).
    "lattice3d.mesh": ["{w}/cube.stl"],
    "layers.solid": ["{w}/cube.stl"],
    "onto.file": ["{w}/c.stl"],
    "pbf.envelope": ["{w}/envelope.vcad"],
    "pbf.solids": ["{w}/boss.vcad"],
}


def scenarios(work):
    """Small runs of each route; {d} is the run's output folder."""
    ender, mizar = P + "ender3_s1_pro_tpu.toml", P + "geeetech_mizar_m_mixing.toml"
    tiny_tp = work + "/tiny.toolpath.json"
    hs = work + "/hs.json"
    return {
        "lattice2d": [["lattice2d", "-o", "{d}/l.json"], ["run", work + "/l2d.toml", "-o", "{d}"]],
        "lattice3d": [["lattice3d", "-o", "{d}/l.json"], ["run", work + "/l3d.toml", "-o", "{d}"]],
        "plan": [
            ["plan", "euler", TINY, "-o", "{d}/t.json", "--report", "{d}/r.json"],
            ["plan", "euler", TINY, "-o", "{d}/t.json", "--machine", ender, "--gcode", "{d}/t.gcode", "--report", "{d}/r.json"],
            ["plan", "gippo", hs, "-o", "{d}/t.json", "--machine", ender, "--gcode", "{d}/t.gcode",
             "--report", "{d}/r.json", "--iterations", "20", "--preview", "{d}/p"],
            ["run", work + "/made2d.toml", "-o", "{d}"],
            ["plan", "aero", OCTET, "-o", "{d}/t.json", "--machine", P + "embedded_aero_410um.toml",
             "--gcode", "{d}/t.nc", "--report", "{d}/r.json", "--preview", "{d}/p"],
            ["run", work + "/made3d.toml", "-o", "{d}"],
            ["run", work + "/made3dm.toml", "-o", "{d}"],
        ],
        "gcode": [["gcode", tiny_tp, "--machine", P + m, "-o", "{d}/t.gcode"] for m in
                  ["ender3_s1_pro_tpu.toml", "pneumatic_pcl_27g.toml", "embedded_aero_two_nozzle.toml",
                   "geeetech_mizar_m_mixing.toml", "voron_klipper.toml", "e3d_toolchanger_rrf.toml"]] +
                 [["gcode", work + "/block.toolpath.json", "--machine", ender, "-o", "{d}/b.gcode"],
                  ["gcode", work + "/graded.toolpath.json", "--machine", mizar, "-o", "{d}/g.gcode"],
                  ["gcode", work + "/graded.toolpath.json", "--machine", P + "prusa_xl_5tools.toml", "-o", "{d}/g.gcode"]],
        "slice": [
            ["slice", work + "/block.vcad", "--machine", ender, "-o", "{d}/s.gcode", "--report", "{d}/r.json"],
            ["slice", work + "/graded.vcad", "--strategy", "2", "--machine", mizar, "-o", "{d}/s.gcode",
             "--report", "{d}/r.json"],
            ["slice", work + "/graded.vcad", "--strategy", "1", "--machine", P + "prusa_xl_5tools.toml",
             "--set", "fgm.colors=5", "-o", "{d}/s.gcode", "--report", "{d}/r.json"],
        ],
        "pbf": [["pbf", "--cell-type", "gyroid", "--cell", "2.5", "--size", "3,3,0.5", "-o", "{d}/p.cli",
                 "--report", "{d}/r.json"],
                ["pbf", "--size", "3,3,0.3", "-o", "{d}/p.cli"],
                ["pbf", D + "concave_cylinder.obj", "--layer-height", "0.2", "-o", "{d}/p.cli",
                 "--report", "{d}/r.json"]],
        "nonplanar": [["nonplanar", work + "/c.stl", "--machine", P + "fresh_nonplanar_2syringe.toml",
                       "-o", "{d}/c.gcode", "--report", "{d}/r.json"]],
        "surface": [["surface", "corrugation", "-o", "{d}/c.stl"]],
    }


def setup(work):
    open(work + "/made2d.toml", "w").write(MADE2D)
    open(work + "/l2d.toml", "w").write('[job]\nroute = "lattice2d"\nname = "l"\n[output]\nimage_size = 120\n')
    open(work + "/l3d.toml", "w").write('[job]\nroute = "lattice3d"\nname = "l"\n[output]\nimage_size = 120\n')
    open(work + "/made3d.toml", "w").write(MADE3D)
    # The same job with its machine: G-code written, so output.gcode acts.
    open(work + "/made3dm.toml", "w").write(MADE3D.replace('name = "made3d"\n', 'name = "made3dm"\nmachine = "'
                                                            + P + 'embedded_aero_410um.toml"\n'))
    run_ok([T, "plan", "euler", TINY, "-o", work + "/tiny.toolpath.json"])
    run_ok([T, "surface", "corrugation", "-o", work + "/c.stl"])
    open(work + "/block.vcad", "w").write(BLOCK)
    open(work + "/envelope.vcad", "w").write("cylinder(1.4, 0.4);\n")
    open(work + "/boss.vcad", "w").write("translate(1, 1, 0) { rectprism(0.6, 0.6, 0.4); }\n")
    write_cube(work + "/cube.stl", 12)
    open(work + "/graded.vcad", "w").write(GRADED)
    run_ok([T, "slice", work + "/block.vcad", "--machine", P + "ender3_s1_pro_tpu.toml", "-o",
            work + "/block.gcode", "--toolpath", work + "/block.toolpath.json"])
    run_ok([T, "slice", work + "/graded.vcad", "--strategy", "2", "--machine", P + "geeetech_mizar_m_mixing.toml",
            "-o", work + "/graded.gcode", "--toolpath", work + "/graded.toolpath.json"])
    run_ok([T, "lattice2d", "--pattern", "honeycomb", "--cell", "2", "--set", "lattice2d.size=8,8",
            "-o", work + "/hs.json"])


# A small block with a hole (walls, skins, infill, travel inside and out) and a small two-material
# plate graded along X, so that every slicing and writing setting has something to act on.
BLOCK = """difference() {
  rectprism(14, 10, 1.6);
  cylinder(2, 10);
}
"""
GRADED = """fgrade(["0.5 + x/14", "0.5 - x/14"], ["a", "b"]) {
  rectprism(14, 8, 0.8);
}
"""
MADE2D = """[job]
route = "plan"
name = "made2d"
[plan]
planner = "gippo"
[gippo]
iterations = 10
[lattice2d]
size = [6.0, 6.0]
[output]
image_size = 120
"""
MADE3D = """[job]
route = "plan"
name = "made3d"
[plan]
planner = "aero"
[lattice3d]
count = [2, 1, 1]
[output]
image_size = 120
"""


def write_cube(path, side):
    """An ASCII STL cube, side mm, centred on the origin in XY, from Z 0."""
    h = side / 2
    v = [(x, y, z) for z in (0, side) for y in (-h, h) for x in (-h, h)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    out = ["solid cube"]
    for a, b, c, d in quads:
        for tri in ((a, b, c), (a, c, d)):
            out.append("facet normal 0 0 0\nouter loop")
            out += ["vertex %g %g %g" % v[i] for i in tri]
            out.append("endloop\nendfacet")
    open(path, "w").write("\n".join(out + ["endsolid cube"]) + "\n")


def run_ok(argv):
    r = subprocess.run(argv, capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"setup failed: {' '.join(argv)}\n{r.stderr}")


def route_settings():
    """Every setting with its type, default, range and flag, from `trellis settings --markdown`."""
    out = subprocess.run([T, "settings", "--markdown"], capture_output=True, text=True, check=True).stdout
    table = {}
    for line in out.splitlines():
        # A kind is one or more words: "number", "true/false", "list of numbers", "list of
        # true/false" (a switch per laser).
        m = re.match(r"\| `([a-z0-9_]+\.[a-z0-9_]+)` \| ([a-z/ ]+?) \| [^|]* \| `([^`]*)` \| ([^|]*) \| ([^|]*) \|", line)
        if m:
            flag = re.search(r"`--([a-z0-9-]+)`", m.group(5))
            kind = {"true/false": "bool", "list of numbers": "list", "list of true/false": "list"}.get(
                m.group(2), m.group(2))
            table[m.group(1)] = {"kind": kind, "default": m.group(3), "range": m.group(4).strip(),
                                 "flag": "--" + flag.group(1) if flag else None}
    return table


def sections_of(route):
    out = subprocess.run([T, "settings", route], capture_output=True, text=True, check=True).stdout
    return {m.group(1) for m in re.finditer(r"^\[([a-z0-9]+)\]", out, re.M)}


def alternatives(key, s):
    """Other values for a setting: the other choices, the flipped boolean, a number scaled and its
    range's ends."""
    if key in TEXT:
        return TEXT[key]
    kind, default, rng = s["kind"], s["default"], s["range"]
    # Every choice and both booleans: a profile may hold a value other than the default.
    if kind == "bool":
        return ["false", "true"] if default == "true" else ["true", "false"]
    if kind == "choice":
        choices = rng[len("one of "):].split(", ")
        return [c for c in choices if c != default and c != '""'] + [c for c in choices if c == default]
    if kind not in ("number", "integer"):
        return None
    nums = re.findall(r"-?[0-9]+(?:\.[0-9]+)?(?:e[+-]?[0-9]+)?", rng)
    positive = rng.startswith("> ")
    if rng.startswith("none (= 0) or"):
        nums = nums[1:]
    lo, hi = (float(nums[0]), float(nums[1])) if len(nums) >= 2 else (-1e300, 1e300)
    integer = kind == "integer"
    try:
        d = float(default)
    except ValueError:
        d = None  # derived from another setting
    cands = []
    if d is None or d == 0:
        cands += [1, 3, 0.3]
    else:
        cands += [d + 1, d - 1] if integer else [d * 1.5, d * 0.6]
    cands += [lo + (1e-6 * min(1.0, hi - lo) if positive else 0), hi]
    out = []
    for c in cands:
        if c < lo or c > hi or (positive and c <= lo) or (d is not None and c == d):
            continue
        t = str(int(round(c))) if integer else f"{c:.6g}"
        if t not in out and (d is None or t != default):
            out.append(t)
    # The default last, as a probe: a profile may hold another value (ignored when silent).
    return out[:4] + ([default] if default else [])


# The run's own timings and memory are not output.
DROP = {"job", "command", "generator", "input", "seconds", "time_s", "peak_memory_mb"}


def clean(o):
    if isinstance(o, dict):
        return {k: clean(v) for k, v in o.items()
                if k not in DROP and not k.endswith("_seconds") and "elapsed" not in k}
    if isinstance(o, list):
        return [clean(v) for v in o]
    return o


HEADER = ("; job:", "; setting ", "; generated by", "$$JOB", "// job:", "// setting ")


def signature(d):
    s = {}
    for root, _, files in os.walk(d):
        for f in sorted(files):
            p = os.path.join(root, f)
            rel = os.path.relpath(p, d)
            b = open(p, "rb").read()
            if f.endswith(".json"):
                try:
                    s[rel] = json.dumps(clean(json.loads(b)), sort_keys=True)
                    continue
                except ValueError:
                    pass
            try:
                t = b.decode()
                t = "\n".join(l for l in t.split("\n") if not l.startswith(HEADER))
                b = t.encode()
            except UnicodeDecodeError:
                pass
            s[rel] = hashlib.sha1(b).hexdigest()
    return s


def run(argv, extra, work):
    d = tempfile.mkdtemp(dir=work)
    try:
        r = subprocess.run([T] + [a.replace("{d}", d) for a in argv] + extra, capture_output=True,
                           text=True, timeout=120)
        if r.returncode:
            return r.returncode, r.stderr, None
        sig = signature(d)
        # What the run says it made (the summary: pore area, counts) is output too.
        sig["stdout"] = re.sub(r"[0-9.]+ s\b", "", r.stdout.replace(d, "{d}"))
        return 0, r.stderr, sig
    finally:
        shutil.rmtree(d, ignore_errors=True)


def fixes(argv, key, flag):
    """Whether the scenario gives `key` itself (its flag or --set), so another value would clash."""
    return (flag is not None and flag in argv) or any(a.startswith(key + "=") for a in argv)


def names(msg, key):
    """Whether a refusal names the setting ("machine.bed_x/bed_y/bed_z" names machine.bed_z)."""
    section, name = key.split(".", 1)
    return key in msg or re.search(rf"\b{section}\.[a-z_/]*\b{name}\b", msg) is not None


def try_setting(key, alts, scen, bases, work, cond_sets=(), flag=None, default=None):
    """Outcomes of giving `key` each alternative over the scenarios: (verdict, detail)."""
    seen = []
    for i, argv in enumerate(scen):
        base = bases[i]
        if base is None or fixes(argv, key, flag):
            continue
        extra0 = []
        for k, v in cond_sets:
            extra0 += ["--set", f"{k}={v}"]
        if extra0:
            code, err, base = run(argv, extra0, work)
            if code:
                seen.append(("refused", f"condition {extra0}: {last_line(err)}"))
                continue
        for a in alts:
            code, err, sig = run(argv, extra0 + ["--set", f"{key}={a}"], work)
            if code == 0:
                if sig != base:
                    return "changed", f"{' '.join(argv[:2])} {key}={a}"
                if a != default:  # the default given again changes nothing, as it should
                    seen.append(("silent", f"{' '.join(argv[:2])} {key}={a}"))
            elif code == 2:
                msg = last_line(err)
                kind = "unused" if "does not use" in msg else "refused"
                seen.append((kind, msg))
            else:
                seen.append(("crash", f"exit {code}: {' '.join(argv[:2])} {key}={a}: {last_line(err)}"))
    if any(k == "crash" for k, _ in seen):
        return "CRASH", next(m for k, m in seen if k == "crash")
    # A limit (bed size, budget, range of a design) shows its effect by refusing a value beyond it.
    limit = [m for k, m in seen if k == "refused" and names(m, key)]
    if limit:
        return "limit", limit[0]
    if any(k == "silent" for k, _ in seen):
        # What the other values did, so that a rare verdict can be read from the log.
        other = "; ".join(f"{k}: {m}" for k, m in seen if k != "silent")
        return "SILENT", next(m for k, m in seen if k == "silent") + (f" (also {other})" if other else "")
    if not seen:
        return "none", "no scenario"
    unused = [m for k, m in seen if k == "unused"]
    return ("unused", unused[0]) if unused else ("refused", seen[0][1])


def last_line(err):
    lines = [l for l in err.strip().split("\n") if l.startswith("trellis: error")] or err.strip().split("\n")
    return lines[-1][:300] if lines else ""


def condition_of(msg):
    """`used only when K = V1 or V2` -> [(K, V1)], if K is a setting that can be given."""
    m = re.search(r"used only when ([a-z0-9_]+\.[a-z0-9_]+) = ([^ ;()]+)", msg)
    if m:
        return [(m.group(1), m.group(2))]
    m = re.search(r"used only when ([a-z0-9_]+\.[a-z0-9_]+) > ([0-9.]+)", msg)
    if m:
        return [(m.group(1), str(int(float(m.group(2))) + 1))]
    return None


# List-valued settings typed as text (flow steps, layer tools), each with values malformed in its
# own syntax; laser.fields also with a field that is not four numbers. (embedded.tool_offsets and
# tool_pressures act only on a toolpath of several tools, which no scenario here has.)
MALFORMED_TEXT = {
    "extrusion.down_flow": ["10", "10,x", "10,-1", "nan,0.5"],
    "nonplanar.layer_tools": ["3:0,x", "0,-1", "1.5", "3:"],
    "laser.fields": ["0,0,10"],
}


def malformed_lists(key, s):
    """Values a list setting must refuse, from its range ("3 whole numbers, each 1 .. 1000",
    "1 number, -360 .. 360 deg"):
    [(form, value)] with form "set" (command-line text) or "toml" (a job file's array)."""
    out = [("set", v) for v in MALFORMED_TEXT.get(key, [])]
    if s["kind"] != "list":
        return out  # text, checked where it is used: the scenario's command line
    m = re.match(r"(?:(\d+) )?(whole )?numbers?, (?:each )?(.+?)(?: [a-z]+)?$", s["range"])
    if not m:
        return out + [("set", "x")]
    n = int(m.group(1)) if m.group(1) else 4
    whole, bounds = m.group(2) is not None, m.group(3)
    nums = [float(x) for x in re.findall(r"-?[0-9]+(?:\.[0-9]+)?(?:e[+-]?[0-9]+)?", bounds)]
    lo, hi = nums[0], nums[-1]
    positive = bounds.startswith("> ")
    below = ["0", "-1"] if positive else [repr(lo - max(1.0, abs(lo)))]

    def with_last(v):
        return ["1"] * (n - 1) + [v]

    lists = [with_last(repr(hi * 10 + 1))] + [with_last(v) for v in below]
    lists += [with_last("x"), with_last("nan"), with_last("inf")]
    if whole:
        lists.append(with_last("1.5"))
    if m.group(1):  # a fixed count: one short and one long
        lists += [["1"] * (n - 1), ["1"] * (n + 1)]
    for l in lists:
        out.append(("set", ",".join(l)))
        toml = [('"x"' if v == "x" else v) for v in l]
        out.append(("toml", "[" + ", ".join(toml) + "]"))
    out.append(("set", ",".join(["1"] * (n - 1) + [""])))  # an empty element
    out.append(("toml", "[" + ", ".join(["[1]"] * n) + "]"))  # nested arrays
    return out


def job_for(route, work):
    """The head of a job file of `route` that runs without other files."""
    head = f'[job]\nroute = "{route}"\nname = "m"\n'
    if route == "nonplanar":
        head += f'input = "{work}/c.stl"\nmachine = "{P}fresh_nonplanar_2syringe.toml"\n'
    if route == "slice":
        head += f'input = "{work}/block.vcad"\nmachine = "{P}ender3_s1_pro_tpu.toml"\n'
    return head


# Lists used only under a condition no scenario meets: a run that uses them, and a value it takes.
USE_WITH = {
    "lattice3d.box": (["lattice3d", "-o", "{d}/l.json", "--set", "lattice3d.kind=foam"], "10,10,12"),
    "onto.domain": (["plan", "euler", TINY, "-o", "{d}/t.json", "--set", "onto.kind=function", "--set",
                     "onto.height_fn=0.05*x*x"], "-1,-1,12,12"),
    "nonplanar.domain": (["nonplanar", "--machine", P + "fresh_nonplanar_2syringe.toml", "-o", "{d}/x.nc",
                          "--set", "nonplanar.height_fn=0.1*x"], "0,0,10,8"),
    "pbf.plate_position": (["pbf", "--size", "3,3,0.3", "-o", "{d}/p.cli", "--set", "pbf.hatch_phase=origin"],
                           "20,30"),
    # Each laser's own values act on a machine of several lasers.
    **{key: (["pbf", "--size", "3,3,0.3", "-o", "{d}/p.cli", "--set", "laser.lasers=2"], value[0])
       for key, value in TEXT.items() if key.startswith("lasers.")},
    # A kind's own rotation acts where a solid part has that kind (its thickness > 0).
    **{f"pbf.{kind}_hatch_rotation": (["pbf", D + "concave_cylinder.obj", "--layer-height", "0.2",
                                       "-o", "{d}/p.cli", "--set", f"pbf.{thickness}=0.4"], "10")
       for kind, thickness in (("core", "skin_thickness"), ("upskin", "upskin_thickness"),
                               ("downskin", "downskin_thickness"))},
}


def using_scenario(key, routes, scen_all, work):
    """The first scenario that runs with the setting's first sample value (so the setting is used
    there and a malformed value meets its parser, not "does not use"): (route, argv)."""
    if key in USE_WITH:
        argv, sample = USE_WITH[key]
        ok = run(argv, ["--set", f"{key}={sample}"], work)[0] == 0
        return (argv[0], argv) if ok else (None, None)
    if key not in TEXT:
        return None, None
    for route in routes:
        for argv in scen_all[route]:
            if fixes(argv, key, None):
                continue
            if run(argv, ["--set", f"{key}={TEXT[key][0].replace('{w}', work)}"], work)[0] == 0:
                return route, argv
    return None, None


def check_malformed(key, s, route, scen, work):
    """Every malformed value of a list setting is refused (exit 2) naming the setting (or its flag),
    and not as a setting the run does not use: on the command line, by its flag and in a job file."""
    problems, tried = [], 0
    section, name = key.split(".", 1)
    for form, value in malformed_lists(key, s):
        runs = []
        if form == "set":
            runs.append(("--set", scen + ["--set", f"{key}={value}"]))
            if s["flag"]:
                runs.append((s["flag"], scen + [s["flag"], value]))
        else:
            job = os.path.join(work, f"malformed_{key}_{tried}.toml")
            open(job, "w").write(job_for(route, work) + f"[{section}]\n{name} = {value}\n")
            runs.append(("job file", ["run", job, "-o", "{d}"]))
        for how, argv in runs:
            tried += 1
            code, err, _ = run(argv, [], work)
            msg = last_line(err)
            named = names(msg, key) or (how.startswith("--") and how in msg)
            if code != 2 or not named or "does not use" in msg:
                problems.append(f"{key} = {value} ({how}): exit {code}: {msg or 'accepted'}")
    return tried, problems


def main():
    routes = sys.argv[1:] or ["lattice2d", "lattice3d", "plan", "gcode", "slice", "pbf", "nonplanar", "surface"]
    work = tempfile.mkdtemp(prefix="trellis_matrix_")
    setup(work)
    table = route_settings()
    scen_all = scenarios(work)
    failures, counts, no_values, known = [], {}, [], []
    # MATRIX_LISTS_ONLY=1: only the malformed lists below (a quick run while working on them).
    for route in ([] if os.environ.get("MATRIX_LISTS_ONLY") else routes):
        scen = scen_all[route]
        bases = []
        for argv in scen:
            code, err, sig = run(argv, [], work)
            if code:
                failures.append(f"{route}: scenario fails: {' '.join(argv)}: {last_line(err)}")
            again = run(argv, [], work)[2] if code == 0 else None
            if code == 0 and again != sig:
                failures.append(f"{route}: scenario is not reproducible: {' '.join(argv)}")
            bases.append(sig)
        secs = sections_of(route)
        keys = [k for k in table if k.split(".")[0] in secs
                and re.search(os.environ.get("MATRIX_KEYS", ""), k)]  # a filter while working

        def one(key):
            if key in EXEMPT:
                return key, "exempt", EXEMPT[key]
            alts = [a.replace("{w}", work) for a in (alternatives(key, table[key]) or [])]
            if not alts:
                return key, "no-values", ""
            flag = table[key]["flag"]
            default = table[key]["default"]
            verdict, detail = try_setting(key, alts, scen, bases, work, flag=flag, default=default)
            if verdict == "unused" and f"{key}: the " in detail:
                cond = condition_of(detail)
                if cond:
                    v2, d2 = try_setting(key, alts, scen, bases, work, cond, flag=flag, default=default)
                    if v2 not in ("changed", "refused", "unused", "limit"):
                        return key, "COND-" + v2, f"{detail} | with {cond}: {d2}"
                    if v2 == "unused" and condition_of(d2) == cond:
                        return key, "COND-STILL-UNUSED", f"with {cond}: {d2}"
            return key, verdict, detail

        with cf.ThreadPoolExecutor(max_workers=int(os.environ.get("MATRIX_JOBS", "2"))) as ex:
            results = list(ex.map(one, keys))
        for key, verdict, detail in results:
            counts[(route, verdict)] = counts.get((route, verdict), 0) + 1
            if verdict == "no-values":
                no_values.append(f"{route}:{key}")
            gap = KNOWN_GAPS.get(f"{route}:{key}")
            if gap and verdict == "SILENT":
                counts[(route, "known-gap")] = counts.get((route, "known-gap"), 0) + 1
                known.append(f"{route}:{key} ({gap})")
            elif gap:
                failures.append(f"{route}: {key}: listed in KNOWN_GAPS but now {verdict}: remove it")
            elif verdict in ("SILENT", "CRASH", "none") or verdict.startswith("COND-"):
                failures.append(f"{route}: {key}: {verdict}: {detail}")
            if os.environ.get("MATRIX_VERBOSE"):
                print(f"{route:10} {key:36} {verdict:9} {detail[:150]}", flush=True)
    # Malformed lists (issue 47): each list setting on the first route that reads it.
    lists = [k for k in table if table[k]["kind"] == "list" or k in MALFORMED_TEXT]
    sections = {r: sections_of(r) for r in routes}
    jobs = [(k, [r for r in routes if k.split(".")[0] in sections[r]]) for k in lists]
    jobs = [(k, rs) for k, rs in jobs if rs]

    def malformed(job):
        key, rs = job
        route, scen = using_scenario(key, rs, scen_all, work)
        if scen is None:
            sample = USE_WITH[key][1] if key in USE_WITH else TEXT.get(key, ["(no sample value)"])[0]
            return 0, [f"{key}: no scenario of {', '.join(rs)} accepts {sample!r} to try it"]
        return check_malformed(key, table[key], route, scen, work)

    with cf.ThreadPoolExecutor(max_workers=int(os.environ.get("MATRIX_JOBS", "2"))) as ex:
        results = list(ex.map(malformed, jobs))
    malformed_runs = sum(t for t, _ in results)
    for _, problems in results:
        failures += [f"malformed list: {p}" for p in problems]
    shutil.rmtree(work, ignore_errors=True)
    print(f"malformed lists: {malformed_runs} runs over {len(jobs)} list settings, "
          f"{sum(len(p) for _, p in results)} accepted or misnamed")
    for route in routes:
        print(route + ": " + ", ".join(f"{v} {n}" for (r, v), n in sorted(counts.items()) if r == route))
    if no_values:
        print("settings without a generated value (file paths): " + " ".join(no_values))
    for k in known:
        print("known gap: " + k)
    for f in failures:
        print("FAIL " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
