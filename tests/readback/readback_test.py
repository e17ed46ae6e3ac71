"""Every output reads back (issue 46, item 2).

Each example job (examples/jobs/*.toml, examples/*.toml) is run with the toolpath it prints
written beside its main output; the tiny plan's toolpath is written again through every G-code
flavour and as ASCII and binary .cli. Every file written then goes through the readers with no
extra flags:

- ``trellis analyze``: the paths, extrusion starts, layers and extruded length of a print equal
  those of the toolpath that made it (``trellis.analyze`` of the toolpath as planned);
- ``trellis view``: exit 0 and the page's scene holds the same number of paths;
- ``trellis render``: a PNG with drawn pixels;
- ``trellis check`` where a design lattice exists: every strut printed, none missing;
- ``trellis rerun``: the same bytes.

A file a reader cannot measure (a report, a lattice given to analyze, a mesh) is refused with
exit 2 and a message naming it, never read as an empty print with exit 0.
"""
import base64
import gzip
import json
import math
import os
import re
import struct
import subprocess
import sys
import zlib

import pytest

import trellis

ROOT = os.environ.get("TRELLIS_SOURCE_DIR",
                      os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.path.abspath(os.environ.get("TRELLIS_CLI", "trellis"))


def cli(*args, cwd=None):
    return subprocess.run([CLI, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=600)


def dir_of(path):
    return os.path.dirname(os.path.abspath(path))


# Jobs run coarser here, with why; each still runs its design, route, machine and writer, and
# every example job is run.
COARSER = {
    # Strategy 2 over the 135 x 175 mm plate: 10 layers, 91,865 paths, 318 s alone under load as
    # written. With a 0.8 mm nozzle (the beads 0.8 mm wide) and 0.64 mm layers: 3 layers, 18,554
    # paths, 12 s of CPU.
    "palette_plate_fgm": ["--set", "extrusion.nozzle_diameter=0.8",
                          "--set", "extrusion.layer_height=0.64"],
}


def example_jobs():
    jobs = []
    for sub in ("jobs", ""):
        folder = os.path.join(ROOT, "examples", sub)
        for f in sorted(os.listdir(folder)):
            if f.endswith(".toml"):
                jobs.append(os.path.join(sub, f) if sub else f)
    return jobs


@pytest.fixture(scope="session")
def mirror(tmp_path_factory):
    """The examples in a folder of their own, each job writing the toolpath it prints too (the
    slice, pbf and nonplanar routes write none by default): its designs, lattices and profiles
    linked, so the jobs' relative paths hold."""
    root = tmp_path_factory.mktemp("readback") / "root"
    (root / "examples" / "jobs").mkdir(parents=True)
    os.symlink(os.path.join(ROOT, "profiles"), root / "profiles")
    for e in os.listdir(os.path.join(ROOT, "examples")):
        src = os.path.join(ROOT, "examples", e)
        if os.path.isdir(src) and e != "jobs":
            os.symlink(src, root / "examples" / e)
    for job in example_jobs():
        with open(os.path.join(ROOT, "examples", job)) as f:
            text = f.read()
        route = re.search(r'^route = "(\w+)"', text, re.M).group(1)
        name = re.search(r'^name = "(.*)"', text, re.M).group(1)
        # Run without previews (output.png = false), which their count would not change.
        text = re.sub(r"^preview_layers = \d+\n", "", text, flags=re.M)
        if route in ("slice", "pbf", "nonplanar"):
            text = text.replace("[job]\n", f'[job]\ntoolpath = "{name}.toolpath.json"\n', 1)
        (root / "examples" / job).write_text(text)
    return root


def run_job(mirror, job, out, *sets):
    text = (mirror / "examples" / job).read_text()
    png = [] if 'route = "gcode"' in text else ["--set", "output.png=false"]
    r = cli("run", mirror / "examples" / job, "-o", out, *png, *sets)
    assert r.returncode == 0, f"{job}: {r.stderr}"


def png_drawn_fraction(path):
    """The fraction of a PNG's drawing band (between the title above and the legend below) that
    is not background (its most common colour): an 8-bit RGB or RGBA PNG decoded with zlib."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and colour in (2, 6), (path, depth, colour)
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        ftype, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b, c = prev[i], prev[i - channels] if i >= channels else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    band = rows[height // 4:height * 3 // 4]
    pixels = [bytes(line[x:x + 3]) for line in band for x in range(0, stride, channels)]
    background = max(set(pixels), key=pixels.count)
    return sum(1 for p in pixels if p != background) / len(pixels)


# Length tolerances from the writers' rounding, per segment: G-code writes X, Y, Z to 3
# decimals (each end moved by at most sqrt(3) x 0.0005 mm, so a segment's length by at most
# twice that); .cli writes µm to 2 decimals (ASCII) or 32-bit floats (binary: 6e-8 relative,
# under 1e-5 mm in a 200 mm build), each end by at most sqrt(2) x 5e-6 mm.
GCODE_MM_PER_SEGMENT = 2 * 3 ** 0.5 * 5e-4
CLI_MM_PER_SEGMENT = 2 * 2 ** 0.5 * 1e-5


class Planned:
    """What the toolpath JSON that made an output holds, measured by the library."""

    def __init__(self, path):
        self.path = path
        self.toolpath = trellis.read_toolpath(path)
        self.analysis = trellis.analyze(self.toolpath)
        self.segments = self.toolpath.point_count - self.toolpath.path_count


def lookahead_of(gcode):
    """The mixing look-ahead our graded G-code records in its header (mm), or 0."""
    with open(gcode, "rb") as f:
        m = re.search(rb"^; mixture lookahead = ([0-9.]+) mm", f.read(1 << 16), re.M)
    return float(m.group(1)) if m else 0.0


BEAD = ("role", "tool", "mixture", "width", "height", "temperature", "power", "flow", "fan", "part")


def deposited_path_count(toolpath_json, lookahead):
    """The IR paths of a planned toolpath as its G-code deposits them with a mixing look-ahead
    (a model of machine/mixing_lag.hpp written apart from it): the changes planned within the
    first `lookahead` mm of printed path are all issued at the start, so every graded path
    starting there carries the mixture the last of them plans; the later ones arrive where they
    were planned. Pieces of one run (no travel between) that then differ in nothing are one path.
    Returns that count and how many of those paths are shorter than 0.1 mm: the reader puts a
    deposited change within 0.05 mm of a point on that point, so such a piece may read back as
    part of its neighbour."""
    with open(toolpath_json) as f:
        layers = [[p for p in l["paths"] if len(p["points"]) >= 2] for l in json.load(f)["layers"]]
    length = lambda p: sum(math.dist(a, b) for a, b in zip(p["points"], p["points"][1:]))
    held, s = None, 0.0
    for p in (p for l in layers for p in l):
        if s > lookahead:
            break
        held = p.get("mixture") or held
        s += length(p)
    s = 0.0
    for p in (p for l in layers for p in l):
        if s > lookahead:
            break
        if p.get("mixture"):
            p["mixture"] = held
        s += length(p)
    count, short = 0, 0
    for l in layers:
        prev = None
        for p in l:
            joins = prev is not None and math.dist(prev["points"][-1], p["points"][0]) <= 1e-9 \
                and (p.get("joined") or not p.get("via")) \
                and all(prev.get(k) == p.get(k) for k in BEAD)
            count += not joins
            short += not joins and length(p) < 0.1
            prev = p
    return count, short


def analyze_report(path, tmp):
    report = os.path.join(tmp, os.path.basename(path) + ".analyze.json")
    r = cli("analyze", path, "--report", report)
    assert r.returncode == 0, f"analyze {path}: {r.stderr}"
    with open(report) as f:
        return json.load(f)


def check_analyze(path, planned, tmp, problems):
    got = analyze_report(path, tmp)
    name = os.path.basename(path)
    # A laser build's .cli, and its toolpath JSON (analyze gives the laser report of both).
    if path.endswith(".cli") or "scan_length_mm" in got:
        want = {"layers": planned.toolpath.layer_count, "paths": planned.toolpath.path_count}
        length, tol = got["scan_length_mm"], CLI_MM_PER_SEGMENT * planned.segments
    else:
        # toolpath_paths too for graded G-code: it issues each mixture change gradient.lookahead
        # mm before the point it deposits at, and the reader gives the mixtures as deposited.
        keys = ["layers", "paths", "extrusion_starts", "toolpath_paths"]
        want = {k: planned.analysis[k] for k in keys}
        if lookahead_of(path) > 0:
            deposited, short = deposited_path_count(planned.path, lookahead_of(path))
            del want["toolpath_paths"]
            # Pieces under 0.1 mm may merge into a neighbour (the reader's 0.05 mm snap); and the
            # printed length read back drifts from the planned one by the G-code's rounding
            # (GCODE_MM_PER_SEGMENT a segment) over the look-ahead, so a deposited change can
            # land past the snap and leave a sliver piece: at most 0.1 % of the paths (2 of
            # 18,456 on the coarse palette plate, none on the vase).
            if not deposited - short <= got["toolpath_paths"] <= deposited + deposited // 1000:
                problems.append(f"analyze {name}: toolpath_paths {got['toolpath_paths']}, planned "
                                f"as deposited {deposited} ({short} of them under 0.1 mm)")
        length, tol = got["extruded_length_mm"], GCODE_MM_PER_SEGMENT * planned.segments
    for k, v in want.items():
        if got[k] != v:
            problems.append(f"analyze {name}: {k} {got[k]}, planned {v}")
    if abs(length - planned.toolpath.extrusion_length) > tol:
        problems.append(f"analyze {name}: length {length:.4f} mm, planned "
                        f"{planned.toolpath.extrusion_length:.4f} (tolerance {tol:.4f})")


def check_view(path, planned, tmp, problems):
    html = os.path.join(tmp, os.path.basename(path) + ".html")
    r = cli("view", path, "-o", html)
    name = os.path.basename(path)
    if r.returncode != 0:
        return problems.append(f"view {name}: exit {r.returncode}: {r.stderr.strip()}")
    m = re.search(r"\((\w+)\): (\d+) layer\(s\), (\d+) paths", r.stdout)
    if not m:
        return problems.append(f"view {name}: no counts in {r.stdout!r}")
    # A path is a run of extrusion between travels, as analyze counts them.
    want = planned.toolpath.path_count if path.endswith(".cli") else planned.analysis["paths"]
    if int(m.group(3)) != want:
        problems.append(f"view {name}: {m.group(3)} paths, planned {want}")
    if int(m.group(2)) != planned.toolpath.layer_count:
        problems.append(f"view {name}: {m.group(2)} layers, planned {planned.toolpath.layer_count}")
    assert os.path.getsize(html) > 1000


def check_render(path, tmp, problems):
    png = os.path.join(tmp, os.path.basename(path) + ".png")
    r = cli("render", path, "-o", png, "--layer", "0", "--image-size", "200")
    name = os.path.basename(path)
    if r.returncode != 0:
        return problems.append(f"render {name}: exit {r.returncode}: {r.stderr.strip()}")
    fraction = png_drawn_fraction(png)
    if fraction < 0.01:
        problems.append(f"render {name}: {100 * fraction:.2f} % of the drawing drawn")


def check_rerun(path, problems):
    stem, ext = os.path.splitext(path)
    again = stem + ".again" + ext
    r = cli("rerun", path, "-o", again, cwd="/")
    name = os.path.basename(path)
    if r.returncode != 0:
        return problems.append(f"rerun {name}: exit {r.returncode}: {r.stderr.strip()}")
    with open(path, "rb") as a, open(again, "rb") as b:
        if a.read() != b.read():
            problems.append(f"rerun {name}: different bytes")
    os.remove(again)


def check_design(lattice, path, tmp, problems):
    report = os.path.join(tmp, os.path.basename(path) + ".check.json")
    r = cli("check", lattice, path, "--report", report)
    name = os.path.basename(path)
    if r.returncode == 2 or not os.path.exists(report):
        return problems.append(f"check {name}: exit {r.returncode}: {r.stderr.strip()}")
    with open(report) as f:
        c = json.load(f)
    if c["missing_struts"]:
        problems.append(f"check {name}: {len(c['missing_struts'])} of {c['struts']} struts missing")


def read_back(out, planned, problems, lattice=None, rerun=True):
    """Every print and toolpath in the folder `out` through the readers."""
    for f in sorted(os.listdir(out)):
        path = os.path.join(out, f)
        if not f.endswith((".gcode", ".nc", ".cli", ".toolpath.json")):
            continue
        check_analyze(path, planned, out, problems)
        check_view(path, planned, out, problems)
        check_render(path, out, problems)
        if rerun:
            check_rerun(path, problems)
        if lattice and not f.endswith(".json"):
            check_design(lattice, path, out, problems)


def refused(args, what, problems):
    r = cli(*args)
    if r.returncode != 2 or not r.stderr.strip():
        problems.append(f"{' '.join(map(str, args[:2]))}: exit {r.returncode} for {what} "
                        f"(stdout {r.stdout.strip()[:80]!r})")


def job_lattice(mirror, job, out):
    """The design lattice of a plan job: the one it generated, or its input."""
    generated = [f for f in os.listdir(out) if f.endswith(".lattice.json")]
    if generated:
        return os.path.join(out, generated[0])
    with open(mirror / "examples" / job) as f:
        m = re.search(r'^input = "(.*\.json)"', f.read(), re.M)
    return str((mirror / "examples" / job).parent / m.group(1)) if m else None


@pytest.mark.parametrize("job", example_jobs())
def test_every_output_of_every_example_job_reads_back(mirror, job):
    text = (mirror / "examples" / job).read_text()
    route = re.search(r'^route = "(\w+)"', text, re.M).group(1)
    out = str(mirror / "out" / os.path.splitext(os.path.basename(job))[0])
    if route == "gcode":  # its input is the tiny plan's toolpath, in ../../out/tiny
        run_job(mirror, "jobs/tiny_plan.toml", mirror / "out" / "tiny")
    run_job(mirror, job, out, *COARSER.get(os.path.splitext(os.path.basename(job))[0], []))
    files = sorted(os.listdir(out))
    assert files, job
    problems = []
    toolpaths = [f for f in files if f.endswith(".toolpath.json")]
    if route == "gcode":
        toolpaths = [str(mirror / "out" / "tiny" / "tiny.toolpath.json")]
    if toolpaths:
        planned = Planned(os.path.join(out, toolpaths[0]))
        lattice = job_lattice(mirror, job, out) if route == "plan" else None
        read_back(out, planned, problems, lattice=lattice)
    for f in files:
        path = os.path.join(out, f)
        if f.endswith(".report.json") or f.endswith(".stl") or \
                (f.endswith(".lattice.json") and route == "plan"):
            # Not prints: refused by the print readers with a message, never read as empty.
            refused(["analyze", path], f, problems)
            refused(["render", path, "-o", path + ".png", "--layer", "0"], f, problems)
        if f.endswith(".report.json") or f.endswith(".stl"):
            refused(["view", path, "-o", path + ".html"], f, problems)
        if f.endswith(".lattice.json") and route in ("lattice2d", "lattice3d"):
            r = cli("view", path, "-o", path + ".html")
            if r.returncode != 0 or "struts" not in r.stdout:
                problems.append(f"view {f}: exit {r.returncode} {r.stderr.strip()}")
            check_rerun(path, problems)
    assert not problems, "\n".join(problems)


# The tiny plan's toolpath written by every G-code writer: each flavour's profile.
FLAVOURS = {
    "marlin": ("ender3_s1_pro_tpu.toml", ".gcode"),
    "marlin_mixing": ("geeetech_mizar_m_mixing.toml", ".gcode"),
    "reprap": ("e3d_toolchanger_rrf.toml", ".gcode"),
    "klipper": ("voron_klipper.toml", ".gcode"),
    "pneumatic": ("pneumatic_pcl_27g.toml", ".nc"),
    "embedded": ("embedded_aero_410um.toml", ".nc"),
}


@pytest.fixture(scope="session")
def tiny(mirror):
    out = mirror / "out" / "tiny_flavours"
    run_job(mirror, "jobs/tiny_plan.toml", out)
    return out


@pytest.mark.parametrize("flavour", sorted(FLAVOURS))
def test_every_gcode_flavour_reads_back(tiny, flavour):
    profile, ext = FLAVOURS[flavour]
    out = str(tiny / flavour)
    os.makedirs(out)
    r = cli("gcode", tiny / "tiny.toolpath.json", "--machine", os.path.join(ROOT, "profiles", profile),
            "-o", os.path.join(out, "tiny" + ext))
    assert r.returncode == 0, r.stderr
    problems = []
    read_back(out, Planned(str(tiny / "tiny.toolpath.json")), problems,
              lattice=os.path.join(ROOT, "examples", "lattices", "tiny.json"))
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("binary", [False, True])
def test_cli_ascii_and_binary_read_back(mirror, binary):
    out = str(mirror / "out" / f"gyroid_cli_{'binary' if binary else 'ascii'}")
    run_job(mirror, "jobs/gyroid_pbf.toml", out, "--set", f"pbf.binary={str(binary).lower()}")
    problems = []
    read_back(out, Planned(os.path.join(out, "gyroid.toolpath.json")), problems)
    with open(os.path.join(out, "gyroid.cli"), "rb") as f:
        head = f.read()
    assert (b"$$LAYER/" not in head) == binary  # binary geometry has no ASCII layer commands
    assert not problems, "\n".join(problems)


# Shardable routes with and without a machine: the merged shards are the one-process file.
SHARD_JOBS = {
    "pbf_machine": ('route = "pbf"\nmachine = "{root}/profiles/pbf_316l_25um.toml"',
                    "[pbf]\ncell_type = \"gyroid\"\ncell = 2.5\nsize = [4.0, 4.0, 0.6]\n", ".cli"),
    "pbf_no_machine": ('route = "pbf"', "[pbf]\ncell_type = \"gyroid\"\ncell = 2.5\n"
                       "size = [4.0, 4.0, 0.6]\n", ".cli"),
    "slice_machine": ('route = "slice"\ninput = "{root}/examples/designs/csg_bracket.vcad"\n'
                      'machine = "{root}/profiles/ender3_s1_pro_tpu.toml"',
                      "[extrusion]\nlayer_height = 0.16\n", ".gcode"),
    "slice_no_machine": ('route = "slice"\ninput = "{root}/examples/designs/csg_bracket.vcad"',
                         "[extrusion]\nlayer_height = 0.16\n", ".gcode"),
    "plan_machine": ('route = "plan"\nmachine = "{root}/profiles/ender3_s1_pro_tpu.toml"',
                     "[lattice2d]\npattern = \"honeycomb\"\ncell = 1.0\nsize = [6.0, 6.0]\n"
                     "[layers]\ncount = 4\n[plan]\nplanner = \"euler\"\n", ".gcode"),
    "nonplanar_machine": ('route = "nonplanar"\nmachine = "{root}/profiles/fresh_nonplanar_2syringe.toml"',
                          "[surface]\nkind = \"corrugation\"\n[nonplanar]\nlayers = 4\n", ".gcode"),
    # Without a machine a non-planar job writes a 3MF toolpath (G-code needs a bath machine); a
    # plan without G-code has nothing to shard (refused: tests/job/test_plate.cpp).
    "nonplanar_no_machine": ('route = "nonplanar"\noutput = "s.3mf"',
                             "[surface]\nkind = \"corrugation\"\n[nonplanar]\nlayers = 4\n", ".3mf"),
}


@pytest.mark.parametrize("case", sorted(SHARD_JOBS))
def test_merged_shards_are_the_one_process_file(tmp_path, case):
    job_lines, body, ext = SHARD_JOBS[case]
    job = tmp_path / "job.toml"
    job.write_text("[job]\n" + job_lines.format(root=ROOT) + "\nname = \"s\"\n" + body +
                   "[output]\npng = false\n")
    one, shards = tmp_path / "one", tmp_path / "shards"
    r = cli("run", job, "-o", one)
    assert r.returncode == 0, r.stderr
    with open(one / ("s" + ext), "rb") as f:
        single = f.read()
    for n in (2, 3):
        for k in range(1, n + 1):
            r = cli("run", job, "-o", shards / str(n), "--shard", f"{k}/{n}")
            assert r.returncode == 0, r.stderr
        manifests = [shards / str(n) / f"s{ext}.shard-{k}-of-{n}.json" for k in range(1, n + 1)]
        # Beside the single run's file: the job in its header names paths relative to it.
        merged = one / f"merged-{n}{ext}"
        r = cli("merge", *manifests, "-o", merged)
        assert r.returncode == 0, r.stderr
        with open(merged, "rb") as f:
            assert f.read() == single, f"{case}: {n} shards merged differ from the single run"


def test_a_3mf_beam_lattice_reads_back_as_the_design_of_its_print(mirror, tmp_path):
    """The octet of jobs/octet_aero.toml as a 3MF beam lattice: the viewer shows its struts, and
    `check` takes it as the design of the job's print (every strut printed once); a 3MF has no
    room for the job, so rerun refuses it saying so, and analyze and render refuse it too."""
    out = mirror / "out" / "octet_3mf"
    run_job(mirror, "jobs/octet_aero.toml", out)
    three = tmp_path / "octet.3mf"
    r = cli("lattice3d", "--cell-type", "octet", "--cell", 7, "--count", "3,3,2", "-o", three)
    assert r.returncode == 0, r.stderr
    with open(out / "octet_aero.lattice.json") as f:
        struts = len(json.load(f)["edges"])
    r = cli("view", three, "-o", tmp_path / "octet.html")
    assert r.returncode == 0, r.stderr
    assert f"(lattice): {struts} struts" in r.stdout
    report = tmp_path / "check.json"
    r = cli("check", three, out / "octet_aero.nc", "--report", report)
    assert r.returncode in (0, 1), r.stderr
    with open(report) as f:
        c = json.load(f)
    assert c["struts"] == struts and not c["missing_struts"] and not c["repeated_struts"]
    problems = []
    refused(["rerun", three, "-o", tmp_path / "again.3mf"], "a 3MF", problems)
    refused(["analyze", three], "a 3MF", problems)
    refused(["render", three, "-o", tmp_path / "x.png", "--layer", "0"], "a 3MF", problems)
    assert not problems, "\n".join(problems)
    assert "carries no Trellis job" in cli("rerun", three, "-o", tmp_path / "again.3mf").stderr
