#!/usr/bin/env python3
"""Hostile inputs (issue 24): malformed, hostile and oversized inputs to every command.

Every case is generated here (settings out of range in job files and flags, broken lattice,
design, mesh, toolpath, profile, job and G-code files, runaway requests) and run in a fresh
folder whose output folder holds a file beforehand. Each must:
  - exit 2 (never 3, never a crash or a hang: a case has 10 s),
  - print one error that names where (the file and line, the flag or the setting),
  - leave every folder exactly as it was (no output, no temporary),
and a runaway request must be refused in under 2 s with its estimate, using under 200 MB.
A second part (outputs.py) checks that no run loses a file: outputs over inputs or over each
other, /dev/null, FIFOs, symbolic links, empty paths and folders as outputs, failed jobs,
SIGINT/SIGTERM/SIGHUP during long writes and temporaries left by kill -9.

usage: hostile_test.py TRELLIS SOURCE_DIR [--list]
"""
import concurrent.futures
import json
import os
import re
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
import outputs  # noqa: E402

TRELLIS = os.path.abspath(sys.argv[1])
ROOT = os.path.abspath(sys.argv[2])
PROFILE = os.path.join(ROOT, "profiles", "ender3_s1_pro_tpu.toml")
MIXING = os.path.join(ROOT, "profiles", "geeetech_a20t_mixing.toml")
SYRINGE = os.path.join(ROOT, "profiles", "fresh_nonplanar_2syringe.toml")
AERO = os.path.join(ROOT, "tests", "data", "aero")
DESIGNS = os.path.join(ROOT, "examples", "designs")

# Sanitizer builds run several times slower: their ctest entry scales the time limits (a case's
# 10 s, a refusal's 2 s, a finishing run's 20 s) by HOSTILE_TIME_SCALE.
SCALE = float(os.environ.get("HOSTILE_TIME_SCALE", "1"))
TINY_LATTICE = b'{"nodes": [[0,0,0],[10,0,0],[10,10,0],[0,10,0]], "edges": [[0,1],[1,2],[2,3],[3,0]]}\n'
TINY_VCAD = b"root((-5,-5,0),(5,5,2),(0.1,0.1,0.1)) {\ncylinder(2,4);\n}\n"


class Case:
    def __init__(self, name, args, where, files=None, runaway=False, setup=None):
        self.name, self.args, self.where = name, args, where
        self.files = files or {}
        self.runaway = runaway
        self.setup = setup  # f(folder) before the run: symlinks and the like
        self.cls = CLASS[0]


CASES = []
CLASS = [""]  # the class of the cases being made (main), counted in the summary


def case(*a, **k):
    CASES.append(Case(*a, **k))


def settings_table():
    out = subprocess.run([TRELLIS, "settings", "--markdown"], capture_output=True, text=True, check=True).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"\| `([a-z0-9_.]+)` \| (\w[\w/]*) \| [^|]* \| [^|]* \| ([^|]*) \| ([^|]*) \|", line)
        if m:
            rows.append((m.group(1), m.group(2), m.group(3).strip(), m.group(4).strip().strip("`")))
    return rows


def route_of(section):
    if section in ("lattice2d",):
        return "lattice2d"
    if section in ("lattice3d",):
        return "lattice3d"
    if section in ("laser", "scan", "timing", "pbf"):
        return "pbf"
    if section in ("slice", "fgm"):
        return "slice"
    if section in ("nonplanar", "surface"):
        return "nonplanar"
    return "plan"


def bad_values(kind, rng):
    """Values outside the setting's range, as TOML text."""
    out = []
    m = re.match(r"> 0 and <= ([-0-9.e+]+)", rng)
    if m:
        out += ["0", "-1", repr(float(m.group(1)) * 10 + 1)]
    m = re.match(r"([-0-9.e+]+) \.\. ([-0-9.e+]+)", rng)
    if m:
        lo, hi = float(m.group(1)), float(m.group(2))
        out += [repr(lo - max(1.0, abs(lo))), repr(hi + max(1.0, abs(hi)))]
    if kind in ("number", "integer"):
        out += ["nan", "inf", '"x"']
    if kind == "integer":
        out += ["1.5"]
    if kind == "choice":
        out += ['"no-such-choice"']
    return out


def settings_cases():
    for key, kind, rng, flag in settings_table():
        section, name = key.split(".", 1)
        route = route_of(section)
        for i, v in enumerate(bad_values(kind, rng)):
            text = f'[job]\nroute = "{route}"\nname = "j"\noutput_dir = "out"\n[{section}]\n{name} = {v}\n'
            case(f"job {key} = {v}", ["run", "job.toml"], "job.toml:6", {"job.toml": text.encode()})
            if flag and i < 2 and kind in ("number", "integer"):
                cmd = {"lattice2d": ["lattice2d", "-o", "out/x.json"],
                       "lattice3d": ["lattice3d", "-o", "out/x.json"],
                       "pbf": ["pbf", "-o", "out/x.cli"],
                       "slice": ["slice", "in.vcad", "--machine", PROFILE, "-o", "out/x.gcode"],
                       "nonplanar": ["nonplanar", "--height-fn", "0.1*x", "--domain", "0,0,5,5",
                                     "--machine", SYRINGE, "-o", "out/x.nc"],
                       "plan": ["plan", "aero" if section in ("aero", "nozzle") else "gippo", "in.json",
                                "-o", "out/x.json"]}[route]
                case(f"flag {flag} {v}", cmd + [flag, v], flag,
                     {"in.vcad": TINY_VCAD, "in.json": TINY_LATTICE})


def lattice_cases():
    bad_json = {
        "truncated": b'{"nodes": [[0,0,0],[1,0,0]], "edges": [[0,',
        "nodes not list": b'{"nodes": 3, "edges": []}',
        "node short": b'{"nodes": [[0,0],[1,0,0]], "edges": [[0,1]]}',
        "node string": b'{"nodes": [["a",0,0],[1,0,0]], "edges": [[0,1]]}',
        "edge out of range": b'{"nodes": [[0,0,0],[1,0,0]], "edges": [[0,7]]}',
        "edge negative": b'{"nodes": [[0,0,0],[1,0,0]], "edges": [[0,-1]]}',
        "edge float": b'{"nodes": [[0,0,0],[1,0,0]], "edges": [[0,0.5]]}',
        "overflow": b'{"nodes": [[0,0,1e999],[1,0,0]], "edges": [[0,1]]}',
        "empty": b"",
        "not json": b"hello",
        "array": b"[1,2,3]",
        "no edges": b'{"nodes": [[0,0,0]], "edges": []}',
        "huge index": b'{"nodes": [[0,0,0],[1,0,0]], "edges": [[0,99999999999999999999]]}',
    }
    for n, body in bad_json.items():
        case(f"lattice json {n}", ["plan", "euler", "bad.json", "-o", "out/t.json"], "bad.json",
             {"bad.json": body})
    bad_csv = {
        "short row": b"0,0,0,1,0,0\n1,0,0,2,0\n",
        "long row": b"0,0,0,1,0,0\n1,0,0,2,0,0,7,8\n",
        "2d then 3d": b"0,0,1,0\n1,0,0,2,0,0\n",
        "text": b"0,0,0,1,0,0\na,b,c,d,e,f\n",
        "nan": b"0,0,0,1,0,0\nnan,0,0,2,0,0\n",
        "inf": b"0,0,0,1,0,0\ninf,0,0,2,0,0\n",
        "overflow": b"0,0,0,1,0,0\n1e999,0,0,2,0,0\n",
    }
    for n, body in bad_csv.items():
        case(f"segments csv {n}", ["plan", "euler", "bad.csv", "-o", "out/t.json"], "bad.csv:2",
             {"bad.csv": body})
    verts = open(os.path.join(AERO, "cubic_vertices.csv"), "rb").read().splitlines()
    edges = open(os.path.join(AERO, "cubic_edges.csv"), "rb").read()
    for n, row in {"two columns": b"1,2", "four columns": b"1,2,3,4", "text": b"a,b,c",
                   "nan": b"nan,0,0", "empty field": b"1,,2"}.items():
        v = b"\n".join(verts[:2] + [row] + verts[3:]) + b"\n"
        case(f"aero vertices {n}", ["plan", "aero", "x_vertices.csv", "-o", "out/t.json"],
             "x_vertices.csv:3", {"x_vertices.csv": v, "x_edges.csv": edges})
    for n, row in {"one column": b"1", "four columns": b"1,2,3,4", "out of range": b"1,100000",
                   "negative": b"-1,2", "text": b"a,b"}.items():
        e = edges.splitlines()
        body = b"\n".join(e[:1] + [row] + e[2:]) + b"\n"
        case(f"aero edges {n}", ["plan", "aero", "x_vertices.csv", "-o", "out/t.json"],
             "x_edges.csv:2", {"x_vertices.csv": b"\n".join(verts) + b"\n", "x_edges.csv": body})
    for n, body in {"bad v": b"v 0 0\nv 1 0 0\nl 1 2\n", "l out of range": b"v 0 0 0\nv 1 0 0\nl 1 9\n",
                    "v text": b"v a b c\nv 1 0 0\nl 1 2\n", "l zero": b"v 0 0 0\nv 1 0 0\nl 0 1\n"}.items():
        case(f"obj lines {n}", ["plan", "euler", "bad.obj", "-o", "out/t.json"], "bad.obj",
             {"bad.obj": body})


def design_cases():
    bad = {
        "unclosed": b"cylinder(2,4) {",
        "unknown node": b"blob(1,2);",
        "wrong args": b"cylinder(2);",
        "text arg": b"cylinder(a,4);",
        "nan fraction": b'fgrade(["sqrt(-1-x*x)","1-sqrt(-1-x*x)"],["a","b"]) { cylinder(10,5); }\n',
        "inf fraction": b'fgrade(["1/(x-x)","1"],["a","b"]) { cylinder(10,5); }\n',
        "bad expression": b'fgrade(["x+","1"],["a","b"]) { cylinder(10,5); }\n',
        "empty": b"",
        "overflow": b"cylinder(1e999,4);",
        "root short": b"root((0,0,0),(1,1,1)) { cylinder(1,1); }",
    }
    for n, body in bad.items():
        args = ["slice", "bad.vcad", "--machine", MIXING, "-o", "out/x.gcode"]
        if "fraction" in n:
            args += ["--strategy", "2"]
        case(f"vcad {n}", args, "bad.vcad", {"bad.vcad": body})
    meshes = {
        "bad.stl": b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\nendloop\nendfacet\nendsolid x\n",
        "short.stl": b"\0" * 80 + b"\x10\0\0\0" + b"\0" * 30,
        "empty.stl": b"",
        "bad.obj": b"v 0 0 0\nv 1 0 0\nf 1 2 9\n",
        "text.obj": b"v a b c\nf 1 2 3\n",
        "bad.3mf": b"garbage",
        "empty.3mf": b"PK\x05\x06" + b"\0" * 18,
    }
    for n, body in meshes.items():
        case(f"mesh {n}", ["slice", n, "--machine", PROFILE, "-o", "out/x.gcode"], n, {n: body})
        case(f"surface mesh {n}", ["nonplanar", n, "--machine", SYRINGE, "-o", "out/x.nc"], n, {n: body})
    # Broken 3MF packages: the message names the part, line and column (or the element).
    for n, (model, where) in broken_3mf_models().items():
        body = package_3mf(model)
        case(f"3mf {n}", ["slice", "bad.3mf", "--machine", PROFILE, "-o", "out/x.gcode"],
             f"bad.3mf: 3D/3dmodel.model line {where}", {"bad.3mf": body})
        case(f"beam 3mf {n}", ["plan", "euler", "bad.3mf", "-o", "out/t.json"],
             f"bad.3mf: 3D/3dmodel.model line {where}", {"bad.3mf": body})


GOOD_3MF = ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<model unit="millimeter" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"\n'
            ' xmlns:b="http://schemas.microsoft.com/3dmanufacturing/beamlattice/2017/02">\n'
            '<resources><object id="1" type="model"><mesh><vertices>\n'
            '<vertex x="0" y="0" z="0"/><vertex x="10" y="0" z="0"/><vertex x="0" y="10" z="0"/><vertex x="0" y="0" z="10"/>\n'
            '</vertices><triangles>\n'
            '<triangle v1="0" v2="2" v3="1"/><triangle v1="0" v2="1" v3="3"/><triangle v1="0" v2="3" v3="2"/><triangle v1="1" v2="2" v3="3"/>\n'
            '</triangles><b:beamlattice radius="0.5" minlength="0.1" precision="0.1" clippingmode="none"><b:beams>\n'
            '<b:beam v1="0" v2="1"/><b:beam v1="1" v2="2"/>\n'
            '</b:beams></b:beamlattice></mesh></object></resources>\n'
            '<build><item objectid="1"/></build></model>\n')


def broken_3mf_models():
    """Model parts with one problem each, and the line (and column) the message must name."""
    return {
        "malformed xml": (GOOD_3MF.replace("</vertices>", "</vertice>"), "6, column"),
        "triangle index": (GOOD_3MF.replace('v3="3"/></triangles', 'v3="7"/></triangles').replace(
            '<triangle v1="1" v2="2" v3="3"/>', '<triangle v1="1" v2="2" v3="9"/>'), "7, column"),
        "vertex text": (GOOD_3MF.replace('<vertex x="10"', '<vertex x="ten"'), "5, column"),
        "vertex missing z": (GOOD_3MF.replace('y="10" z="0"', 'y="10"'), "5, column"),
        "vertex nan": (GOOD_3MF.replace('z="10"', 'z="nan"'), "5, column"),
        "beam index": (GOOD_3MF.replace('<b:beam v1="1" v2="2"/>', '<b:beam v1="1" v2="12"/>'), "9, column"),
        "unit": (GOOD_3MF.replace('unit="millimeter"', 'unit="parsec"'), "2, column"),
        "item object": (GOOD_3MF.replace('objectid="1"', 'objectid="5"'), "11, column"),
        "truncated": (GOOD_3MF[:GOOD_3MF.index("</triangles>")], "8, column"),
    }


def package_3mf(model):
    import io
    import zipfile
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml",
                   '<?xml version="1.0" encoding="UTF-8"?>\n<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
                   '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
                   '<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>')
        z.writestr("_rels/.rels",
                   '<?xml version="1.0" encoding="UTF-8"?>\n<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
                   '<Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>'
                   '</Relationships>')
        z.writestr("3D/3dmodel.model", model)
    return buf.getvalue()


def toolpath_cases():
    good = ('{"format": "trellis.toolpath", "version": 1, "units": "mm", "layers": [{"z": 0.2, "paths": [{"points": [[0,0,0.2],[10,0,0.2]], '
            '"role": "strut", "tool": 0, "width": 0.4, "height": 0.2}]}]}')
    bad = {
        "inch": good.replace('"mm"', '"inch"'),
        "units number": good.replace('"mm"', "3"),
        "overflow": good.replace("10,0,0.2", "1e999,0,0.2"),
        "truncated": good[:40],
        "points short": good.replace("[10,0,0.2]", "[10,0]"),
        "layers not list": '{"format": "trellis.toolpath", "version": 1, "units": "mm", "layers": 4}',
        "negative width": good.replace('"width": 0.4', '"width": -1'),
        "nan text": good.replace("10,0,0.2", '"nan",0,0.2'),
    }
    for n, body in bad.items():
        case(f"toolpath {n}", ["gcode", "bad.json", "--machine", PROFILE, "-o", "out/x.gcode"], "bad.json",
             {"bad.json": body.encode()})


def profile_cases():
    base = open(PROFILE).read()
    bad = {
        "nozzle zero": re.sub(r"nozzle_diameter = [0-9.]+", "nozzle_diameter = 0", base),
        "nozzle negative": re.sub(r"nozzle_diameter = [0-9.]+", "nozzle_diameter = -0.4", base),
        "unknown key": base + "\n[speed]\nwarp = 9\n",
        "not toml": "this is [not toml",
        "nan bed": re.sub(r"bed_x = [0-9.]+", "bed_x = nan", base),
    }
    for n, body in bad.items():
        case(f"profile {n}", ["gcode", "in.json", "--machine", "bad.toml", "-o", "out/x.gcode"], "bad.toml",
             {"bad.toml": body.encode(), "in.json": b""})


def job_cases():
    def job(body):
        return {"job.toml": ('[job]\nroute = "lattice2d"\noutput_dir = "out"\n' + body).encode()}
    case("job name ..", ["run", "job.toml"], "job.name", job('name = "../escaped/x"\n'))
    case("job name /", ["run", "job.toml"], "job.name", job('name = "a/b"\n'))
    case("job output ..", ["run", "job.toml"], "job.toml:4", job('output = "../x.lattice.json"\n'))
    case("job output deep ..", ["run", "job.toml"], "job.toml:4", job('output = "a/../../x.json"\n'))
    case("job output absolute", ["run", "job.toml"], "job.toml:4", job('output = "/tmp/trellis_escape.json"\n'))
    case("job preview absolute", ["run", "job.toml"], "job.toml:4", job('preview = "/tmp/trellis_escape"\n'))

    def link_out(d):
        os.makedirs(os.path.join(d, "elsewhere"), exist_ok=True)
        os.symlink(os.path.join(d, "elsewhere"), os.path.join(d, "out", "link"))

    case("job output via symlink", ["run", "job.toml"], "output_dir", job('output = "link/x.json"\n'),
         setup=link_out)

    def link_file(d):
        os.symlink(os.path.join(d, "victim.json"), os.path.join(d, "out", "j.lattice.json"))
        open(os.path.join(d, "victim.json"), "w").write("keep")

    case("job default output is a symlink", ["run", "job.toml"], "output_dir", job('name = "j"\n'),
         setup=link_file)
    case("job route", ["run", "job.toml"], "job.route", {"job.toml": b'[job]\nroute = "nope"\n'})
    case("job no table", ["run", "job.toml"], "job.toml", {"job.toml": b"[lattice2d]\ncell = 1\n"})
    case("job unknown key", ["run", "job.toml"], "job.toml:4", job('bogus = "x"\n'))
    case("job not toml", ["run", "job.toml"], "job.toml", {"job.toml": b"[job\n"})
    case("job layer height 0", ["run", "job.toml"], "job.toml:6",
         {"job.toml": b'[job]\nroute = "plan"\nname = "x"\noutput_dir = "out"\n[extrusion]\nlayer_height = 0\n'})
    # Fails after its first outputs (lattice, toolpath, G-code) are made: the preview folder is a file.
    def blocker(d):
        open(os.path.join(d, "out", "blocker"), "w").write("a file\n")

    case("job fails after first outputs", ["run", "job.toml"], "blocker",
         {"job.toml": ('[job]\nroute = "plan"\nname = "x"\noutput_dir = "out"\nmachine = "' + PROFILE +
                       '"\npreview = "blocker"\n[lattice2d]\ncell = 5\nsize = [40, 20]\n').encode()},
         setup=blocker)


def gcode_cases():
    def unreadable(d):
        os.makedirs(os.path.join(d, "dir.gcode"))

    for cmd in (["check", "in.json", "dir.gcode"], ["analyze", "dir.gcode"], ["check", "in.json", "missing.gcode"],
                ["analyze", "missing.gcode"]):
        case(f"{cmd[0]} unreadable {cmd[-1]}", cmd, cmd[-1].split(".")[0], {"in.json": TINY_LATTICE}, setup=unreadable)
    for n, body in {"X1e308": b"G1 X1e308 Y0 E1\n", "duplicate X": b"G1 X1 X2 Y0 E1\n",
                    "bad number": b"G1 X1.2.3 Y0 E1\n", "inf": b"G1 Xinf Y0 E1\n"}.items():
        case(f"gcode strict {n}", ["analyze", "bad.gcode", "--strict"], "bad.gcode:1", {"bad.gcode": body})


def endless_input_cases():
    """Inputs that never end or never open (issue 47, second round): a device or a FIFO named as
    any command's input is refused naming it, before it is opened (`analyze /dev/zero` read
    without end, 865 MB in 15 s; a FIFO nobody writes blocked the run)."""
    def fifo(d):
        os.mkfifo(os.path.join(d, "pipe.gcode"))

    commands = {
        "analyze": lambda p: ["analyze", p],
        "analyze --design": lambda p: ["analyze", "g.gcode", "--design", p],
        "check print": lambda p: ["check", "l.json", p],
        "check lattice": lambda p: ["check", p, "g.gcode"],
        "view": lambda p: ["view", p, "-o", "out/x.html"],
        "view --machine": lambda p: ["view", "g.gcode", "--machine", p, "-o", "out/x.html"],
        "render": lambda p: ["render", p, "--layer", "0", "-o", "out/x.png"],
        "walls": lambda p: ["walls", p, "-o", "out/x.stl"],
        "plan": lambda p: ["plan", "euler", p, "-o", "out/x.json"],
        "gcode --machine": lambda p: ["gcode", "tp.json", "--machine", p, "-o", "out/x.gcode"],
        "run": lambda p: ["run", p],
    }
    files = {"l.json": TINY_LATTICE, "tp.json": None, "g.gcode": b"G21\nG90\nM83\nG1 X0 Y0 Z0.2\nG1 X10 Y0 E1\n"}
    for name, argv in commands.items():
        for source in ("/dev/zero", "/dev/urandom", "pipe.gcode"):
            case(f"endless input {name} {source}", argv(source), source, files,
                 setup=fifo if source == "pipe.gcode" else None)


def nonsense_cases():
    """Values that parse but mean nothing (issue 47): refused naming the value, nothing written."""
    mixed = ('{"format": "trellis.toolpath", "version": 1, "units": "mm", "layers": [{"z": 0.2, "paths": [{"points": '
             '[[0,0,0.2],[10,0,0.2]], "role": "strut", "tool": 0, "width": 0.4, "height": 0.2, "mixture": [%s]}]}]}')
    for n, mixture in {"negative": "-0.5, 1.5", "above 1": "0.2, 1.2", "three": "0.5, 0.7, -0.2"}.items():
        case(f"toolpath mixture {n}", ["gcode", "mix.json", "--machine", MIXING, "-o", "out/x.gcode"], "mixture",
             {"mix.json": (mixed % mixture).encode()})
    for flag, value in (("--bead-width", "1e308"), ("--bead-width", "inf"), ("--bead-width", "nan"),
                        ("--height", "1e308"), ("--height", "-inf")):
        case(f"walls {flag} {value}", ["walls", "l.json", flag, value, "-o", "out/x.stl"], flag,
             {"l.json": TINY_LATTICE})
    for value in ("nan", "inf", "1e308"):
        case(f"analyze --layer-height {value}", ["analyze", "g.gcode", "--layer-height", value], "--layer-height",
             {"g.gcode": b"G21\nG90\nM83\nG1 X0 Y0 Z0.2\nG1 X10 Y0 E1\n"})
    case("analyze --bead-width inf", ["analyze", "g.gcode", "--bead-width", "inf"], "--bead-width",
         {"g.gcode": b"G1 X10 Y0 E1\n"})
    for value in ("-1", "-5"):
        case(f"render --layer {value}", ["render", "tp.json", "--layer", value, "-o", "out/x.png"], "--layer",
             {"tp.json": None})
    case("render --bead-width nan", ["render", "tp.json", "--layer", "0", "--bead-width", "nan", "-o", "out/x.png"],
         "--bead-width", {"tp.json": None})
    # A height-field grid far beyond memory (an 8 TB allocation before) or beyond any integer.
    for value in ("1e-5", "1e-300"):
        case(f"surface --resolution {value}", ["surface", "miura", "--resolution", value, "-o", "out/x.stl"],
             "surface.resolution")


    # .vcad numbers are decimal (0x10 was read as 16); a blend radius is not negative; a TPMS
    # sheet's c must be a number (1/0 filled the box solid, sqrt(-1) sliced noise).
    for n, (body, where) in {"hex": (b"sphere(0x10);\n", "bad.vcad:1:8"),
                             "hex float": (b"sphere(0x1p3);\n", "bad.vcad:1:8"),
                             "negative blend": (b"union(-1) {\n  sphere(2);\n  cube(2);\n}\n", "bad.vcad:1:7")}.items():
        case(f"vcad {n}", ["slice", "bad.vcad", "--machine", PROFILE, "-o", "out/x.gcode"], where,
             {"bad.vcad": body})
    for c in ("1/0", "sqrt(-1)", "0*x + 1/0"):
        case(f"pbf c {c}", ["pbf", "--c", c, "--size", "3,3,3", "-o", "out/x.cli"], "pbf.c")
    case("pbf vcad sheet cell 0.001", ["pbf", "sheet.vcad", "-o", "out/x.cli"], "sheet.vcad: pbf.resolution",
         {"sheet.vcad": b'root((-5,-5,0),(5,5,2),(0.1,0.1,0.1)) {\ngyroid(0.001, 0.3);\n}\n'})
    # The same cells sliced for FDM (13,448 aliasing paths before): the field route's grid and the
    # mesh route's voxel; inside a CSG box too.
    tiny = b'root((-5,-5,0),(5,5,2),(0.1,0.1,0.1)) {\ngyroid(0.001, 0.3);\n}\n'
    boxed = b'intersection() {\n  rectprism(10, 10, 2);\n  gyroid(0.01, 0.003);\n}\n'
    case("slice vcad tpms cell 0.001", ["slice", "tiny.vcad", "--machine", PROFILE, "-o", "out/x.gcode"],
         "tiny.vcad: slice.resolution", {"tiny.vcad": tiny})
    case("slice vcad tpms cell in a box", ["slice", "tiny.vcad", "--machine", PROFILE, "-o", "out/x.gcode"],
         "tiny.vcad: slice.resolution", {"tiny.vcad": boxed})
    case("slice vcad tpms cell mesh route", ["slice", "tiny.vcad", "--route", "mesh", "--machine", PROFILE, "-o",
                                             "out/x.gcode"], "tiny.vcad: slice.mesh_voxel", {"tiny.vcad": tiny})
    case("pbf vcad sheet c sqrt(-1)", ["pbf", "sheet.vcad", "-o", "out/x.cli"], "pbf.c",
         {"sheet.vcad": b'root((-5,-5,0),(5,5,2),(0.1,0.1,0.1)) {\ngyroid(2.5, "sqrt(-1)");\n}\n'})


    # File readers: an STL facet without its loop, an OBJ face index that is not an integer, a
    # laser build file whose $$UNITS scale its coordinates beyond ±1e6 mm.
    def tetra(drop):
        """A closed tetrahedron in ASCII STL with `drop` left out of its second facet."""
        v = [(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)]
        out = ["solid t"]
        for k, (a, b, c) in enumerate([(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]):
            facet = ["facet normal 0 0 0", "outer loop"] + [f"vertex {v[i][0]} {v[i][1]} {v[i][2]}" for i in (a, b, c)]
            facet += ["endloop", "endfacet"]
            out += [x for x in facet if k != 1 or x != drop]
        return ("\n".join(out + ["endsolid t"]) + "\n").encode()
    stl = {"no endloop": tetra("endloop"), "no outer loop": tetra("outer loop")}
    for n, body in stl.items():
        case(f"mesh stl {n}", ["slice", "m.stl", "--machine", PROFILE, "-o", "out/x.gcode"], "m.stl:", {"m.stl": body})
    case("mesh obj face 1.5", ["slice", "m.obj", "--machine", PROFILE, "-o", "out/x.gcode"], "m.obj:5",
         {"m.obj": b"v 0 0 0\nv 10 0 0\nv 0 10 0\nv 0 0 10\nf 1.5 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"})
    for units in ("1e300", "1e10"):
        case(f"cli $$UNITS/{units}", ["analyze", "u.cli"], "u.cli",
             {"u.cli": f"$$HEADERSTART\n$$ASCII\n$$UNITS/{units}\n$$HEADEREND\n$$GEOMETRYSTART\n$$LAYER/1\n"
                       "$$HATCHES/1,1,0,0,10,0\n$$GEOMETRYEND\n".encode()})
    # A job's empty path is not "none": input = "" made the plan route generate a lattice.
    for key in ("input", "machine", "output", "output_dir"):
        case(f"job {key} empty", ["run", "job.toml"], "job." + key,
             {"job.toml": f'[job]\nroute = "plan"\n{key} = ""\n'.encode()})

    # A part of a plate cannot have its own machine, plate or run settings (they were ignored).
    for section, setting in (("machine", "bed_x = 1"), ("plate", "clearance = 50"), ("run", "threads = 1")):
        case(f"plate part [{section}]", ["run", "job.toml"], "job.toml:9: part." + section,
             {"job.toml": ('[job]\nroute = "slice"\noutput_dir = "out"\n'
                           f'machine = "{PROFILE}"\n[[part]]\ninput = "{DESIGNS}/csg_bracket.vcad"\n'
                           f'x = 110\ny = 110\n[part.{section}]\n{setting}\n').encode()})


def big_cell_check():
    """A TPMS cell far larger than the part (a 947 mm cell on a 3.2 mm box allocated 34 GB for
    its periodic tiles) runs within a normal part's memory."""
    with tempfile.TemporaryDirectory(prefix="hostile_cell_") as d:
        mb, rc = peak_memory_mb(["pbf", "--cell", "947", "--size", "3.2,3.2,3.2", "-o", "x.cli"], d)
        if rc != 0 or mb > 1000 or not os.path.exists(os.path.join(d, "x.cli")):
            return [f"pbf --cell 947 --size 3.2,3.2,3.2: exit {rc}, peak {mb:.0f} MB"]
    return []


def stacked_print(folder, lines, n=16):
    """Writes l.json, a planar n x n grid lattice (struts 2 mm), and g.gcode, printing it layer upon
    layer until it has `lines` lines: every strut once per layer, nothing in the nozzle's way.
    Written a layer at a time (the runs measured are forked from this process: it stays small).
    Returns the number of moves."""
    nodes = [(2 * i, 2 * j) for j in range(n + 1) for i in range(n + 1)]
    at = {p: k for k, p in enumerate(nodes)}
    edges = [(at[(x, y)], at[(x + 2, y)]) for x, y in nodes if x < 2 * n] + \
            [(at[(x, y)], at[(x, y + 2)]) for x, y in nodes if y < 2 * n]
    with open(os.path.join(folder, "l.json"), "w") as f:
        json.dump({"nodes": [[x, y, 0] for x, y in nodes], "edges": edges}, f)
    e, k = 0.0, 0
    with open(os.path.join(folder, "g.gcode"), "w") as f:
        f.write("G21\nG90\nM82\n")
        while 3 + k * (1 + 2 * len(edges)) < lines:
            z = 0.2 * (k + 1)
            layer = [f";LAYER:{k}\n"]
            for a, b in edges:
                e += 0.05
                layer.append(f"G0 X{nodes[a][0]} Y{nodes[a][1]} Z{z:.2f}\nG1 X{nodes[b][0]} Y{nodes[b][1]} "
                             f"E{e:.3f}\n")
            f.write("".join(layer))
            k += 1
    return k * len(edges)


def streamed_check():
    """`check` streams a G-code: a long print's peak memory is that of a few layers, not of the
    file (a 10^7-line G-code peaked at 1.43 GB when every segment was indexed; 10^6 lines of
    stacked layers took 7 minutes, each move visiting every layer below it)."""
    peaks = {}
    problems = []
    with tempfile.TemporaryDirectory(prefix="hostile_stream_") as d:
        for lines in (100000, 1000000):
            segments = stacked_print(d, lines)
            t0 = time.monotonic()
            try:
                r = subprocess.run([TRELLIS, "check", "l.json", "g.gcode", "--report", "r.json"], cwd=d,
                                   capture_output=True, timeout=60 * SCALE)
            except subprocess.TimeoutExpired:
                return [f"check of {lines} stacked lines: over {60 * SCALE:.0f} s"]
            secs = time.monotonic() - t0
            report = json.load(open(os.path.join(d, "r.json"))) if r.returncode == 0 else {}
            if r.returncode != 0 or report.get("segments") != segments or not report.get("ok"):
                problems.append(f"check of {lines} stacked lines: exit {r.returncode}, "
                                f"{r.stdout.decode(errors='replace')[:200]}{r.stderr.decode(errors='replace')[:300]}")
            if secs > 20 * SCALE:
                problems.append(f"check of {lines} stacked lines: {secs:.1f} s")
            peaks[lines], _ = peak_memory_mb(["check", "l.json", "g.gcode"], d)
    # Ten times the lines, about the same memory (one layer of the grid is 544 moves).
    if peaks[1000000] > 1.3 * peaks[100000] + 8:
        problems.append(f"check peak memory grows with the file: {peaks[100000]:.0f} MB at 1e5 lines, "
                        f"{peaks[1000000]:.0f} MB at 1e6")
    print(f"streamed check: peak {peaks[100000]:.0f} MB at 1e5 lines, {peaks[1000000]:.0f} MB at 1e6")
    return problems


def runaway_cases():
    def big(args, where="refused before starting", files=None):
        case("runaway " + " ".join(a for a in args if "/" not in a), args, where, files, runaway=True)

    big(["nonplanar", "--height-fn", "0.1*x", "--domain", "0,0,100,100", "--layers", "100000",
         "--machine", SYRINGE, "-o", "out/x.nc"])
    big(["lattice2d", "--cell", "1", "--size", "2000,2000", "-o", "out/x.json"])
    big(["lattice2d", "--pattern", "voronoi", "--density", "100", "--size", "2000,2000", "-o", "out/x.json"])
    big(["lattice3d", "--count", "1000,1000,1000", "-o", "out/x.json"])
    big(["slice", os.path.join(DESIGNS, "fgm_palette_plate.vcad"), "--strategy", "2", "--colors", "1000",
         "--material-resolution", "1e-6", "--machine", MIXING, "-o", "out/x.gcode"])
    big(["slice", "cube.vcad", "--walls", "100", "--resolution", "0.01", "--machine", PROFILE,
         "-o", "out/x.gcode"], files={"cube.vcad": b"root((-50,-50,0),(50,50,100),(0.1,0.1,0.1)) {\nrectprism(100,100,100);\n}\n"})
    big(["plan", "aero", "oc.json", "--tries", "100000", "-o", "out/x.json"], files={"oc.json": None})
    big(["plan", "gippo", "l.json", "--iterations", "10000000", "-o", "out/x.json"], files={"l.json": None})
    big(["pbf", "--size", "1000,1000,1000", "-o", "out/x.cli"])
    big(["pbf", "--resolution", "1e-4", "-o", "out/x.cli"])
    big(["pbf", "--resolution", "0.001", "--size", "50,50,50", "-o", "out/x.cli"])
    # Mesh inputs: a distance field or marching cubes far too fine (estimated from the mesh).
    big(["slice", os.path.join(ROOT, "tests", "data", "mesh", "unit_centimeter.3mf"), "--route", "field",
         "--mesh-voxel", "0.0005", "--machine", PROFILE, "-o", "out/x.gcode"])
    big(["slice", os.path.join(DESIGNS, "csg_bracket.vcad"), "--route", "mesh", "--mesh-voxel", "0.001",
         "--machine", PROFILE, "-o", "out/x.gcode"])
    # Cells the sampling grid cannot resolve (fuzz_job_run: ran for minutes and wrote 40 m parts).
    case("pbf unresolved cell", ["pbf", "--cell", "0.1", "-o", "out/x.cli"], "pbf.cell")
    case("pbf unresolved graded cell", ["pbf", "--grade-to", "schwarz_p:0.05", "-o", "out/x.cli"],
         "pbf.grade_to")
    big(["slice", os.path.join(DESIGNS, "csg_bracket.vcad"), "--layer-height", "0.001", "--resolution", "0.001",
         "--machine", PROFILE, "-o", "out/x.gcode"])
    big(["render", "tp.json", "--image-size", "20000", "-o", "out/x.png"], "--image-size", files={"tp.json": None})
    big(["run", "job.toml"], files={"job.toml": b'[job]\nroute = "lattice2d"\nname = "x"\noutput_dir = "out"\n'
                                                b'[lattice2d]\ncell = 1\nsize = [2000, 2000]\n'})
    big(["run", "job.toml"], files={"job.toml": b'[job]\nroute = "plan"\nname = "x"\noutput_dir = "out"\n'
                                                b'[lattice2d]\ncell = 0.5\nsize = [100, 100]\n[gippo]\niterations = 10000000\n'})


def loose_triangles(n):
    """A binary STL of n loose triangles (a soup: every edge open, a hole per triangle to fill)."""
    import random
    import struct
    r = random.Random(2)
    out = [b"\0" * 80, struct.pack("<I", n)]
    for _ in range(n):
        c = [r.uniform(0, 50) for _ in range(3)]
        out.append(struct.pack("<3f", 0, 0, 0))
        for _ in range(3):
            out.append(struct.pack("<3f", *[c[j] + r.uniform(-1, 1) for j in range(3)]))
        out.append(b"\0\0")
    return b"".join(out)


def sphere_union(n):
    """A .vcad union of n spheres (55 s with --max-time 5 before the design's size was estimated)."""
    import random
    r = random.Random(1)
    body = "".join(f"  translate({r.uniform(-20, 20):.2f},{r.uniform(-20, 20):.2f},{r.uniform(1, 19):.2f}) "
                   "{ sphere(1); }\n" for _ in range(n))
    return ("union() {\n" + body + "}\n").encode()


def piled_gcode(moves):
    """Every move over the same 10 mm: a collision replay of moves^2 pairs."""
    return b"G21\nG90\nM82\n" + b"G1 X10 Y10 E0.01\nG1 X20 Y10 E0.02\n" * (moves // 2)


def runaway_cases_issue47():
    """Runaways of issue 47 that the estimates missed: the design's size, mesh repair, the
    collision replay, walls."""
    case("runaway slice union of 1e5 spheres --max-time 5",
         ["slice", "u.vcad", "--machine", PROFILE, "--max-time", "5", "-o", "out/x.gcode"],
         "refused before starting", {"u.vcad": sphere_union(100000)}, runaway=True)
    case("runaway slice repair of a 2e5-triangle soup --max-time 5",
         ["slice", "soup.stl", "--machine", PROFILE, "--max-time", "5", "-o", "out/x.gcode"],
         "refused before starting", {"soup.stl": loose_triangles(200000)}, runaway=True)
    case("runaway check of 1e5 piled moves", ["check", "l.json", "g.gcode", "--max-time", "10"],
         "refused before starting", {"l.json": TINY_LATTICE, "g.gcode": piled_gcode(100000)}, runaway=True)
    case("runaway check --max-memory 1", ["check", "l.json", "g.gcode", "--max-memory", "1"],
         "refused before starting", {"l.json": TINY_LATTICE, "g.gcode": piled_gcode(100000)}, runaway=True)
    case("runaway walls of 25,200 struts --max-memory 20", ["walls", "big.json", "--max-memory", "20", "-o",
                                                            "out/x.stl"],
         "refused before starting", {"big.json": None}, runaway=True)


def finishing_checks():
    """Requests that are large but cheap finish, quickly: 1,000 angles over 6 non-planar layers
    are 6 directions (all 1,000 were sectioned before, for minutes)."""
    angles = ",".join(f"{-180 + 0.36 * i:.2f}" for i in range(1000))
    problems = []
    with tempfile.TemporaryDirectory(prefix="hostile_finish_") as d:
        t0 = time.monotonic()
        r = subprocess.run([TRELLIS, "nonplanar", "--height-fn", "0.1*x", "--domain", "0,0,40,40", "--angles",
                            angles, "--machine", SYRINGE, "-o", "x.nc"], cwd=d, capture_output=True, timeout=120)
        secs = time.monotonic() - t0
        if r.returncode != 0 or secs > 20 * SCALE or not os.path.exists(os.path.join(d, "x.nc")):
            problems.append(f"nonplanar with 1000 --angles: exit {r.returncode}, {secs:.1f} s: "
                            f"{r.stderr.decode(errors='replace')[:300]}")
    return problems


def prepared(folder, c):
    """Inputs some cases share, made by Trellis itself."""
    if "oc.json" in c.files:
        # 6 x 6 x 6 octets: 100,000 AERO tries over its struts are days of work on any machine.
        subprocess.run([TRELLIS, "lattice3d", "--cell-type", "octet", "--count", "6,6,6", "-o",
                        os.path.join(folder, "oc.json")], capture_output=True, check=True)
    if "l.json" in c.files or "tp.json" in c.files:
        subprocess.run([TRELLIS, "lattice2d", "--cell", "1", "--size", "40,40", "-o",
                        os.path.join(folder, "l.json")], capture_output=True, check=True)
    if "big.json" in c.files:
        # 10 x 10 x 10 cells: 25,200 struts, 580,000 wall triangles (about 58 MB).
        subprocess.run([TRELLIS, "lattice3d", "--count", "10,10,10", "-o", os.path.join(folder, "big.json")],
                       capture_output=True, check=True)
    if "tp.json" in c.files:
        subprocess.run([TRELLIS, "plan", "euler", os.path.join(folder, "l.json"), "-o",
                        os.path.join(folder, "tp.json")], capture_output=True, check=True)


def snapshot(folder):
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            p = os.path.join(dirpath, n)
            st = os.lstat(p)
            out[os.path.relpath(p, folder)] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return out


def limit_memory():
    """A run that is not refused must not take the machine with it (4 GB of address space)."""
    import resource
    if not os.environ.get("HOSTILE_NO_RLIMIT"):  # sanitizers reserve terabytes of address space
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def run_case(c):
    with tempfile.TemporaryDirectory(prefix="hostile_") as d:
        os.makedirs(os.path.join(d, "out"))
        open(os.path.join(d, "out", "keep.txt"), "w").write("here before\n")
        for n, body in c.files.items():
            if body is not None:
                open(os.path.join(d, n), "wb").write(body)
        prepared(d, c)
        if c.setup:
            c.setup(d)
        before = snapshot(d)
        tmp_before = set(os.listdir("/tmp"))
        t0 = time.monotonic()
        p = subprocess.Popen([TRELLIS] + c.args, cwd=d, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             preexec_fn=limit_memory)
        try:
            out, err = p.communicate(timeout=10 * SCALE)
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            return f"{c.name}: still running after {10 * SCALE:g} s"
        secs = time.monotonic() - t0
        err = err.decode(errors="replace")
        problems = []
        if p.returncode != 2:
            problems.append(f"exit {p.returncode}, expected 2")
        if "internal error" in err:
            problems.append("internal error")
        if "error:" not in err:
            problems.append("no error message")
        elif c.where not in err:
            problems.append(f"message does not name {c.where!r}")
        after = snapshot(d)
        # Folder mtimes may move (a temporary came and went); contents may not.
        before = {k: v for k, v in before.items() if not (v[0] & 0o040000)} | {k: 0 for k, v in before.items() if v[0] & 0o040000}
        after = {k: v for k, v in after.items() if not (v[0] & 0o040000)} | {k: 0 for k, v in after.items() if v[0] & 0o040000}
        if after != before:
            added = sorted(set(after) - set(before))
            changed = sorted(k for k in before if k in after and after[k] != before[k])
            removed = sorted(set(before) - set(after))
            problems.append(f"files changed: added {added} changed {changed} removed {removed}")
        leaked = {n for n in set(os.listdir("/tmp")) - tmp_before if n.startswith("trellis_escape")}
        if leaked:
            problems.append(f"wrote outside: {sorted(leaked)}")
        if c.runaway:
            if secs > 2 * SCALE:
                problems.append(f"refusal took {secs:.1f} s")
            if "estimate" not in err and c.where == "refused before starting":
                problems.append("no estimate in the message")
        if problems:
            return f"{c.name}: " + "; ".join(problems) + f"\n    {' '.join(c.args)}\n    stderr: {err.strip()[:400]}"
        return None


def peak_memory_mb(args, folder):
    """Peak RSS (MB) of one run, from wait4."""
    def limits():  # a run that is not refused must not take the machine with it
        import resource
        resource.setrlimit(resource.RLIMIT_CPU, (10, 10))
        if not os.environ.get("HOSTILE_NO_RLIMIT"):
            resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))

    p = subprocess.Popen([TRELLIS] + args, cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         preexec_fn=limits)
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    return ru.ru_maxrss / 1024, p.returncode


def memory_checks():
    """Refusals stay under 200 MB."""
    problems = []
    with tempfile.TemporaryDirectory(prefix="hostile_mem_") as d:
        for c in [c for c in CASES if c.runaway and not any(v is None for v in c.files.values())]:
            for n, body in c.files.items():
                open(os.path.join(d, n), "wb").write(body)
            mb, rc = peak_memory_mb(c.args, d)
            if mb > 200 or rc != 2:
                problems.append(f"{c.name}: peak {mb:.0f} MB, exit {rc}")
    return problems


def umask_check():
    problems = []
    with tempfile.TemporaryDirectory(prefix="hostile_umask_") as d:
        for mask, mode in ((0o077, 0o600), (0o002, 0o664), (0o022, 0o644)):
            subprocess.run([TRELLIS, "lattice2d", "--size", "5,5", "-o", "u.json"], cwd=d, check=True,
                           capture_output=True, preexec_fn=lambda m=mask: os.umask(m))
            got = os.stat(os.path.join(d, "u.json")).st_mode & 0o777
            if got != mode:
                problems.append(f"umask {mask:03o}: output mode {got:03o}, expected {mode:03o}")
            os.remove(os.path.join(d, "u.json"))
    return problems


def main():
    for cls, make in (("settings", settings_cases), ("lattice files", lattice_cases),
                      ("designs and meshes", design_cases), ("toolpaths", toolpath_cases),
                      ("profiles", profile_cases), ("jobs", job_cases), ("G-code", gcode_cases),
                      ("endless inputs", endless_input_cases), ("nonsense", nonsense_cases),
                      ("runaways", runaway_cases), ("runaways (issue 47)", runaway_cases_issue47)):
        CLASS[0] = cls
        make()
    if "--list" in sys.argv:
        for c in CASES:
            print(c.name)
        return 0
    t0 = time.monotonic()
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        failures = [f for f in pool.map(run_case, CASES) if f]
    output_problems, output_counts = outputs.checks(TRELLIS, ROOT)
    failures += memory_checks() + output_problems + umask_check() + big_cell_check() + finishing_checks()
    failures += streamed_check()
    print(f"{len(CASES)} hostile inputs, {len(failures)} problem(s), {time.monotonic() - t0:.0f} s")
    per_class = {}
    for c in CASES:
        per_class[c.cls] = per_class.get(c.cls, 0) + 1
    print("inputs per class: " + ", ".join(f"{k} {v}" for k, v in per_class.items()))
    print("outputs (tests/hostile/outputs.py), runs per class: " +
          ", ".join(f"{k} {v}" for k, v in output_counts.items()))
    for f in failures:
        print("FAIL " + f)
    return 1 if failures or len(CASES) < 200 else 0


if __name__ == "__main__":
    sys.exit(main())
