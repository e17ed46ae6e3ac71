"""3MF build items for plates, merged shards, `trellis gcode` and lattices on a surface (issue 43
item 1), through the CLI.

For every package written here: it validates (toolpath_3mf_test.validate: the XSDs with xmllint,
every layer's part UUID a build item); each part's paths, read from the layer parts, lie on the
part's design as its build item places it (the object's vertices through the item's transform
cover the same footprint and height as the paths); lib3mf (through Trellis's mesh reader, which
composes the build items' transforms) reads the placed geometry over the same extent; a merge of
shards writes the single run's package byte for byte; `trellis gcode` of a toolpath JSON carries
the design of the job it embeds, and a toolpath without one its beads.
"""

import json
import math
import random
import sys
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from toolpath_3mf_test import (BEAM, CORE, PART, PROD, ROOT, TP, beams_of, cube_stl,  # noqa: E402
                               mesh_of, model_of, nozzle, run, validate, xsd)  # noqa: F401

FDM = ROOT / "profiles" / "ender3_s1_pro_tpu.toml"
PBF = ROOT / "profiles" / "pbf_316l_25um.toml"
UNIT = 1e-5  # the writer's unitfactor (mm per coordinate unit)


def transform_of(item):
    """A build item's 3 x 4 transform (core §3.4.1) as a function of a point."""
    m = [float(v) for v in item.get("transform", "1 0 0 0 1 0 0 0 1 0 0 0").split()]
    assert len(m) == 12
    return lambda p: tuple(p[0] * m[k] + p[1] * m[3 + k] + p[2] * m[6 + k] + m[9 + k] for k in range(3))


def items_of(path):
    """The build items: UUID -> (item, object element)."""
    model = model_of(path)
    objects = {o.get("id"): o for o in model.iter(f"{{{CORE}}}object")}
    return {i.get(f"{{{PROD}}}UUID"): (i, objects[i.get("objectid")])
            for i in model.find(f"{{{CORE}}}build").iter(f"{{{CORE}}}item")}


def points_by_part(path):
    """Every path point the layer parts hold (mm), by the UUID of the part its segment names."""
    out = {}
    with zipfile.ZipFile(path) as z:
        model = ET.fromstring(z.read("3D/3dmodel.model"))
        res = model.find(f".//{{{TP}}}toolpathresource")
        for layer_ref in res.iter(f"{{{TP}}}toolpathlayer"):
            layer = ET.fromstring(z.read(layer_ref.get("path").lstrip("/")))
            ztop = float(layer_ref.get("ztop", "nan")) * UNIT  # (3-axis layers: none)
            uuids = {p.get("id"): p.get("uuid") for p in layer.iter(f"{{{TP}}}part")}
            for seg in layer.iter(f"{{{TP}}}segment"):
                pts = out.setdefault(uuids[seg.get("partid")], [])
                for e in seg.iter():
                    for a, b in (("x", "y"), ("x1", "y1"), ("x2", "y2")):
                        if e.get(a) is not None:
                            zk = e.get("z")
                            pts.append((float(e.get(a)) * UNIT, float(e.get(b)) * UNIT,
                                        float(zk) * UNIT if zk is not None else ztop))
    return out


def box(points):
    return [min(p[k] for p in points) for k in range(3)], [max(p[k] for p in points) for k in range(3)]


def placed_vertices(item, obj):
    f = transform_of(item)
    return [f(v) for v in mesh_of(obj)[0]]


def check_parts_on_their_designs(path, labels, tol_xy, tol_z, tol_bottom=1e-6):
    """Every part of the plate is one build item (partnumber = its label); its printed points lie
    on its placed design: the same XY footprint and top within the tolerances (a bead, a sampling
    step), its bottom at z = 0 (within `tol_bottom`: a meshed sheet's lowest vertex)."""
    items = items_of(path)
    points = points_by_part(path)
    assert set(points) <= set(items)
    assert sorted(i.get("partnumber") for i, _ in items.values()) == sorted(labels)
    for uuid, (item, obj) in items.items():
        assert obj.find(f"{{{CORE}}}mesh/{{{CORE}}}triangles") is not None, "a design, not beads"
        assert "beads" not in obj.get("name", "")
        lo, hi = box(placed_vertices(item, obj))
        plo, phi = box(points[uuid])
        for k in range(2):
            assert plo[k] == pytest.approx(lo[k], abs=tol_xy), (item.get("partnumber"), k, plo, lo)
            assert phi[k] == pytest.approx(hi[k], abs=tol_xy), (item.get("partnumber"), k, phi, hi)
        assert lo[2] == pytest.approx(0, abs=tol_bottom), (item.get("partnumber"), lo)
        assert phi[2] == pytest.approx(hi[2], abs=tol_z), (item.get("partnumber"), phi, hi)
    return items


def lib3mf_extent(path, tmp):
    """The package's geometry as lib3mf reads it (Trellis's mesh reader: build items with their
    transforms), from a copy that leaves "tp" out of the required extensions (lib3mf 1.8.1
    predates it): the extent `slice --report` gives."""
    geometry = tmp / (path.stem + "_geometry.3mf")
    with zipfile.ZipFile(path) as z, zipfile.ZipFile(geometry, "w") as out:
        for name in z.namelist():
            data = z.read(name)
            if name == "3D/3dmodel.model":
                data = data.replace(b'requiredextensions="p tp', b'requiredextensions="p')
            out.writestr(name, data)
    report = tmp / (path.stem + "_geometry.json")
    run("slice", geometry, "--machine", FDM, "-o", tmp / (path.stem + "_geometry.gcode"),
        "--report", report)
    e = json.loads(report.read_text())["extent_mm"]
    return e["min"], e["max"]


def lifted_stl(path, size, height, z0):
    """cube_stl's box with its bottom at z0 (the layers count from it, the build item drops it)."""
    cube_stl(path, size=size, height=height)
    lines = []
    for line in path.read_text().splitlines():
        if line.startswith("vertex "):
            x, y, z = map(float, line.split()[1:])
            line = f"vertex {x} {y} {z + z0}"
        lines.append(line)
    path.write_text("\n".join(lines) + "\n")


def plate_job(path, route, parts, extra=""):
    """A job file of `parts`: (label, input or None, x, y, rotation, own settings TOML)."""
    head = {"slice": f'machine = "{FDM}"\n', "pbf": f'machine = "{PBF}"\n'}[route]
    text = f'[job]\nroute = "{route}"\nname = "plate"\n{head}output = "plate.3mf"\n{extra}'
    for label, design, x, y, rot, own in parts:
        text += f'\n[[part]]\nlabel = "{label}"\nx = {x}\ny = {y}\nrotation = {rot}\n'
        if design:
            text += f'input = "{design}"\n'
        text += own
    path.write_text(text)
    return path


SLICE_EXTRA = "[extrusion]\nlayer_height = 0.15\n[slice]\nwalls = 1\ninfill = 0.2\n"
PBF_EXTRA = ("[scan]\nlayer = 0.1\n[pbf]\ncell_type = \"gyroid\"\ncell = 2.0\n"
             "size = [2.0, 2.0, 1.0]\nresolution = 0.05\n[plate]\nclearance = 1.0\n")


def slice_parts(tmp, seed):
    """Three or four parts from a seed: the cylinder with a hole (.vcad), a box (STL) lifted off
    z = 0, each at a random place and turn on a grid that keeps them apart."""
    rng = random.Random(seed)
    (tmp / "part.vcad").write_text(PART)
    cube_stl(tmp / "box.stl", size=8.0, height=1.2)
    lifted = tmp / "lifted.stl"
    lifted_stl(lifted, size=6.0, height=0.9, z0=2.5)
    designs = [tmp / "part.vcad", tmp / "box.stl", lifted, tmp / "part.vcad"]
    n = rng.choice((3, 4))
    return [(f"p{k + 1}", designs[k], 60 + 25 * (k % 2) + rng.uniform(-3, 3),
             60 + 25 * (k // 2) + rng.uniform(-3, 3), rng.choice((0, 30, 45, 90, 137)),
             "[part.slice]\nwalls = 2\n" if k == 3 else "") for k in range(n)]


@pytest.mark.parametrize("seed", [1, 2])
def test_slice_plate_parts_are_their_designs_placed(tmp_path, xsd, seed):
    parts = slice_parts(tmp_path, seed)
    job = plate_job(tmp_path / "plate.toml", "slice", parts, SLICE_EXTRA)
    run("run", job, "-o", tmp_path / "out")
    out = tmp_path / "out" / "plate.3mf"
    validate(xsd, out, tmp_path)
    # One object per design (the two cylinders share theirs), a build item per part.
    items = check_parts_on_their_designs(out, [p[0] for p in parts], tol_xy=0.6, tol_z=0.2)
    assert len({o.get("id") for _, o in items.values()}) == len({str(p[1]) for p in parts})
    # lib3mf reads the placed parts: their union's extent.
    lo, hi = lib3mf_extent(out, tmp_path)
    every = [v for i, o in items.values() for v in placed_vertices(i, o)]
    elo, ehi = box(every)
    assert lo == pytest.approx(elo, abs=1e-4) and hi == pytest.approx(ehi, abs=1e-4)


def pbf_parts(seed):
    rng = random.Random(seed)
    return [(f"g{k + 1}", None, 20 + 6 * (k % 2) + rng.uniform(-0.5, 0.5),
             20 + 6 * (k // 2) + rng.uniform(-0.5, 0.5), rng.choice((0, 30, 60)),
             "[part.pbf]\ncell = 1.0\nsize = [2.0, 2.0, 1.5]\n" if k == 2 else "")
            for k in range(rng.choice((3, 4)))]


@pytest.mark.parametrize("seed", [3, 4])
def test_pbf_plate_parts_are_their_designs_placed(tmp_path, xsd, seed):
    parts = pbf_parts(seed)
    job = plate_job(tmp_path / "plate.toml", "pbf", parts, PBF_EXTRA)
    run("run", job, "-o", tmp_path / "out")
    out = tmp_path / "out" / "plate.3mf"
    validate(xsd, out, tmp_path)
    items = check_parts_on_their_designs(out, [p[0] for p in parts], tol_xy=0.15, tol_z=0.12,
                                         tol_bottom=0.05)
    # The part with its own cell and height is an object of its own.
    assert len({o.get("id") for _, o in items.values()}) == 2


def merged_equals_single(tmp, job, shards=2, *extra):
    run("run", job, "-o", tmp / "whole", *extra)
    for k in range(1, shards + 1):
        run("run", job, "-o", tmp / "shards", "--shard", f"{k}/{shards}", *extra)
    return tmp / "whole", tmp / "shards"


def same_package(a, b):
    """Byte for byte; else say what differs: objects, build items, layers."""
    if a.read_bytes() == b.read_bytes():
        return
    ma, mb = model_of(a), model_of(b)
    ia = [ET.tostring(i) for i in ma.find(f"{{{CORE}}}build")]
    ib = [ET.tostring(i) for i in mb.find(f"{{{CORE}}}build")]
    assert ia == ib, "build items differ"
    oa = [ET.tostring(o) for o in ma.iter(f"{{{CORE}}}object")]
    ob = [ET.tostring(o) for o in mb.iter(f"{{{CORE}}}object")]
    assert oa == ob, "objects differ"
    with zipfile.ZipFile(a) as za, zipfile.ZipFile(b) as zb:
        assert za.namelist() == zb.namelist()
        for n in za.namelist():
            assert za.read(n) == zb.read(n), n


@pytest.mark.parametrize("route", ["slice", "pbf"])
def test_merged_plate_is_the_single_runs_package(tmp_path, xsd, route):
    parts = slice_parts(tmp_path, 5) if route == "slice" else pbf_parts(6)
    job = plate_job(tmp_path / "plate.toml", route, parts,
                    SLICE_EXTRA if route == "slice" else PBF_EXTRA)
    whole, shards = merged_equals_single(tmp_path, job, 3)
    manifests = sorted(shards.glob("plate.3mf.shard-*-of-3.json"))
    assert len(manifests) == 3
    # (At the depth of the single run's: the job embedded names its files relative to it.)
    (tmp_path / "merged").mkdir()
    run("merge", *manifests, "-o", tmp_path / "merged" / "plate.3mf")
    same_package(whole / "plate.3mf", tmp_path / "merged" / "plate.3mf")
    validate(xsd, tmp_path / "merged" / "plate.3mf", tmp_path)


# A honeycomb made in the job (flat, and laid on a sphere cap of radius 15 mm over a 14 mm disc).
MADE = ('[plan]\nplanner = "euler"\n[lattice2d]\npattern = "honeycomb"\ncell = 1.5\n'
        'region = "circle"\ndiameter = 12\n[layers]\ncount = 4\n')
ONTO = ('[plan]\nplanner = "euler"\n[lattice2d]\npattern = "honeycomb"\ncell = 1.5\n'
        'region = "circle"\ndiameter = 12\n[layers]\ncount = {layers}\n'
        '[onto]\nkind = "sphere-cap"\nradius = 15\ndiameter = 14\n')


def single_job(path, route, design, extra):
    machine = FDM if route in ("slice", "plan") else PBF
    text = f'[job]\nroute = "{route}"\nname = "one"\nmachine = "{machine}"\n'
    if design:
        text += f'input = "{design}"\n'
    text += ('gcode = "one.3mf"\n[output]\ngcode = true\n' if route == "plan"
             else 'output = "one.3mf"\n') + extra
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", ["slice_vcad", "slice_lifted_stl", "pbf_box", "plan_lattice",
                                  "plan_made", "plan_onto"])
def test_merged_single_part_is_the_single_runs_package(tmp_path, xsd, case):
    """One part (slice, pbf), a planned lattice (a file, one made in the job, one laid on a
    surface): the merge's package has the single run's objects and build items."""
    (tmp_path / "part.vcad").write_text(PART)
    lifted = tmp_path / "lifted.stl"
    lifted_stl(lifted, size=6.0, height=1.2, z0=3.0)
    route, design, extra = {
        "slice_vcad": ("slice", tmp_path / "part.vcad", "[extrusion]\nlayer_height = 0.15\n"),
        "slice_lifted_stl": ("slice", lifted, "[extrusion]\nlayer_height = 0.15\n"),
        "pbf_box": ("pbf", None, PBF_EXTRA.replace("[plate]\nclearance = 1.0\n", "")),
        "plan_lattice": ("plan", ROOT / "examples" / "lattices" / "tiny.json", ""),
        "plan_made": ("plan", None, MADE),
        "plan_onto": ("plan", None, ONTO.format(layers=3)),
    }[case]
    job = single_job(tmp_path / "one.toml", route, design, extra)
    whole, shards = merged_equals_single(tmp_path, job, 2)
    manifests = sorted(shards.glob("one.3mf.shard-*-of-2.json"))
    assert len(manifests) == 2
    (tmp_path / "merged").mkdir()
    run("merge", *manifests, "-o", tmp_path / "merged" / "one.3mf")
    same_package(whole / "one.3mf", tmp_path / "merged" / "one.3mf")
    validate(xsd, tmp_path / "merged" / "one.3mf", tmp_path)
    objects = list(model_of(tmp_path / "merged" / "one.3mf").iter(f"{{{CORE}}}object"))
    assert len(objects) == 1 and "beads" not in objects[0].get("name")
    if case == "plan_onto":
        assert objects[0].get("type") == "surface"


def test_gcode_of_a_toolpath_json_carries_its_jobs_design(tmp_path, xsd):
    """`trellis gcode` of a toolpath JSON: the struts of the lattice its plan read (a beam per
    strut, as the plan's own package), the sliced design (the slice's own object and item), the
    surface a lattice was laid on; without a job, the beads; a design gone, the beads and a
    warning."""
    lattice = ROOT / "examples" / "lattices" / "tiny.json"
    run("plan", "euler", lattice, "--machine", FDM, "-o", tmp_path / "t.json", "--gcode", tmp_path / "t.3mf")
    run("gcode", tmp_path / "t.json", "--machine", FDM, "-o", tmp_path / "g.3mf")
    validate(xsd, tmp_path / "g.3mf", tmp_path)
    beams = beams_of(model_of(tmp_path / "g.3mf").find(f".//{{{CORE}}}object"))
    data = json.loads(lattice.read_text())
    struts = {frozenset((tuple(data["nodes"][a]), tuple(data["nodes"][b]))) for a, b in data["edges"]}
    assert {frozenset((a, b)) for a, b, _, _ in beams} == struts and len(beams) == len(struts)
    objects = lambda p: [ET.tostring(o) for o in model_of(p).iter(f"{{{CORE}}}object")]
    assert objects(tmp_path / "g.3mf") == objects(tmp_path / "t.3mf")
    # A slice: the design's object and build item, as the slice's own package.
    (tmp_path / "part.vcad").write_text(PART)
    run("slice", tmp_path / "part.vcad", "--machine", FDM, "-o", tmp_path / "p.3mf", "--toolpath",
        tmp_path / "p.json")
    run("gcode", tmp_path / "p.json", "--machine", FDM, "-o", tmp_path / "pg.3mf")
    validate(xsd, tmp_path / "pg.3mf", tmp_path)
    assert objects(tmp_path / "pg.3mf") == objects(tmp_path / "p.3mf")
    build = lambda p: [ET.tostring(i) for i in model_of(p).find(f"{{{CORE}}}build")]
    assert build(tmp_path / "pg.3mf") == build(tmp_path / "p.3mf")
    # No job: the beads.
    doc = json.loads((tmp_path / "t.json").read_text())
    del doc["job"]
    (tmp_path / "nojob.json").write_text(json.dumps(doc))
    run("gcode", tmp_path / "nojob.json", "--machine", FDM, "-o", tmp_path / "b.3mf")
    validate(xsd, tmp_path / "b.3mf", tmp_path)
    assert "printed beads" in model_of(tmp_path / "b.3mf").find(f".//{{{CORE}}}object").get("name")
    # The design gone: the beads, said.
    copy = tmp_path / "moved"
    copy.mkdir()
    (copy / "p.json").write_text((tmp_path / "p.json").read_text())
    r = run("gcode", copy / "p.json", "--machine", FDM, "-o", tmp_path / "m.3mf")
    assert "design_not_read" in r.stderr or "could not be read again" in r.stderr, r.stderr
    assert "printed beads" in model_of(tmp_path / "m.3mf").find(f".//{{{CORE}}}object").get("name")


def test_lattice_on_a_surface_carries_the_surface(tmp_path, xsd):
    """plan with onto.*: the surface the lattice is laid on, an open "surface" object under the
    toolpath (every point within a layer stack above it), in the plan's package and in `gcode`'s
    of its toolpath JSON."""
    job = single_job(tmp_path / "onto.toml", "plan", None,
ONTO.format(layers=2))
    text = job.read_text().replace('gcode = "one.3mf"', 'gcode = "one.3mf"\ntoolpath = "one.json"')
    job.write_text(text)
    run("run", job, "-o", tmp_path / "out")
    pkg = tmp_path / "out" / "one.3mf"
    validate(xsd, pkg, tmp_path)
    (item, obj), = items_of(pkg).values()
    assert obj.get("type") == "surface"
    vertices, triangles = mesh_of(obj)
    assert len(triangles) > 100
    # The cap: z = sqrt(R² - r²) - sqrt(R² - (D/2)²) over its footprint; the paths lie on or
    # above it.
    def cap(x, y):
        return math.sqrt(15 ** 2 - x * x - y * y) - math.sqrt(15 ** 2 - 7 ** 2)
    (x0, y0, _), (x1, y1, _) = box(vertices)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    for v in vertices[:: max(1, len(vertices) // 200)]:
        assert v[2] == pytest.approx(cap(v[0] - cx, v[1] - cy), abs=0.05)
    pts = [p for ps in points_by_part(pkg).values() for p in ps]
    assert pts and all(p[2] >= cap(p[0] - cx, p[1] - cy) - 0.05 for p in pts)
    run("gcode", tmp_path / "out" / "one.json", "--machine", FDM, "-o", tmp_path / "g.3mf")
    validate(xsd, tmp_path / "g.3mf", tmp_path)
    assert ([ET.tostring(o) for o in model_of(tmp_path / "g.3mf").iter(f"{{{CORE}}}object")]
            == [ET.tostring(o) for o in model_of(pkg).iter(f"{{{CORE}}}object")])
