"""3MF projects in the layout OrcaSlicer and Bambu Studio write (issue 46, item 6).

Their project packages keep the build in 3D/3dmodel.model as components objects whose
components name meshes in other model parts (3MF Production Extension: p:path="/3D/Objects/
object_N.model", requiredextensions="p", p:UUID everywhere), with thumbnails and their settings
under Metadata/. Neither program can be installed here, so this test writes such packages itself
with zipfile, from meshes it builds (a box and a wedge), to the same structure -- not files
exported by those programs -- and checks:

- the mesh read (through `trellis slice`) is the source meshes with every transform composed
  (build item after component after nested component): its G-code equals the G-code of the same
  triangles transformed here, independently, and written as a binary STL;
- the volume and bounding box the test computes for the transformed meshes are those of the
  source meshes placed (a check of this test's own transform arithmetic against hand values);
- a thumbnail, plate and settings files under Metadata/ are ignored;
- a component naming a part the package lacks, an object its part does not define, or a part
  that is not well-formed XML exits 2 with a message naming that part.
"""

import itertools
import os
import struct
import subprocess
import zipfile
from pathlib import Path

import pytest

CLI = os.environ.get("TRELLIS_CLI", "trellis")
ROOT = Path(os.environ.get("TRELLIS_SOURCE_DIR", Path(__file__).resolve().parents[2]))
PROFILE = ROOT / "profiles" / "ender3_s1_pro_tpu.toml"

CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
PROD = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
BAMBU = "http://schemas.bambulab.com/package/2021"
MODEL_REL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
THUMB_REL = "http://schemas.openxmlformats.org/package/2006/relationships/metadata/thumbnail"
IDENTITY = (1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0)


# --- meshes (vertices, triangles), outward facing -------------------------------------------

def box(sx, sy, sz):
    v = [(x, y, z) for z in (0, sz) for y in (0, sy) for x in (0, sx)]
    t = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
         (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
    return v, t


def wedge(sx, sy, sz):
    """A right triangle (0,0) (sx,0) (0,sy) extruded to sz: not symmetric, so a wrong rotation
    or mirror shows."""
    v = [(0, 0, 0), (sx, 0, 0), (0, sy, 0), (0, 0, sz), (sx, 0, sz), (0, sy, sz)]
    t = [(0, 2, 1), (3, 4, 5), (0, 1, 4), (0, 4, 3), (1, 2, 5), (1, 5, 4), (2, 0, 3), (2, 3, 5)]
    return v, t


# --- transforms: 3MF's 12 numbers "m00 m01 m02 m10 m11 m12 m20 m21 m22 m30 m31 m32", a row
# vector times the matrix (3MF core spec 3.4.1): p' = (x y z 1) M ---------------------------

def apply(tf, p):
    x, y, z = p
    return (x * tf[0] + y * tf[3] + z * tf[6] + tf[9],
            x * tf[1] + y * tf[4] + z * tf[7] + tf[10],
            x * tf[2] + y * tf[5] + z * tf[8] + tf[11])


def rot_z90(tx=0, ty=0, tz=0):  # (x, y) -> (-y, x)
    return (0, 1, 0, -1, 0, 0, 0, 0, 1, tx, ty, tz)


def move(tx, ty, tz, s=1):
    return (s, 0, 0, 0, s, 0, 0, 0, s, tx, ty, tz)


def placed(mesh, *tfs):
    """The mesh's triangles as corner triples after tfs (innermost first)."""
    v, t = mesh
    pts = []
    for p in v:
        for tf in tfs:
            p = apply(tf, p)
        pts.append(p)
    return [tuple(pts[i] for i in tri) for tri in t]


def volume(tris):
    vol = 0.0
    for a, b, c in tris:
        vol += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0])) / 6
    return vol


def bbox(tris):
    pts = [p for tri in tris for p in tri]
    return (tuple(min(p[k] for p in pts) for k in range(3)),
            tuple(max(p[k] for p in pts) for k in range(3)))


def write_stl(path, tris):
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", len(tris)))
        for tri in tris:
            f.write(struct.pack("<3f", 0, 0, 0))
            for p in tri:
                f.write(struct.pack("<3f", *p))
            f.write(b"\0\0")


# --- the package -----------------------------------------------------------------------------

def fmt(tf):
    return " ".join(f"{x:g}" for x in tf)


_UUIDS = itertools.count(1)


def uuid(_=None):
    """A new p:UUID (the Production Extension wants them unique within the package)."""
    return f"{next(_UUIDS):08x}-61cb-4c03-9d28-80fed5dfa1dc"


def mesh_xml(oid, mesh):
    v, t = mesh
    vs = "".join(f'     <vertex x="{x:g}" y="{y:g}" z="{z:g}"/>\n' for x, y, z in v)
    ts = "".join(f'     <triangle v1="{a}" v2="{b}" v3="{c}"/>\n' for a, b, c in t)
    return (f'  <object id="{oid}" p:UUID="{uuid(oid)}" type="model">\n   <mesh>\n'
            f'    <vertices>\n{vs}    </vertices>\n    <triangles>\n{ts}    </triangles>\n'
            f'   </mesh>\n  </object>\n')


def model_xml(resources, build=""):
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<model unit="millimeter" xml:lang="en-US" xmlns="{CORE}" xmlns:BambuStudio="{BAMBU}" '
            f'xmlns:p="{PROD}" requiredextensions="p">\n'
            ' <metadata name="Application">BambuStudio-01.09.07.52</metadata>\n'
            ' <metadata name="BambuStudio:3mfVersion">1</metadata>\n'
            f' <resources>\n{resources} </resources>\n <build{build}\n</model>\n')


def components_xml(oid, comps):
    """comps: (path or None, objectid, transform)."""
    rows = ""
    for path, ref, tf in comps:
        p = f' p:path="{path}"' if path else ""
        rows += (f'    <component{p} objectid="{ref}" p:UUID="{uuid(1000 + ref)}" '
                 f'transform="{fmt(tf)}"/>\n')
    return (f'  <object id="{oid}" p:UUID="{uuid(oid)}" type="model">\n   <components>\n{rows}'
            f'   </components>\n  </object>\n')


PNG = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010806000000"
                    "1f15c4890000000d49444154789c6360000002000154a24f5d0000000049454e44ae426082")


def write_project(path, root_objects, items, parts, thumbnail=True, drop=()):
    """root_objects: XML of 3dmodel.model's resources; items: (objectid, transform);
    parts: {"3D/Objects/object_1.model": XML}; drop: part names listed in the relationships but
    left out of the package."""
    build = ">\n" + "".join(
        f'  <item objectid="{oid}" p:UUID="{uuid(2000 + oid)}" transform="{fmt(tf)}" '
        f'printable="1"/>\n' for oid, tf in items) + " </build>"
    build = f' p:UUID="{uuid(3000)}"' + build
    rels = "".join(f' <Relationship Target="/{name}" Id="rel-{i + 1}" Type="{MODEL_REL}"/>\n'
                   for i, name in enumerate(parts))
    top = [f' <Relationship Target="/3D/3dmodel.model" Id="rel-1" Type="{MODEL_REL}"/>\n']
    if thumbnail:
        top.append(f' <Relationship Target="/Metadata/plate_1.png" Id="rel-2" Type="{THUMB_REL}"/>\n')
    rel_head = '<?xml version="1.0" encoding="UTF-8"?>\n<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n'
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml",
                   '<?xml version="1.0" encoding="UTF-8"?>\n<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">\n'
                   ' <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>\n'
                   ' <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>\n'
                   ' <Default Extension="png" ContentType="image/png"/>\n'
                   ' <Default Extension="gcode" ContentType="text/x.gcode"/>\n</Types>\n')
        z.writestr("_rels/.rels", rel_head + "".join(top) + "</Relationships>\n")
        z.writestr("3D/3dmodel.model", model_xml(root_objects, build))
        z.writestr("3D/_rels/3dmodel.model.rels", rel_head + rels + "</Relationships>\n")
        for name, text in parts.items():
            if name not in drop:
                z.writestr(name, text)
        if thumbnail:
            z.writestr("Metadata/plate_1.png", PNG)
            z.writestr("Metadata/plate_1_small.png", PNG)
            z.writestr("Metadata/top_1.png", PNG)
        z.writestr("Metadata/model_settings.config",
                   '<?xml version="1.0" encoding="UTF-8"?>\n<config>\n  <object id="2">\n'
                   '    <metadata key="name" value="box.stl"/>\n    <metadata key="extruder" value="1"/>\n'
                   '  </object>\n  <plate>\n    <metadata key="plater_id" value="1"/>\n'
                   '    <metadata key="thumbnail_file" value="Metadata/plate_1.png"/>\n  </plate>\n</config>\n')
        z.writestr("Metadata/project_settings.config",
                   '{\n    "layer_height": "0.2",\n    "printer_model": "Bambu Lab X1 Carbon",\n'
                   '    "from": "project",\n    "version": "01.09.07.52"\n}\n')
        z.writestr("Metadata/slice_info.config",
                   '<?xml version="1.0" encoding="UTF-8"?>\n<config>\n  <header>\n'
                   '    <header_item key="X-BBL-Client-Type" value="slicer"/>\n  </header>\n</config>\n')


def object_part(*objects):
    return model_xml("".join(objects), "/>")


# --- the cases: (packages, the corner triples the read must give) ---------------------------

BOX, WEDGE = box(10, 6, 4), wedge(8, 5, 3)


def one_object(path, thumbnail=True):
    item = move(20, 30, 0)
    comp = move(1, 2, 0)
    write_project(path, components_xml(2, [("/3D/Objects/object_1.model", 1, comp)]),
                  [(2, item)], {"3D/Objects/object_1.model": object_part(mesh_xml(1, BOX))},
                  thumbnail=thumbnail)
    return placed(BOX, comp, item)


def several_objects(path):
    # Object 3: two parts (box, wedge) in one object part; object 5: a wedge in its own part,
    # placed by a rotation and a half scale.
    p1, p2 = "/3D/Objects/object_1.model", "/3D/Objects/object_2.model"
    c_box, c_wedge, c_other = move(0, 0, 0), move(2, 1, 5), move(0, 0, 0, 0.5)
    i3, i5 = move(10, 10, 0), rot_z90(60, 10, 0)
    roots = (components_xml(3, [(p1, 1, c_box), (p1, 2, c_wedge)]) +
             components_xml(5, [(p2, 4, c_other)]))
    write_project(path, roots, [(3, i3), (5, i5)],
                  {p1[1:]: object_part(mesh_xml(1, BOX), mesh_xml(2, WEDGE)),
                   p2[1:]: object_part(mesh_xml(4, WEDGE))})
    return (placed(BOX, c_box, i3) + placed(WEDGE, c_wedge, i3) +
            placed(WEDGE, c_other, i5))


def nested(path):
    # Root object 9 -> (object part) components object 7 -> meshes 1 and 2 of the same part:
    # item, component, inner components and the meshes' own placement all compose.
    p = "/3D/Objects/object_1.model"
    inner_a, inner_b = move(0, 0, 0), rot_z90(0, 20, 0)
    comp, item = move(0, 0, 2, 2), rot_z90(50, 5, 0)
    part = object_part(mesh_xml(1, BOX), mesh_xml(2, WEDGE),
                       components_xml(7, [(None, 1, inner_a), (None, 2, inner_b)]))
    write_project(path, components_xml(9, [(p, 7, comp)]), [(9, item)], {p[1:]: part})
    return placed(BOX, inner_a, comp, item) + placed(WEDGE, inner_b, comp, item)


def same_id_in_two_parts(path):
    # Object ids are per model part: object 1 of part 1 (a box) and object 1 of part 2 (a wedge).
    p1, p2 = "/3D/Objects/object_1.model", "/3D/Objects/object_2.model"
    i3, i5 = move(0, 0, 0), move(40, 0, 0)
    roots = components_xml(3, [(p1, 1, IDENTITY)]) + components_xml(5, [(p2, 1, IDENTITY)])
    write_project(path, roots, [(3, i3), (5, i5)],
                  {p1[1:]: object_part(mesh_xml(1, BOX)), p2[1:]: object_part(mesh_xml(1, WEDGE))})
    return placed(BOX, i3) + placed(WEDGE, i5)


def run(*args):
    return subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)


def gcode_body(path):
    """G-code without comment lines (the header names the input file and the run)."""
    return [l for l in Path(path).read_text().splitlines() if l and not l.startswith(";")]


def slice_gcode(src, out):
    r = run("slice", src, "--machine", PROFILE, "-o", out)
    assert r.returncode == 0, f"{src}: {r.stderr}"
    return gcode_body(out)


# The hand values the test's own transform arithmetic must give (so the expected meshes the
# slices are compared against are the source meshes placed as the package says).
HAND = {
    "one_object": (240.0, ((21, 32, 0), (31, 38, 4))),
    # box at 10..20 x 10..16 x 0..4; wedge (8 x 5 / 2 x 3 = 60) at 12..20 x 11..16 x 5..8;
    # half wedge (4 x 2.5 x 1.5: 7.5) turned (x, y) -> (-y, x): x 60-2.5..60, y 10..14.
    "several_objects": (240.0 + 60.0 + 7.5, ((10, 10, 0), (60, 16, 8))),
    # The component doubles and lifts by 2: box x 0..20, y 0..12, z 2..10; the wedge, turned
    # and moved 20 in y inside object 7 (x -5..0, y 20..28), becomes x -10..0, y 40..56, z 2..8.
    # The item turns (x, y) -> (-y + 50, x + 5): box x 38..50, y 5..25; wedge x -6..10, y -5..5.
    "nested": (240.0 * 8 + 60.0 * 8, ((-6, -5, 2), (50, 25, 10))),
    "same_id_in_two_parts": (240.0 + 60.0, ((0, 0, 0), (48, 6, 4))),
}


@pytest.mark.parametrize("case", [one_object, several_objects, nested, same_id_in_two_parts],
                         ids=lambda f: f.__name__)
def test_project_reads_as_its_meshes_placed(case, tmp_path):
    pkg = tmp_path / f"{case.__name__}.3mf"
    tris = case(pkg)
    vol, (lo, hi) = HAND[case.__name__]
    assert volume(tris) == pytest.approx(vol, rel=1e-12)
    assert bbox(tris) == (pytest.approx(lo), pytest.approx(hi))
    stl = tmp_path / "same.stl"
    write_stl(stl, tris)
    from_3mf = slice_gcode(pkg, tmp_path / "a.gcode")
    from_stl = slice_gcode(stl, tmp_path / "b.gcode")
    assert len(from_3mf) > 100
    assert from_3mf == from_stl


def test_comparison_sees_a_misplaced_mesh(tmp_path):
    """The G-code comparison above can fail: the same mesh 1 mm off slices differently."""
    pkg, stl = tmp_path / "one.3mf", tmp_path / "off.stl"
    tris = one_object(pkg)
    write_stl(stl, [tuple((x + 1, y, z) for x, y, z in tri) for tri in tris])
    assert slice_gcode(pkg, tmp_path / "a.gcode") != slice_gcode(stl, tmp_path / "b.gcode")


def test_metadata_and_thumbnail_do_not_change_the_mesh(tmp_path):
    with_thumb, without = tmp_path / "with.3mf", tmp_path / "without.3mf"
    one_object(with_thumb, thumbnail=True)
    one_object(without, thumbnail=False)
    assert "Metadata/plate_1.png" in zipfile.ZipFile(with_thumb).namelist()
    assert slice_gcode(with_thumb, tmp_path / "a.gcode") == slice_gcode(without, tmp_path / "b.gcode")


def test_missing_part_is_an_error_naming_it(tmp_path):
    pkg, out = tmp_path / "missing.3mf", tmp_path / "out.gcode"
    p = "/3D/Objects/object_1.model"
    write_project(pkg, components_xml(2, [(p, 1, IDENTITY)]), [(2, IDENTITY)],
                  {p[1:]: object_part(mesh_xml(1, BOX))}, drop=(p[1:],))
    r = run("slice", pkg, "--machine", PROFILE, "-o", out)
    assert r.returncode == 2, r.stderr
    assert "3D/Objects/object_1.model" in r.stderr and "missing.3mf" in r.stderr
    assert not out.exists()


def test_object_missing_from_its_part_is_an_error_naming_it(tmp_path):
    pkg = tmp_path / "noobject.3mf"
    p = "/3D/Objects/object_1.model"
    write_project(pkg, components_xml(2, [(p, 7, IDENTITY)]), [(2, IDENTITY)],
                  {p[1:]: object_part(mesh_xml(1, BOX))})
    r = run("slice", pkg, "--machine", PROFILE, "-o", tmp_path / "out.gcode")
    assert r.returncode == 2, r.stderr
    assert "3D/Objects/object_1.model" in r.stderr and "7" in r.stderr


def test_malformed_part_is_an_error_naming_it(tmp_path):
    pkg = tmp_path / "malformed.3mf"
    p = "/3D/Objects/object_1.model"
    bad = object_part(mesh_xml(1, BOX)).replace('<vertex x="10"', '<vertex x="1 0"', 1)
    write_project(pkg, components_xml(2, [(p, 1, IDENTITY)]), [(2, IDENTITY)], {p[1:]: bad})
    r = run("slice", pkg, "--machine", PROFILE, "-o", tmp_path / "out.gcode")
    assert r.returncode == 2, r.stderr
    assert "3D/Objects/object_1.model line" in r.stderr


if __name__ == "__main__":
    # tests/data/mesh/project_<case>.3mf, read by tests/slice/test_mesh_repair.cpp, which checks
    # the volume and box of the mesh read against the hand values in HAND.
    import sys
    out = Path(sys.argv[1] if len(sys.argv) > 1 else ROOT / "tests" / "data" / "mesh")
    for case in (several_objects, nested):
        case(out / f"project_{case.__name__}.3mf")
