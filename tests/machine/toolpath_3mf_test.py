"""3MF Toolpath Extension out and in (issue 43, items 1, 2 and 6), through the CLI and Python.

- The same PBF build as .cli and as 3MF measures the same in `trellis analyze` (layers, vectors,
  contour and hatch length and FR_a per layer) and reads into the same vectors.
- A deposition print as G-code and as 3MF reads back with the same extrusion per layer, widths
  and tools; a mesh design's 3MF carries the mesh as its build item.
- Every part of every package written here validates against the specification's XSD
  (xmllint --schema); the specification's own example (Appendix D) reads.
- A 3MF without a toolpath, and malformed layer XML, exit 2 with a message naming the file,
  the part and the line.
"""

import json
import math
import os
import re
import shutil
import subprocess
import tomllib
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

CLI = os.environ.get("TRELLIS_CLI", "trellis")
ROOT = Path(os.environ.get("TRELLIS_SOURCE_DIR", Path(__file__).resolve().parents[2]))
DATA = ROOT / "tests" / "data" / "3mf_toolpath"
BEAM_DATA = ROOT / "tests" / "data" / "3mf_beamlattice"
CORE_DATA = ROOT / "tests" / "data" / "3mf_core"
TP = "http://schemas.3mf.io/3dmanufacturing/toolpath/2026/03"
CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
BEAM = "http://schemas.microsoft.com/3dmanufacturing/beamlattice/2017/02"
PROD = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
TREL = "urn:trellis:3mf-toolpath:2026-11"  # our namespace (src/machine/toolpath_3mf_module.hpp)

# A gyroid sheet in a 3 x 3 x 0.6 mm box: thin walls (contours) and junctions (hatches).
GYROID = "root((-1.5,-1.5,0), (1.5,1.5,0.6), (0.02,0.02,0.02)) {\n  gyroid(2.5, 0.1);\n}\n"
# A small part for extrusion: a cylinder with a hole.
PART = ("root((-6,-6,0), (6,6,1.2), (0.05,0.05,0.05)) {\n"
        "  difference() {\n    cylinder(5, 1.2);\n    cylinder(2, 1.2);\n  }\n}\n")


def run(*args, ok=True):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    if ok:
        assert r.returncode == 0, f"{args}: {r.stderr}"
    return r


def trellis_module():
    import trellis  # PYTHONPATH=build/release/python
    return trellis


def layers_of(tp):
    """A Python toolpath's layers: (z, paths), each path a dict of its points and values."""
    a = tp.arrays()
    out = []
    for i in range(tp.layer_count):
        paths = []
        for k in range(a["layer_offsets"][i], a["layer_offsets"][i + 1]):
            pts = a["points"][a["path_offsets"][k]:a["path_offsets"][k + 1]]
            length = float(sum(math.dist(pts[j - 1], pts[j]) for j in range(1, len(pts))))
            paths.append({"points": pts, "length": length, "power": float(a["power"][k]),
                          "speed": float(a["speed"][k]), "width": float(a["width"][k]),
                          "tool": int(a["tool"][k])})
        out.append((float(a["layer_z"][i]), paths))
    return out


# A stand-in for the W3C's xml.xsd (network only): the one attribute the core schema uses.
XML_XSD = ('<?xml version="1.0"?>\n<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" '
           'targetNamespace="http://www.w3.org/XML/1998/namespace">'
           '<xs:attribute name="lang" type="xs:language"/></xs:schema>\n')


@pytest.fixture(scope="module")
def xsd(tmp_path_factory):
    """The specifications' schemas as Debian 12's xmllint (libxml2 2.9.14) compiles them:
    maxOccurs 2^31-1 written as unbounded, the network-only xml.xsd import dropped (toolpath,
    beam lattice: unused) or pointed at a local stand-in (core: xml:lang). "model" is a driver
    importing the core, beam lattice and toolpath schemas, so that one xmllint run validates a
    whole model part, extension elements included. Its core schema lets a mesh have no
    <triangles>: Beam Lattice Chapter 2 allows a lattice's mesh none (validate() checks that
    every other mesh has triangles)."""
    d = tmp_path_factory.mktemp("xsd")
    (d / "xml.xsd").write_text(XML_XSD)

    def fixed(path, xml_import):
        text = path.read_text().replace('maxOccurs="2147483647"', 'maxOccurs="unbounded"')
        return re.sub(r'(<xs:import namespace="http://www.w3.org/XML/1998/namespace"\s+'
                      r'schemaLocation=")[^"]*("\s*/>)', xml_import, text)

    out = {}
    for name in ("toolpath_2026_03.xsd", "toolpath_layer_2026_03.xsd"):
        (d / name).write_text(fixed(DATA / name, ""))
        out[name] = d / name
    (d / "beamlattice.xsd").write_text(fixed(BEAM_DATA / "beamlattice_2017_02.xsd", ""))
    core = fixed(CORE_DATA / "core_2015_02.xsd", r"\1xml.xsd\2")
    relaxed = core.replace('<xs:element ref="triangles"/>', '<xs:element ref="triangles" minOccurs="0"/>')
    assert relaxed != core
    (d / "core.xsd").write_text(relaxed)
    imports = {CORE: "core.xsd", BEAM: "beamlattice.xsd", TP: "toolpath_2026_03.xsd"}
    (d / "model.xsd").write_text(
        '<?xml version="1.0"?>\n<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" '
        'targetNamespace="urn:trellis:test:3mf-model">\n'
        + "".join(f'<xs:import namespace="{ns}" schemaLocation="{f}"/>\n' for ns, f in imports.items())
        + "</xs:schema>\n")
    out["model"] = d / "model.xsd"
    return out


def xmllint(schema, *files):
    r = subprocess.run(["xmllint", "--nonet", "--noout", "--schema", schema, *files],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]


def validate(xsd, path, tmp):
    """Validates the package: the model part against the core, beam lattice and toolpath schemas
    together, every layer part against the layer schema. Then what the schemas cannot say: the
    extensions are required (Toolpath Chapter 1; Beam Lattice Chapter 1: "b" when a lattice is
    written), the build selects the resource (§4.6), every mesh has triangles or a beam lattice,
    and every part a layer names is a build item of the package (Part II §1.1.1)."""
    assert shutil.which("xmllint"), "xmllint (libxml2-utils) is needed: scripts/install-deps.sh"
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        model = ET.fromstring(z.read("3D/3dmodel.model"))
        required = model.get("requiredextensions", "").split()
        assert "tp" in required and "p" in required
        assert ("b" in required) == (model.find(f".//{{{BEAM}}}beamlattice") is not None)
        res = model.find(f".//{{{TP}}}toolpathresource")
        assert res is not None
        build = model.find(f"{{{CORE}}}build")
        assert build.get(f"{{{TP}}}toolpathid") == res.get("id")
        objects = {o.get("id"): o for o in model.iter(f"{{{CORE}}}object")}
        items = {i.get(f"{{{PROD}}}UUID"): i.get("objectid") for i in build.iter(f"{{{CORE}}}item")}
        assert items and all(oid in objects for oid in items.values())
        for o in objects.values():
            mesh = o.find(f"{{{CORE}}}mesh")
            assert (mesh.find(f"{{{CORE}}}triangles/{{{CORE}}}triangle") is not None
                    or mesh.find(f"{{{BEAM}}}beamlattice/{{{BEAM}}}beams/{{{BEAM}}}beam") is not None)
        whole = tmp / "3dmodel.model"
        whole.write_bytes(z.read("3D/3dmodel.model"))
        files = []
        layers = [l.get("path") for l in res.iter(f"{{{TP}}}toolpathlayer")]
        rels = z.read("3D/_rels/3dmodel.model.rels").decode()
        for i, part in enumerate(layers):
            assert part.lstrip("/") in names
            assert f'Target="{part}"' in rels  # §3.2
            layer = z.read(part.lstrip("/"))
            for p in ET.fromstring(layer).iter(f"{{{TP}}}part"):
                assert p.get("uuid") in items, f"{part}: part {p.get('id')} is no build item"
            f = tmp / f"layer{i}.xml"
            f.write_bytes(layer)
            files.append(f)
    xmllint(xsd["model"], whole)
    for chunk in range(0, len(files), 200):
        xmllint(xsd["toolpath_layer_2026_03.xsd"], *files[chunk:chunk + 200])
    return len(layers)


@pytest.fixture(scope="module")
def pbf(tmp_path_factory):
    d = tmp_path_factory.mktemp("pbf")
    (d / "gyroid.vcad").write_text(GYROID)
    machine = ROOT / "profiles" / "pbf_316l_25um.toml"
    for ext in ("cli", "3mf"):
        run("pbf", d / "gyroid.vcad", "--machine", machine, "-o", d / f"g.{ext}")
    return d


def test_pbf_cli_and_3mf_measure_the_same(pbf, tmp_path, xsd):
    reports = {}
    for ext in ("cli", "3mf"):
        run("analyze", pbf / f"g.{ext}", "--design", pbf / "gyroid.vcad",
            "--machine", ROOT / "profiles" / "pbf_316l_25um.toml", "--report", tmp_path / f"{ext}.json")
        reports[ext] = json.loads((tmp_path / f"{ext}.json").read_text())
    c, t = reports["cli"], reports["3mf"]
    assert c["layers"] == t["layers"] > 5
    assert c["vectors"] == t["vectors"] > 50
    assert t["scan_length_mm"] == pytest.approx(c["scan_length_mm"], rel=1e-9)
    assert t["fr_a"]["mean"] == pytest.approx(c["fr_a"]["mean"], rel=1e-9)
    for key in ("z_mm", "area_mm2", "fr_a", "contour_mm", "hatch_mm", "outside_vectors"):
        assert t["per_layer"][key] == pytest.approx(c["per_layer"][key], rel=1e-9, abs=1e-12), key
    assert sum(t["per_layer"]["contour_mm"]) > 0 and sum(t["per_layer"]["hatch_mm"]) > 0
    assert validate(xsd, pbf / "g.3mf", tmp_path) == c["layers"]


def test_pbf_3mf_carries_the_laser_profile(pbf):
    tr = trellis_module()
    cli = layers_of(tr.read_toolpath(str(pbf / "g.cli")))
    tmf = layers_of(tr.read_toolpath(str(pbf / "g.3mf")))
    assert len(cli) == len(tmf)
    with zipfile.ZipFile(pbf / "g.3mf") as z:
        model = ET.fromstring(z.read("3D/3dmodel.model"))
    profiles = list(model.iter(f"{{{TP}}}toolpathprofile"))
    assert {p.get("laserpower") for p in profiles} >= {"100", "200"} or len(profiles) >= 2
    for p in profiles:
        for key in ("laserpower", "laserspeed", "jumpspeed", "spotradius", "laserindex"):
            assert p.get(key) is not None, key
    sources = list(model.iter(f"{{{TP}}}lasersource"))
    assert [s.get("index") for s in sources] == ["0"]
    # The .cli lists a layer's contours before its hatches; the 3MF keeps the planner's order.
    for (za, a), (zb, b) in zip(cli, tmf):
        key = lambda p: (len(p["points"]), round(p["length"], 6), p["power"], p["speed"])
        assert sorted(map(key, a)) == sorted(map(key, b))
        assert za == pytest.approx(zb, abs=1e-9)


def test_pbf_3mf_renders_views_and_reruns(pbf, tmp_path):
    run("render", pbf / "g.3mf", "--layer", 3, "-o", tmp_path / "l3.png")
    assert (tmp_path / "l3.png").stat().st_size > 0
    run("view", pbf / "g.3mf", "-o", tmp_path / "v.html")
    assert (tmp_path / "v.html").stat().st_size > 0
    # The job is embedded (toolpath metadata): rerun beside it makes the same package.
    run("rerun", pbf / "g.3mf", "-o", pbf / "g.again.3mf")
    assert (pbf / "g.again.3mf").read_bytes() == (pbf / "g.3mf").read_bytes()


def extrusion_by_layer(layers):
    return [sum(p["length"] for p in paths) for _, paths in layers]


def test_deposition_gcode_and_3mf_read_back_the_same(tmp_path, xsd):
    (tmp_path / "part.vcad").write_text(PART)
    machine = ROOT / "profiles" / "ender3_s1_pro_tpu.toml"
    for ext in ("gcode", "3mf"):
        run("slice", tmp_path / "part.vcad", "--machine", machine, "-o", tmp_path / f"p.{ext}")
    tr = trellis_module()
    g = layers_of(tr.read_toolpath(str(tmp_path / "p.gcode")))
    t = layers_of(tr.read_toolpath(str(tmp_path / "p.3mf")))
    assert len(g) == len(t) > 3
    for (za, _), (zb, _) in zip(g, t):
        assert zb == pytest.approx(za, abs=1e-3)
    # Extrusion per layer: the G-code's within its 3-decimal coordinates.
    for a, b in zip(extrusion_by_layer(g), extrusion_by_layer(t)):
        assert b == pytest.approx(a, rel=1e-3, abs=0.01)
    widths = lambda layers: sorted({round(p["width"], 3) for _, paths in layers for p in paths})
    tools = lambda layers: sorted({p["tool"] for _, paths in layers for p in paths})
    assert widths(t) == widths(g) and widths(t)[0] > 0
    assert tools(t) == tools(g)
    # analyze measures the same extruded length.
    a = {}
    for ext in ("gcode", "3mf"):
        run("analyze", tmp_path / f"p.{ext}", "--report", tmp_path / f"{ext}.json")
        a[ext] = json.loads((tmp_path / f"{ext}.json").read_text())
    assert a["3mf"]["extruded_length_mm"] == pytest.approx(a["gcode"]["extruded_length_mm"], rel=1e-3)
    validate(xsd, tmp_path / "p.3mf", tmp_path)


def test_nonplanar_and_plan_routes_write_3mf_that_reads_back(tmp_path, xsd):
    # Non-planar layers: a 3-axis toolpath (points carry their z), as the G-code's.
    run("surface", "--kind", "corrugation", "-o", tmp_path / "c.stl")
    machine = ROOT / "profiles" / "fresh_nonplanar_2syringe.toml"
    for ext in ("gcode", "3mf"):
        run("nonplanar", tmp_path / "c.stl", "--machine", machine, "-o", tmp_path / f"c.{ext}")
    with zipfile.ZipFile(tmp_path / "c.3mf") as z:
        model = ET.fromstring(z.read("3D/3dmodel.model"))
    assert model.find(f".//{{{TP}}}toolpathresource").get("toolpathtype") == "3axis"
    # The surface printed on is the build item, as an open "surface" object (core §4.1).
    surface = model.find(f".//{{{CORE}}}object")
    assert surface.get("type") == "surface" and mesh_of(surface)[1]
    tr = trellis_module()
    g = layers_of(tr.read_toolpath(str(tmp_path / "c.gcode")))
    t = layers_of(tr.read_toolpath(str(tmp_path / "c.3mf")))
    assert len(g) == len(t) > 2
    for a, b in zip(extrusion_by_layer(g), extrusion_by_layer(t)):
        assert b == pytest.approx(a, rel=1e-3)
    zs = lambda layers: [p["points"][:, 2].min() for _, paths in layers for p in paths]
    assert zs(t) == pytest.approx(zs(g), abs=2e-3)
    validate(xsd, tmp_path / "c.3mf", tmp_path)
    # The surface as a 3MF mesh package (it was STL bytes under a .3mf name) prints the same,
    # within its 32-bit float vertices (lib3mf's, as the STL's).
    run("surface", "--kind", "corrugation", "-o", tmp_path / "c_mesh.3mf")
    assert zipfile.is_zipfile(tmp_path / "c_mesh.3mf")
    run("nonplanar", tmp_path / "c_mesh.3mf", "--machine", machine, "-o", tmp_path / "c2.gcode")
    again = layers_of(tr.read_toolpath(str(tmp_path / "c2.gcode")))
    assert extrusion_by_layer(again) == pytest.approx(extrusion_by_layer(g), rel=1e-5)
    # A planned lattice: `check` reads the 3MF as it reads the G-code.
    lattice = ROOT / "examples" / "lattices" / "tiny.json"
    fdm = ROOT / "profiles" / "ender3_s1_pro_tpu.toml"
    out = {}
    for ext in ("gcode", "3mf"):
        r = run("plan", "euler", lattice, "--machine", fdm, "-o", tmp_path / f"t{ext}.toolpath.json",
                "--gcode", tmp_path / f"t.{ext}")
        out[ext] = r.stdout.splitlines()[0]
    # The same summary (machine check and estimate as G-code) but for the planner's seconds.
    timed = lambda line: re.sub(r", [0-9.]+ s$", "", line)
    assert timed(out["3mf"]) == timed(out["gcode"])
    checks = {ext: run("check", lattice, tmp_path / f"t.{ext}").stdout for ext in ("gcode", "3mf")}
    assert checks["3mf"] == checks["gcode"] and "0 missing, 0 repeated" in checks["3mf"]
    validate(xsd, tmp_path / "t.3mf", tmp_path)


def cube_stl(path, size=10.0, height=1.0):
    """A closed box as ASCII STL (12 facets, counter-clockwise seen from outside)."""
    v = [(x * size, y * size, z * height) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    faces = [(0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
             (2, 6, 7), (2, 7, 3), (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5)]
    lines = ["solid box"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {v[i][0]} {v[i][1]} {v[i][2]}" for i in f]
        lines += ["endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid box", ""]))


def test_mesh_design_is_the_build_item(tmp_path, xsd):
    stl = tmp_path / "box.stl"
    cube_stl(stl)
    out = tmp_path / "box.3mf"
    run("slice", stl, "--machine", ROOT / "profiles" / "ender3_s1_pro_tpu.toml", "-o", out)
    with zipfile.ZipFile(out) as z:
        model = ET.fromstring(z.read("3D/3dmodel.model"))
    mesh = model.find(f".//{{{CORE}}}mesh")
    assert mesh is not None
    assert len(mesh.findall(f"{{{CORE}}}triangles/{{{CORE}}}triangle")) >= 12
    item = model.find(f"{{{CORE}}}build/{{{CORE}}}item")
    with zipfile.ZipFile(out) as z:
        layer = ET.fromstring(z.read("Toolpath/Layers/layer00001.xml"))
    part = layer.find(f"{{{TP}}}parts/{{{TP}}}part")
    assert part.get("uuid") == item.get("{http://schemas.microsoft.com/3dmanufacturing/production/2015/06}UUID")
    validate(xsd, out, tmp_path)


def mesh_of(obj):
    """An object's vertices (x, y, z) and triangles (v1, v2, v3)."""
    mesh = obj.find(f"{{{CORE}}}mesh")
    vertices = [tuple(float(v.get(k)) for k in "xyz") for v in mesh.iter(f"{{{CORE}}}vertex")]
    triangles = [tuple(int(t.get(k)) for k in ("v1", "v2", "v3")) for t in mesh.iter(f"{{{CORE}}}triangle")]
    return vertices, triangles


def beams_of(obj):
    """An object's beams as pairs of end points, with their radii (r1, r2: §2.1.1.1 defaults)."""
    vertices, _ = mesh_of(obj)
    lattice = obj.find(f"{{{CORE}}}mesh/{{{BEAM}}}beamlattice")
    if lattice is None:
        return []
    out = []
    for b in lattice.iter(f"{{{BEAM}}}beam"):
        r1 = float(b.get("r1", lattice.get("radius")))
        out.append((vertices[int(b.get("v1"))], vertices[int(b.get("v2"))], r1, float(b.get("r2", r1))))
    return out


def nozzle(profile):
    with open(profile, "rb") as f:
        return tomllib.load(f)["extrusion"]["nozzle_diameter"]


def model_of(path):
    with zipfile.ZipFile(path) as z:
        return ET.fromstring(z.read("3D/3dmodel.model"))


def closed(triangles):
    """Every edge of the mesh is met once each way by the triangles (core §4.1, "model")."""
    edges = {}
    for t in triangles:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            edges[(a, b)] = edges.get((a, b), 0) + 1
    return all(n == 1 and edges.get((b, a)) == 1 for (a, b), n in edges.items())


def test_planned_lattice_is_the_build_item_as_beams(tmp_path, xsd):
    """Issue 43: a strut lattice's toolpath package carries the lattice as a Beam Lattice
    Extension object: a beam per strut between the lattice's nodes, of half the bead width,
    built under the UUID the layers name; the toolpath reads back as its G-code twin's."""
    lattice = ROOT / "examples" / "lattices" / "tiny.json"
    fdm = ROOT / "profiles" / "ender3_s1_pro_tpu.toml"
    for ext in ("gcode", "3mf"):
        run("plan", "gippo", lattice, "--machine", fdm, "-o", tmp_path / f"t{ext}.json",
            "--gcode", tmp_path / f"t.{ext}")
    validate(xsd, tmp_path / "t.3mf", tmp_path)
    obj = model_of(tmp_path / "t.3mf").find(f".//{{{CORE}}}object")
    beams = beams_of(obj)
    data = json.loads(lattice.read_text())
    struts = {frozenset((tuple(data["nodes"][a]), tuple(data["nodes"][b]))) for a, b in data["edges"]}
    assert {frozenset((a, b)) for a, b, _, _ in beams} == struts and len(beams) == len(struts)
    # The struts of tiny.json have no radius: half the bead the G-code lays, the nozzle's.
    assert {r for b in beams for r in b[2:]} == {nozzle(fdm) / 2}
    g = layers_of(trellis_module().read_toolpath(str(tmp_path / "t.gcode")))
    t = layers_of(trellis_module().read_toolpath(str(tmp_path / "t.3mf")))
    assert extrusion_by_layer(t) == pytest.approx(extrusion_by_layer(g), rel=1e-3)


def test_lib3mf_reads_the_packages_geometry(tmp_path):
    """An independent reader: Debian's lib3mf 1.8.1 (through Trellis's lattice and mesh readers,
    which use it) sees the beams of a planned lattice's package and the triangles of a sliced
    design's. lib3mf 1.8.1 predates the Toolpath Extension, so — as a consumer that wants the
    geometry only — it reads a copy whose required extensions leave out "tp"."""
    lattice = ROOT / "examples" / "lattices" / "tiny.json"
    run("plan", "euler", lattice, "--machine", ROOT / "profiles" / "ender3_s1_pro_tpu.toml",
        "-o", tmp_path / "t.json", "--gcode", tmp_path / "t.3mf")
    (tmp_path / "part.vcad").write_text(PART)
    run("slice", tmp_path / "part.vcad", "--machine", ROOT / "profiles" / "ender3_s1_pro_tpu.toml",
        "-o", tmp_path / "p.3mf")
    for name in ("t", "p"):
        with zipfile.ZipFile(tmp_path / f"{name}.3mf") as z, \
                zipfile.ZipFile(tmp_path / f"{name}_geometry.3mf", "w") as out:
            for item in z.namelist():
                data = z.read(item)
                if item == "3D/3dmodel.model":
                    data = data.replace(b'requiredextensions="p tp', b'requiredextensions="p')
                out.writestr(item, data)
    # The lattice: the same struts, planned again from the package, as from the JSON.
    a = run("plan", "euler", lattice, "-o", tmp_path / "a.json").stdout.splitlines()[0]
    b = run("plan", "euler", tmp_path / "t_geometry.3mf", "-o", tmp_path / "b.json").stdout.splitlines()[0]
    assert a.split(",")[0] == b.split(",")[0] == "euler: 6 edges"
    # The mesh: lib3mf reads the package's triangles (no index repeated: core §4.1.4.1; the mesh
    # reader leaves out those of no area, which marching cubes makes a few of), over the
    # package's extent, and the design's mesh slices.
    obj = model_of(tmp_path / "p.3mf").find(f".//{{{CORE}}}object")
    vertices, triangles = mesh_of(obj)
    assert len(triangles) > 100 and closed(triangles)
    assert all(len(set(t)) == 3 for t in triangles)

    def area(t):
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = (vertices[i] for i in t)
        u, v = (bx - ax, by - ay, bz - az), (cx - ax, cy - ay, cz - az)
        return any((u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]))
    run("slice", tmp_path / "p_geometry.3mf", "--machine", ROOT / "profiles" / "ender3_s1_pro_tpu.toml",
        "-o", tmp_path / "again.gcode", "--report", tmp_path / "again_report.json")
    report = json.loads((tmp_path / "again_report.json").read_text())
    assert report["mesh_triangles"] == sum(map(area, triangles)) > 0.99 * len(triangles), report
    for k in range(3):
        assert report["extent_mm"]["min"][k] == pytest.approx(min(v[k] for v in vertices), abs=1e-5)
        assert report["extent_mm"]["max"][k] == pytest.approx(max(v[k] for v in vertices), abs=1e-5)


def test_the_beam_lattice_specifications_example_validates_and_reads(tmp_path, xsd):
    """The Beam Lattice Extension's Appendix D.1 (a lattice-only mesh, the form Trellis writes)
    validates against the schemas validate() uses, and reads as a lattice of its 12 beams."""
    example = BEAM_DATA / "spec_example_d1.model"
    xmllint(xsd["model"], example)
    with zipfile.ZipFile(tmp_path / "d1.3mf", "w") as z:
        z.writestr("[Content_Types].xml",
                   '<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
                   '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
                   '<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>')
        z.writestr("_rels/.rels",
                   '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
                   '<Relationship Id="rel0" Target="/3D/3dmodel.model" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>')
        z.writestr("3D/3dmodel.model", example.read_text())
    r = run("plan", "euler", tmp_path / "d1.3mf", "-o", tmp_path / "d1.json")
    assert r.stdout.startswith("euler: 12 edges"), r.stdout


def test_field_designs_are_meshed_as_the_build_item(pbf, tmp_path, xsd):
    """A .vcad design (pbf's gyroid sheet, slice's part) is meshed into its package: a closed
    "model" object inside the design's root box, the build item the layers name."""
    (tmp_path / "part.vcad").write_text(PART)
    run("slice", tmp_path / "part.vcad", "--machine", ROOT / "profiles" / "ender3_s1_pro_tpu.toml",
        "-o", tmp_path / "p.3mf")
    validate(xsd, tmp_path / "p.3mf", tmp_path)
    for path, box in ((pbf / "g.3mf", ((-1.5, -1.5, 0), (1.5, 1.5, 0.6))),
                      (tmp_path / "p.3mf", ((-5, -5, 0), (5, 5, 0.6)))):
        obj = model_of(path).find(f".//{{{CORE}}}object")
        vertices, triangles = mesh_of(obj)
        assert obj.get("type") == "model" and len(triangles) > 100 and closed(triangles)
        for k in range(3):
            assert min(v[k] for v in vertices) >= box[0][k] - 0.05
            assert max(v[k] for v in vertices) <= box[1][k] + 0.05


def test_a_toolpath_without_design_carries_its_beads(tmp_path, xsd):
    """`trellis gcode` of a toolpath JSON without a job (another tool's) has no design: its
    package's build item is the beads it prints, a beam per path segment of half the path's
    width, the nozzle's where the path has none, as the G-code extrudes it (toolpath_3mf.hpp).
    (With its job, the design: toolpath_3mf_items_test.py.)"""
    lattice = ROOT / "examples" / "lattices" / "tiny.json"
    fdm = ROOT / "profiles" / "ender3_s1_pro_tpu.toml"
    run("plan", "euler", lattice, "--machine", fdm, "-o", tmp_path / "planned.json")
    doc = json.loads((tmp_path / "planned.json").read_text())
    del doc["job"]
    (tmp_path / "t.json").write_text(json.dumps(doc))
    run("gcode", tmp_path / "t.json", "--machine", fdm, "-o", tmp_path / "t.3mf")
    validate(xsd, tmp_path / "t.3mf", tmp_path)
    beams = beams_of(model_of(tmp_path / "t.3mf").find(f".//{{{CORE}}}object"))
    layers = layers_of(trellis_module().read_toolpath(str(tmp_path / "t.json")))
    segments = [(tuple(p["points"][k - 1]), tuple(p["points"][k]), (p["width"] or nozzle(fdm)) / 2)
                for _, paths in layers for p in paths for k in range(1, len(p["points"]))]
    assert len(beams) == len(segments) > 0
    for (a, b, r1, r2), (p, q, r) in zip(beams, segments):
        assert a == pytest.approx(p) and b == pytest.approx(q) and r1 == r2 == pytest.approx(r)


def spec_package(path, layer_text=None, model_text=None):
    """Appendix D of the specification as a package: D.1 model, D.2 relationship, D.3 layer."""
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("[Content_Types].xml",
                   '<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
                   '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
                   '<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>'
                   '<Default Extension="xml" ContentType="application/xml"/></Types>')
        z.writestr("_rels/.rels",
                   '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
                   '<Relationship Id="rel0" Target="/3D/3dmodel.model" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>')
        z.writestr("3D/3dmodel.model", model_text or (DATA / "spec_example_3dmodel.model").read_text())
        z.writestr("3D/_rels/3dmodel.model.rels",
                   '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
                   '<Relationship Id="rel1" Type="http://schemas.3mf.io/3dmanufacturing/toolpath/2026/03/layer" '
                   'Target="/Toolpath/Layers/layer00001.xml" /></Relationships>')
        z.writestr("Toolpath/Layers/layer00001.xml",
                   layer_text or (DATA / "spec_example_layer00001.xml").read_text())


def test_the_specifications_example_reads(tmp_path, xsd):
    for f in ("spec_example_layer00001.xml",):
        r = subprocess.run(["xmllint", "--nonet", "--noout", "--schema",
                            xsd["toolpath_layer_2026_03.xsd"], DATA / f], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    spec_package(tmp_path / "d.3mf")
    layers = layers_of(trellis_module().read_toolpath(str(tmp_path / "d.3mf")))
    assert len(layers) == 1
    z, paths = layers[0]
    assert z == pytest.approx(0.05)  # ztop 50 x unitfactor 0.001 mm
    assert len(paths) == 2  # two hatches
    for p in paths:
        assert p["length"] == pytest.approx(10.0)
        assert (p["power"], p["speed"]) == (200.0, 1000.0)
    r = run("analyze", tmp_path / "d.3mf")
    assert "1 layers, 2 vectors (20.0 mm" in r.stdout


def test_a_3mf_without_a_toolpath_is_refused(tmp_path):
    mesh = tmp_path / "mesh.3mf"
    with zipfile.ZipFile(mesh, "w") as z:
        z.writestr("_rels/.rels",
                   '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
                   '<Relationship Id="rel0" Target="/3D/3dmodel.model" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>')
        z.writestr("3D/3dmodel.model",
                   f'<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xmlns="{CORE}"><resources>'
                   '<object id="1" type="model"><mesh><vertices><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/>'
                   '<vertex x="0" y="1" z="0"/></vertices><triangles><triangle v1="0" v2="1" v3="2"/></triangles>'
                   '</mesh></object></resources><build><item objectid="1"/></build></model>')
    r = run("analyze", mesh, ok=False)
    assert r.returncode == 2
    assert str(mesh) in r.stderr and "a 3MF with no toolpath" in r.stderr


def test_malformed_layer_xml_names_the_part_and_line(tmp_path):
    bad = (DATA / "spec_example_layer00001.xml").read_text().replace(
        '<hatch x1="0" y1="100"', '<hatch x1="0" y1="100"<')
    spec_package(tmp_path / "bad.3mf", bad)
    for cmd in (("analyze", tmp_path / "bad.3mf"), ("render", tmp_path / "bad.3mf", "--layer", 0, "-o", tmp_path / "x.png")):
        r = run(*cmd, ok=False)
        assert r.returncode == 2, r.stderr
        line = next(i + 1 for i, s in enumerate(bad.splitlines()) if 'y1="100"<' in s)
        assert "/Toolpath/Layers/layer00001.xml" in r.stderr and f"line {line}" in r.stderr, r.stderr
        assert not (tmp_path / "x.png").exists()
    # A segment naming an undeclared profile is refused too (Part II §1.1.2), with its line.
    undeclared = (DATA / "spec_example_layer00001.xml").read_text().replace('profileid="1"', 'profileid="7"')
    spec_package(tmp_path / "undeclared.3mf", undeclared)
    r = run("analyze", tmp_path / "undeclared.3mf", ok=False)
    assert r.returncode == 2 and "profileid 7" in r.stderr and "line 10" in r.stderr, r.stderr


def test_constant_modifiers_apply_and_others_are_refused(tmp_path):
    """§4.2: a constant laserpower modifier sets each hatch's power; a consumer must refuse a file
    with a modifier it does not apply (Trellis: linear and nonlinear ones)."""
    model = (DATA / "spec_example_3dmodel.model").read_text()
    layer = (DATA / "spec_example_layer00001.xml").read_text()
    modifier = ('laserindex="1"><tp:modifier attribute="laserpower" type="{}" factor="f" '
                'minvalue="0" maxvalue="200"/></tp:toolpathprofile>')
    assert 'laserindex="1" />' in model
    constant = model.replace('laserindex="1" />', modifier.format("constant"))
    scaled = layer.replace('y2="0" />', 'y2="0" f="0.25" />').replace('y2="100" />', 'y2="100" f="1" />')
    spec_package(tmp_path / "m.3mf", scaled, constant)
    _, paths = layers_of(trellis_module().read_toolpath(str(tmp_path / "m.3mf")))[0]
    assert [p["power"] for p in paths] == [50.0, 200.0]
    spec_package(tmp_path / "linear.3mf", scaled, model.replace('laserindex="1" />', modifier.format("linear")))
    r = run("analyze", tmp_path / "linear.3mf", ok=False)
    assert r.returncode == 2 and "linear modifier of laserpower" in r.stderr, r.stderr


@pytest.mark.parametrize("profile", ["pbf_316l_2laser.toml", "pbf_316l_2laser_unequal.toml"])
def test_two_lasers_cli_and_3mf_keep_the_lasers_and_their_times(tmp_path, xsd, profile):
    """Issue 43 item 3: the twin-laser profiles (alike, and differing in every per-laser value)
    split each layer; the .cli and the 3MF carry each vector's laser (and each laser's values
    where they differ), `analyze` of either reports the same per-laser times as the pbf run did,
    and the build time (the slowest laser per layer, summed) is below the lasers' sum."""
    (tmp_path / "gyroid.vcad").write_text(GYROID)
    machine = ROOT / "profiles" / profile
    runs = {}
    for ext in ("cli", "3mf"):
        r = run("pbf", tmp_path / "gyroid.vcad", "--machine", machine, "-o", tmp_path / f"g.{ext}",
                "--report", tmp_path / f"pbf_{ext}.json")
        assert "2 lasers scan" in r.stdout + r.stderr  # the run's summary
        run("analyze", tmp_path / f"g.{ext}", "--machine", machine, "--report", tmp_path / f"a_{ext}.json")
        runs[ext] = (json.loads((tmp_path / f"pbf_{ext}.json").read_text())["lasers"],
                     json.loads((tmp_path / f"a_{ext}.json").read_text())["lasers"])
    for ext, (made, read) in runs.items():
        assert made["count"] == read["count"] == 2, ext
        assert min(made["scan_time_s"]) > 0, ext
        assert read["scan_time_s"] == pytest.approx(made["scan_time_s"], rel=1e-6), ext
        assert read["build_time_s"] == pytest.approx(made["build_time_s"], rel=1e-6), ext
        assert made["build_time_s"] < made["all_lasers_time_s"], ext
        per = made["per_layer"]["scan_time_s"]
        assert [max(l) for l in per] == pytest.approx(made["per_layer"]["build_time_s"]), ext
    # The 3MF: one laser source per laser, and profiles on both.
    with zipfile.ZipFile(tmp_path / "g.3mf") as z:
        model = ET.fromstring(z.read("3D/3dmodel.model"))
    assert [s.get("index") for s in model.iter(f"{{{TP}}}lasersource")] == ["0", "1"]
    assert {p.get("laserindex") for p in model.iter(f"{{{TP}}}toolpathprofile")} == {"0", "1"}
    assert validate(xsd, tmp_path / "g.3mf", tmp_path) > 5
    declared = [l.get("hatchspeed") for l in model.iter(f"{{{TREL}}}laser")]
    assert declared == (["1500", "1000"] if "unequal" in profile else []), declared
    # The .cli: both lasers' ids in the file.
    text = (tmp_path / "g.cli").read_text()
    assert "$$LABEL/3,contour laser 2" in text and "$$HATCHES/4," in text
