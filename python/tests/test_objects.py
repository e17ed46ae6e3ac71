"""Objects all the way: toolpaths designed in numpy (Toolpath.from_arrays) checked like a file and
printed on every machine profile; every function that takes a file takes the object; outputs
made from objects rerun to the same bytes."""
import filecmp
import glob
import math
import os
import tomllib

import numpy as np
import pytest

import trellis

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
PROFILES = sorted(glob.glob(os.path.join(ROOT, "profiles", "*.toml")))
ENDER = os.path.join(ROOT, "profiles", "ender3_s1_pro_tpu.toml")
BATH = os.path.join(ROOT, "profiles", "embedded_aero_410um.toml")
MIXING = os.path.join(ROOT, "profiles", "geeetech_mizar_m_mixing.toml")
LASER = os.path.join(ROOT, "profiles", "pbf_316l_25um.toml")
PLATE = os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad")


def is_laser(profile):
    with open(profile, "rb") as f:
        return "laser" in tomllib.load(f)


def spiral_vase(radius=12.0, turns=15, rise=0.2, per_turn=120):
    """One continuous path rising `rise` mm per turn (a FullControl-style vase)."""
    t = np.linspace(0, turns * 2 * np.pi, turns * per_turn + 1)
    r = radius + 1.5 * np.sin(t / turns)  # a bulge along the height
    return np.column_stack([r * np.cos(t), r * np.sin(t), 0.2 + rise * t / (2 * np.pi)])


def sine_wave(lines=6, length=30.0, amplitude=1.0):
    """Parallel non-planar lines, z a sine along x, alternating direction."""
    x = np.linspace(0, length, 121)
    paths = []
    for i in range(lines):
        xs = x if i % 2 == 0 else x[::-1]
        paths.append(np.column_stack([xs, np.full_like(xs, 0.6 * i), 1.5 + amplitude * np.sin(2 * np.pi * xs / 10)]))
    return np.concatenate(paths), np.arange(lines + 1) * len(x)


def design_length(points, offsets):
    return sum(np.linalg.norm(np.diff(points[a:b], axis=0), axis=1).sum()
               for a, b in zip(offsets[:-1], offsets[1:]))


@pytest.fixture(scope="module")
def routes(tmp_path_factory):
    """Toolpaths made by several routes."""
    d = tmp_path_factory.mktemp("routes")
    lat = trellis.lattice2d(pattern="penrose", cell=1.2, size=(8, 8)).lattice
    return {
        "gippo": trellis.plan("gippo", lat, machine=ENDER, iterations=20).toolpath,
        "aero": trellis.plan("aero", trellis.lattice3d(cell_type="octet", cell=7, count=(2, 2, 1)).lattice,
                             machine=BATH).toolpath,
        "slice": trellis.slice(PLATE, machine=ENDER, strategy="none").toolpath,
        "graded": trellis.slice(PLATE, machine=MIXING, strategy=2, colors=4).toolpath,
        "pbf": trellis.pbf(size=(2.5, 2.5, 0.3)).toolpath,
        "nonplanar": trellis.nonplanar(None, d / "n.gcode", machine=os.path.join(
            ROOT, "profiles", "fresh_nonplanar_2syringe.toml"), height_fn="0.2*x", domain=(0, 0, 8, 4),
            layers=2).toolpath,
    }


@pytest.mark.parametrize("route", ["gippo", "aero", "slice", "graded", "pbf", "nonplanar"])
def test_from_arrays_inverts_arrays(routes, route):
    tp = routes[route]
    a = tp.arrays()
    back = trellis.Toolpath.from_arrays(**a)
    b = back.arrays()
    assert set(a) == set(b)
    for key in a:
        assert a[key].shape == b[key].shape, key
        assert np.array_equal(a[key], b[key]), key
    assert back.extrusion_length == tp.extrusion_length
    # And once more through the toolpath file: the same arrays.
    again = trellis.Toolpath(trellis._trellis.toolpath_from_json(back.to_json()))
    for key in a:
        assert np.array_equal(a[key], again.arrays()[key]), key


def test_from_arrays_defaults_and_broadcasts():
    pts, offs = sine_wave(lines=3)
    tp = trellis.Toolpath.from_arrays(pts, offs, width=0.5, height=np.array([0.2, 0.25, 0.3]),
                                      role=["perimeter", "infill", 6], mixture=[0.25, 0.75])
    assert tp.layer_count == 1 and tp.path_count == 3 and tp.point_count == len(pts)
    assert list(tp.role) == [3, 4, 6] and np.all(tp.width == 0.5) and list(tp.height) == [0.2, 0.25, 0.3]
    assert np.allclose(tp.mixture, [[0.25, 0.75]] * 3)
    assert tp.layer_z[0] == pts[:, 2].min()  # a layer's z: its lowest point by default
    assert math.isclose(tp.extrusion_length, design_length(pts, offs), rel_tol=1e-12)
    one = trellis.Toolpath.from_arrays(spiral_vase())
    assert one.path_count == 1 and one.layer_count == 1


BAD = [
    (dict(points=np.zeros((4, 2))), "points"),
    (dict(points=np.array([[0, 0, 0], [1, 0, 0], [np.nan, 0, 0], [3, 0, 0]])), "points[2]"),
    (dict(points=np.array([[0, 0, 0], [1, 0, 0], [2, 0, 2e6], [3, 0, 0]])), "points[2]"),
    (dict(path_offsets=[1, 4]), "path_offsets[0]"),
    (dict(path_offsets=[0, 3, 2, 4]), "path_offsets[2]"),
    (dict(path_offsets=[0, 2, 5]), "path_offsets[2]"),
    (dict(path_offsets=[0, 1, 4]), "path_offsets[0]"),
    (dict(path_offsets=np.array([0.0, 4.0])), "path_offsets"),
    (dict(layer_offsets=[0, 2]), "layer_offsets[1]"),
    (dict(path_offsets=[0, 2, 4], layer_z=[1.0, 2.0]), "layer_z"),
    (dict(role="strt"), "role"),
    (dict(path_offsets=[0, 2, 4], role=["strut", "bogus"]), "role[1]"),
    (dict(role=len(trellis.ROLES)), "role"),  # one past the last role
    (dict(path_offsets=[0, 2, 4], width=[0.4, -0.1]), "width[1]"),
    (dict(path_offsets=[0, 2, 4], width=[0.4, 0.4, 0.4]), "width"),
    (dict(height=float("inf")), "height[0]"),
    (dict(speed="fast"), "speed"),
    (dict(tool=1.5), "tool[0]"),
    (dict(tool=-1), "tool[0]"),
    (dict(temperature=-20), "temperature[0]"),
    (dict(path_offsets=[0, 2, 4], mixture=[[0.5, 0.5], [0.5, -0.5]]), "mixture[1, 1]"),
    (dict(path_offsets=[0, 2, 4], mixture=np.ones((3, 2))), "mixture"),
]


@pytest.mark.parametrize("kwargs,element", BAD, ids=[e for _, e in BAD])
def test_from_arrays_refuses_bad_input_naming_argument_and_index(kwargs, element):
    args = dict(points=np.array([[0, 0, 0.2], [1, 0, 0.2], [1, 1, 0.2], [0, 1, 0.2]], float))
    args.update(kwargs)
    with pytest.raises(trellis.InputError) as e:
        trellis.Toolpath.from_arrays(**args)
    assert e.value.element == element, str(e.value)


def profile_value(profile, section):
    """A setting of a profile's section: the profile's value, else the schema's default."""
    with open(profile, "rb") as f:
        table = tomllib.load(f).get(section, {})
    defaults = {s["key"]: s["default"] for s in trellis.settings()}
    return lambda key: float(table.get(key, defaults[f"{section}.{key}"]))


def read_back(path):
    """The G-code read back into design coordinates, and its analysis."""
    return trellis.read_toolpath(path), trellis.analyze(path)


@pytest.mark.parametrize("profile", PROFILES, ids=[os.path.basename(p)[:-5] for p in PROFILES])
def test_numpy_designs_print_on_every_machine_profile(tmp_path, profile):
    vase = trellis.Toolpath.from_arrays(spiral_vase(), height=0.2, role="perimeter")
    pts, offs = sine_wave()
    wave = trellis.Toolpath.from_arrays(pts, offs, height=0.25, role="infill")
    if is_laser(profile):
        # A laser powder bed melts planar layers: the G-code route refuses its profile.
        with pytest.raises(trellis.TrellisError) as e:
            trellis.gcode(vase, tmp_path / "vase.gcode", machine=profile)
        assert "laser" in str(e.value).lower() or ".cli" in str(e.value)
        assert not os.path.exists(tmp_path / "vase.gcode")
        return
    for name, tp, points, offsets, height in (("vase", vase, spiral_vase(), [0, len(spiral_vase())], 0.2),
                                              ("wave", wave, pts, offs, 0.25)):
        out = tmp_path / f"{name}.gcode"
        trellis.gcode(tp, out, machine=profile)
        back, a = read_back(out)
        length = design_length(points, offsets)
        assert math.isclose(back.extrusion_length, length, rel_tol=2e-3), (name, back.extrusion_length, length)
        if a["filament_mm"] > 0:  # analyze without a machine reads E; a valve machine's G-code has none
            assert math.isclose(a["extruded_length_mm"], length, rel_tol=2e-3)
        # Every design point is a vertex of the print (the writer may split a path, not drop points).
        assert len(points) <= back.point_count <= len(points) + 4 * len(offsets), (back.point_count, len(points))
        # The read-back path stays within G-code rounding (3 decimals) of the design's box.
        lo, hi = points.min(axis=0), points.max(axis=0)
        assert np.all(back.points >= lo - 2e-3) and np.all(back.points <= hi + 2e-3)
        if a["filament_mm"] > 0:  # extruders: E as Eq. 4 asks for the design's length and height
            e = profile_value(profile, "extrusion")
            per_mm = (e("k") * 4 * height * e("multiplier") * e("nozzle_diameter")
                      / (math.pi * e("filament_diameter") ** 2))
            assert math.isclose(a["filament_mm"], per_mm * length, rel_tol=0.02), (a["filament_mm"], per_mm * length)
        # Objects all the way: the output reruns from the design written beside it.
        sidecar = tmp_path / f"{name}.gcode.toolpath.json"
        assert sidecar.exists()
        trellis.rerun(out, tmp_path / f"{name}_again.gcode")
        assert filecmp.cmp(out, tmp_path / f"{name}_again.gcode", shallow=False)


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """tempfile's folder, private to the test: what a call leaves there can be seen and deleted."""
    d = tmp_path / "tmp"
    d.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(d))
    return d


def test_outputs_made_from_objects_rerun_to_the_same_bytes(tmp_path, private_tmp):
    out = tmp_path / "out"
    out.mkdir()
    lat = trellis.lattice2d(pattern="penrose", cell=1.2, size=(8, 8)).lattice
    trellis.plan("euler", lat, out / "p.json", machine=ENDER, gcode=out / "p.gcode")
    part = trellis.difference(trellis.rectprism(12, 10, 2), trellis.cylinder(2.5, 10))
    trellis.slice(part, out / "s.gcode", machine=ENDER, strategy="none")
    graded = trellis.fgrade(["0.5 + x/24", "0.5 - x/24"], ["a", "b"], trellis.rectprism(20, 10, 0.6))
    trellis.slice(graded, out / "g.gcode", machine=MIXING, strategy=2, colors=4)
    trellis.pbf(out / "b.cli", envelope=trellis.cylinder(1.5, 0.4), machine=LASER, size=(2.5, 2.5, 0.4))
    tp = trellis.Toolpath.from_arrays(spiral_vase(turns=4), height=0.2)
    trellis.gcode(tp, out / "v.gcode", machine=ENDER)
    # The designs are beside their outputs; nothing stays in the temporary folder.
    assert sorted(os.listdir(private_tmp)) == []
    for name in ("p.json.lattice.json", "s.gcode.design.vcad", "g.gcode.design.vcad",
                 "b.cli.design.vcad", "v.gcode.toolpath.json"):
        assert (out / name).exists(), name
    for made in ("p.json", "p.gcode", "s.gcode", "g.gcode", "b.cli", "v.gcode"):
        again = out / ("again_" + made)  # in the same folder: the job names the design relative to it
        trellis.rerun(out / made, again)
        assert filecmp.cmp(out / made, again, shallow=False), made
    # The whole folder moved elsewhere still reruns (the job names the design relative to it).
    os.rename(out, tmp_path / "moved")
    trellis.rerun(tmp_path / "moved" / "v.gcode", tmp_path / "moved" / "v2.gcode")
    assert filecmp.cmp(tmp_path / "moved" / "v.gcode", tmp_path / "moved" / "v2.gcode", shallow=False)


def test_a_mesh_object_is_a_mesh_file(tmp_path):
    """A ``Mesh`` goes where a mesh file goes: nonplanar's surface and slice's design, the same
    paths as from the file, and the output reruns from the mesh written beside it."""
    n = 25
    x, y = np.meshgrid(np.linspace(0, 24, n), np.linspace(0, 12, n // 2 + 1))
    z = 1.5 * np.sin(x / 24 * 2 * np.pi)
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    faces = []
    rows, cols = x.shape
    for r in range(rows - 1):
        for c in range(cols - 1):
            a = r * cols + c
            faces += [(a, a + 1, a + cols + 1), (a, a + cols + 1, a + cols)]
    surface = trellis.Mesh(vertices, np.array(faces))
    fresh = os.path.join(ROOT, "profiles", "fresh_nonplanar_2syringe.toml")
    a = trellis.nonplanar(surface, tmp_path / "a.gcode", machine=fresh, layers=2)
    assert (tmp_path / "a.gcode.mesh.obj").exists()
    with open(tmp_path / "s.obj", "w") as f:
        f.write(surface.obj_text())
    b = trellis.nonplanar(str(tmp_path / "s.obj"), tmp_path / "b.gcode", machine=fresh, layers=2)
    assert a.toolpath.path_count == b.toolpath.path_count > 0
    assert a.toolpath.point_count == b.toolpath.point_count
    trellis.rerun(tmp_path / "a.gcode", tmp_path / "again.gcode")
    assert filecmp.cmp(tmp_path / "a.gcode", tmp_path / "again.gcode", shallow=False)
    # A closed mesh from a field slices like its file.
    box = trellis.rectprism(10, 8, 2).mesh(0.25)
    s = trellis.slice(box, tmp_path / "box.gcode", machine=ENDER, strategy="none")
    assert s.toolpath.path_count > 0 and (tmp_path / "box.gcode.mesh.obj").exists()


def test_a_failed_call_leaves_no_design_behind(tmp_path, private_tmp):
    tp = trellis.Toolpath.from_arrays(spiral_vase(radius=400.0, turns=2), height=0.2)  # beyond the bed
    with pytest.raises(trellis.MachineError):
        trellis.gcode(tp, tmp_path / "big.gcode", machine=ENDER)
    assert os.listdir(tmp_path) == ["tmp"] and os.listdir(private_tmp) == []
    # Without an output file the design goes to a temporary file, removed after the call.
    assert trellis.gcode(tp, machine=ENDER).toolpath.point_count == tp.point_count
    assert os.listdir(private_tmp) == []


def test_check_and_analyze_take_objects(tmp_path):
    cells = trellis.lattice3d(cell_type="octet", cell=7, count=(2, 2, 1))
    planned = trellis.plan("aero", cells.lattice, tmp_path / "o.json", machine=BATH, gcode=tmp_path / "o.nc")
    trellis.lattice3d(tmp_path / "octet.json", cell_type="octet", cell=7, count=(2, 2, 1))
    from_files = trellis.check(tmp_path / "octet.json", tmp_path / "o.nc")
    from_objects = trellis.check(cells.lattice, planned.toolpath)
    assert from_objects["collisions"] == from_files["collisions"] == 0
    assert from_objects["struts_printed_once"] == from_files["struts_printed_once"] == from_objects["struts"] > 0
    mixed = trellis.check(cells.lattice, tmp_path / "o.nc")
    assert mixed["struts_printed_once"] == from_files["struts_printed_once"]
    with pytest.raises(TypeError):
        trellis.check(planned.toolpath, cells.lattice)
    lat = trellis.lattice2d(pattern="snub-square", cell=1.2, size=(10, 10)).lattice
    r = trellis.plan("euler", lat, machine=ENDER, gcode=tmp_path / "p.gcode", center=True)
    on_file = trellis.analyze(tmp_path / "p.gcode", lat, align=True)
    planned = trellis.analyze(r.toolpath, lat)
    assert on_file["missing_edges"] == planned["missing_edges"] == 0
    assert math.isclose(planned["extruded_length_mm"], lat.total_length, rel_tol=1e-9)
    assert math.isclose(on_file["extruded_length_mm"], planned["extruded_length_mm"], rel_tol=2e-3)


def test_a_machine_profile_as_a_dict_is_the_profile(tmp_path, private_tmp):
    with open(ENDER, "rb") as f:
        profile = tomllib.load(f)
    tp = trellis.Toolpath.from_arrays(spiral_vase(turns=3), height=0.2)
    trellis.gcode(tp, tmp_path / "file.gcode", machine=ENDER)
    trellis.gcode(tp, tmp_path / "dict.gcode", machine=profile)
    # The same G-code; the job in the header names the profile and the design it was given.
    header = ("; job: machine =", "; job: input =")
    body = lambda p: [line for line in p.read_text().splitlines() if not line.startswith(header)]
    assert body(tmp_path / "file.gcode") == body(tmp_path / "dict.gcode")
    assert (tmp_path / "dict.gcode.machine.toml").exists()  # beside the output, for rerun
    trellis.rerun(tmp_path / "dict.gcode", tmp_path / "again.gcode")
    assert filecmp.cmp(tmp_path / "dict.gcode", tmp_path / "again.gcode", shallow=False)
    assert tp.gcode(machine=profile) == tp.gcode(machine=ENDER)
    lat = trellis.lattice3d(cell_type="octet", cell=7, count=(1, 1, 1)).lattice
    planned = trellis.plan("aero", lat, machine=BATH).toolpath
    with open(BATH, "rb") as f:
        assert trellis.check(lat, planned, machine=tomllib.load(f)) == trellis.check(lat, planned, machine=BATH)
    assert os.listdir(private_tmp) == []
