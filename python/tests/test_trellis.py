"""The Python door: every route as a call, the same files as the CLI, numpy in and out, errors
mapped with their place, long calls interruptible."""
import filecmp
import json
import math
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import trellis

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("TRELLIS_CLI", "trellis")
ENDER = os.path.join(ROOT, "profiles", "ender3_s1_pro_tpu.toml")
BATH = os.path.join(ROOT, "profiles", "embedded_aero_410um.toml")
FRESH = os.path.join(ROOT, "profiles", "fresh_nonplanar_2syringe.toml")
LASER = os.path.join(ROOT, "profiles", "pbf_316l_25um.toml")
MIXING = os.path.join(ROOT, "profiles", "geeetech_mizar_m_mixing.toml")


def cli(*args, cwd=None):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True, cwd=cwd)
    assert r.returncode == 0, r.stderr
    return r


def test_version_and_settings_come_from_the_library():
    assert trellis.__version__.count(".") == 2
    keys = {s["key"] for s in trellis.settings()}
    assert "extrusion.layer_height" in keys and "pbf.cell_type" in keys
    slice_keys = {s["key"] for s in trellis.settings("slice")}
    assert "slice.walls" in slice_keys and "pbf.cell" not in slice_keys


# Each route through Python writes exactly the bytes the CLI writes with the same settings.
CASES = [
    ("lattice2d", lambda out: trellis.lattice2d(out, pattern="voronoi", density=2, seed=3, size=(6, 6)),
     ["lattice2d", "--pattern", "voronoi", "--density", "2", "--seed", "3", "--size", "6,6"]),
    ("lattice3d", lambda out: trellis.lattice3d(out, cell_type="bcc", cell=5, count=(2, 2, 1)),
     ["lattice3d", "--cell-type", "bcc", "--cell", "5", "--count", "2,2,1"]),
    ("slice", lambda out: trellis.slice(os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), out,
                                        machine=ENDER, walls=3, infill=0.3, strategy="none"),
     ["slice", os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), "--machine", ENDER,
      "--walls", "3", "--infill", "0.3", "--strategy", "none"]),
    ("slice_graded", lambda out: trellis.slice(os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), out,
                                               machine=MIXING, strategy=2, colors=4),
     ["slice", os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), "--machine", MIXING,
      "--strategy", "2", "--colors", "4"]),
    ("pbf", lambda out: trellis.pbf(out, machine=LASER, size=(2.5, 2.5, 0.5), cell_type="schwarz_d"),
     ["pbf", "--machine", LASER, "--size", "2.5,2.5,0.5", "--cell-type", "schwarz_d"]),
    ("nonplanar", lambda out: trellis.nonplanar(None, out, machine=FRESH, height_fn="0.2*x", domain=(0, 0, 8, 4),
                                                layers=2),
     ["nonplanar", "--machine", FRESH, "--height-fn", "0.2*x", "--domain", "0,0,8,4", "--layers", "2"]),
    ("surface", lambda out: trellis.surface("miura", out, depth=2),
     ["surface", "miura", "--depth", "2"]),
]
EXT = {"lattice2d": ".json", "lattice3d": ".json", "slice": ".gcode", "slice_graded": ".gcode",
       "pbf": ".cli", "nonplanar": ".gcode", "surface": ".stl"}


@pytest.mark.parametrize("name,call,args", CASES, ids=[c[0] for c in CASES])
def test_python_writes_the_same_bytes_as_the_cli(tmp_path, name, call, args):
    py_out = tmp_path / "py" / ("out" + EXT[name])
    cli_out = tmp_path / "cli" / ("out" + EXT[name])
    py_out.parent.mkdir()
    cli_out.parent.mkdir()
    call(str(py_out))
    cli(*args, "-o", cli_out)
    assert filecmp.cmp(py_out, cli_out, shallow=False)


def test_plan_routes_same_bytes_and_in_memory_results(tmp_path):
    lat = trellis.lattice2d(tmp_path / "l.json", pattern="penrose", cell=1.2, size=(8, 8))
    assert lat.lattice.edge_count > 50
    for planner in ("gippo", "euler"):
        r = trellis.plan(planner, tmp_path / "l.json", tmp_path / f"{planner}.json", machine=ENDER,
                         gcode=tmp_path / f"{planner}.gcode", iterations=20) if planner == "gippo" else \
            trellis.plan(planner, tmp_path / "l.json", tmp_path / f"{planner}.json", machine=ENDER,
                         gcode=tmp_path / f"{planner}.gcode")
        extra = ["--iterations", "20"] if planner == "gippo" else []
        cli("plan", planner, tmp_path / "l.json", "-o", tmp_path / f"c_{planner}.json", "--machine", ENDER,
            "--gcode", tmp_path / f"c_{planner}.gcode", *extra)
        assert filecmp.cmp(tmp_path / f"{planner}.gcode", tmp_path / f"c_{planner}.gcode", shallow=False)
        assert filecmp.cmp(tmp_path / f"{planner}.json", tmp_path / f"c_{planner}.json", shallow=False)
        # The gcode route from the toolpath file, both ways.
        trellis.gcode(tmp_path / f"{planner}.json", tmp_path / f"g_{planner}.nc", machine=BATH)
        cli("gcode", tmp_path / f"{planner}.json", "--machine", BATH, "-o", tmp_path / f"cg_{planner}.nc")
        assert filecmp.cmp(tmp_path / f"g_{planner}.nc", tmp_path / f"cg_{planner}.nc", shallow=False)
        tp = r.toolpath
        # Every strut once: the path lengths add up to the lattice's length.
        seg = np.diff(tp.points, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        inside = np.ones(len(lengths), bool)
        inside[tp.path_offsets[1:-1] - 1] = False  # no segment between two paths
        assert abs(lengths[inside].sum() - lat.lattice.total_length) < 1e-6
    # A Lattice object straight in; AERO on a 3D lattice with its independent check.
    cells = trellis.lattice3d(cell_type="octet", cell=7, count=(2, 2, 1)).lattice
    r = trellis.plan("aero", cells, machine=BATH, gcode=tmp_path / "octet.nc")
    assert "collisions 0" in r.summary
    assert r.toolpath.path_count > 0 and (tmp_path / "octet.nc").exists()


def test_lattices_from_numpy_and_bad_arrays_name_the_argument():
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    lat = trellis.Lattice.from_arrays(nodes, edges, material=[0, 0, 1, 1])
    assert np.array_equal(lat.nodes, nodes) and np.array_equal(lat.edges, edges)
    assert list(lat.material) == [0, 0, 1, 1]
    r = trellis.plan("euler", lat)
    assert r.toolpath.path_count == 2  # two materials, one closed loop each part
    cases = [
        (lambda: trellis.Lattice.from_arrays(nodes[:, :2], edges), "nodes"),
        (lambda: trellis.Lattice.from_arrays(nodes, edges[:, :1]), "edges"),
        (lambda: trellis.Lattice.from_arrays(nodes, edges.astype(float)), "edges"),
        (lambda: trellis.Lattice.from_arrays(nodes, np.array([[0, 7]])), "edges[0]"),
        (lambda: trellis.Lattice.from_arrays(np.array([[0, 0, np.nan]]), np.zeros((0, 2), int)), "nodes[0]"),
        (lambda: trellis.Lattice.from_arrays(nodes, edges, material=[0]), "material"),
        # What the file readers refuse: no struts, materials beyond 0..255, coordinates beyond
        # ±1e6 mm, node indices far out of range.
        (lambda: trellis.Lattice.from_arrays(np.zeros((0, 3)), np.zeros((0, 2), int)), "nodes"),
        (lambda: trellis.Lattice.from_arrays(nodes, np.zeros((0, 2), int)), "edges"),
        (lambda: trellis.Lattice.from_arrays(nodes, edges, material=[0, 300, 0, 0]), "material[1]"),
        (lambda: trellis.Lattice.from_arrays(nodes, edges, material=[0, 0, -1, 0]), "material[2]"),
        (lambda: trellis.Lattice.from_arrays(nodes, edges, material=[0, 0.5, 0, 0]), "material"),
        (lambda: trellis.Lattice.from_arrays(nodes * [1, 1e300, 1], edges), "nodes[2]"),
        (lambda: trellis.Lattice.from_arrays(nodes, np.array([[0, 2**62]])), "edges[0]"),
        (lambda: trellis.Lattice.from_arrays(nodes, np.array([[0, 2**64 - 1]], np.uint64)), "edges[0]"),
    ]
    for fn, element in cases:
        with pytest.raises(trellis.SettingError) as e:
            fn()
        assert e.value.element == element, (element, e.value)


def _created_in(folder, fn):
    """The entries (name, is a folder) created directly in `folder` while fn() runs (inotify)."""
    import ctypes
    import struct
    libc = ctypes.CDLL(None, use_errno=True)
    fd = libc.inotify_init1(os.O_NONBLOCK)
    assert fd >= 0
    try:
        assert libc.inotify_add_watch(fd, os.fsencode(folder), 0x100) >= 0  # IN_CREATE
        result = fn()
        assert result
        data = b""
        while True:
            try:
                chunk = os.read(fd, 65536)
            except BlockingIOError:
                break
            if not chunk:
                break
            data += chunk
        created, at = [], 0
        while at < len(data):
            _, mask, _, size = struct.unpack_from("iIII", data, at)
            name = data[at + 16:at + 16 + size].rstrip(b"\0").decode()
            created.append((name, bool(mask & 0x40000000)))  # IN_ISDIR
            at += 16 + size
        return created
    finally:
        os.close(fd)


def test_python_values_reach_files_only_through_escaping_writers(tmp_path, monkeypatch):
    # Fields: a string where a number goes, a non-finite number, a string holding '"' (a .vcad
    # string has no escapes) or a non-field in an operation never reach the .vcad text.
    hostile = [
        (lambda: trellis.sphere('1); mesh("/etc/passwd"); sphere(2'), TypeError),
        (lambda: trellis.rectprism(1, "2", 3), TypeError),
        (lambda: trellis.sphere(float("nan")), ValueError),
        (lambda: trellis.sphere(1).translate(0, float("inf"), 0), ValueError),
        (lambda: trellis.sphere(1, material='a"); mesh("/etc/passwd'), ValueError),
        (lambda: trellis.gyroid(2.5, c='0"); mesh("/etc/passwd'), ValueError),
        (lambda: trellis.fgrade(['1"); mesh("/etc/passwd'], ["a"], trellis.cube(2)), ValueError),
        (lambda: trellis.union(-1), TypeError),
        (lambda: trellis.union(trellis.cube(1), "mesh(\"/etc/passwd\");"), TypeError),
        (lambda: trellis.sphere(True), TypeError),
    ]
    for fn, kind in hostile:
        with pytest.raises(kind):
            fn()
    assert trellis.cube(np.float64(2.5)).vcad() == "cube(2.5);\n"
    assert trellis.cube(np.int64(3), material="m1").vcad() == 'cube(3, "m1");\n'
    # Job dicts: keys and values that would start a table or a key of their own are escaped, so
    # the TOML reads back as the dict it came from, and the job names the key it was given.
    import tomllib
    job = {"job": {"route": "lattice2d", "name": 'd"\n[output]\npng = true\n\\', "a=b": 1},
           "out put": {'png = true\n[lattice2d]\ncell': False, "x\x01": [1.5, "y\"z"]},
           "part": [{"input": "p.vcad", "machine": {"bed x": 3}}, {"input": "q\\"}]}
    assert tomllib.loads(trellis._toml(job)) == job
    out = tmp_path / "job"
    with pytest.raises(trellis.TrellisError) as e:
        trellis.run_job({"job": {"route": "lattice2d", "name": "d", "output_dir": str(out)},
                         "output": {'png = true\n[lattice2d]\ncell': False}})
    assert "png = true" in str(e.value), e.value
    assert not out.exists()
    r = trellis.run_job({"job": {"route": "lattice2d", "name": "d", "output_dir": str(out)},
                         "lattice2d": {"pattern": "penrose", "cell": np.float64(1.5), "size": (10, 10)},
                         "output": {"png": False}})
    assert r.lattice.edge_count > 0
    # Toolpath.png: rendered in a private folder, not a predictable /tmp/trellis_py_<address>.png
    # (a planted symbolic link there would be written through), and the folder removed.
    tp = trellis.plan("euler", trellis.lattice2d(pattern="square", cell=2, size=(6, 6)).lattice).toolpath
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    created = _created_in(tmp, lambda: tp.png(0, 64))
    assert created and all(is_dir and name.startswith("trellis_png_") and name != "trellis_png_XXXXXX"
                           for name, is_dir in created), created
    assert os.listdir(tmp) == []
    with pytest.raises(trellis.SettingError) as e:
        tp.png(0, 10**6)
    assert e.value.element == "size"


def test_python_integers_beyond_a_setting_raise_a_setting_error(tmp_path):
    lat = trellis.lattice2d(pattern="honeycomb", cell=1, size=(5, 5)).lattice
    for value in (2**70, -2**70):
        with pytest.raises(trellis.SettingError) as e:
            trellis.plan("gippo", lat, iterations=value)
        assert e.value.element == "gippo.iterations" and "beyond" in str(e.value)
    with pytest.raises(trellis.SettingError) as e:
        trellis.plan("gippo", lat, iterations=np.int64(10**8))  # numpy integers are integers
    assert e.value.element == "gippo.iterations"


def test_bad_keywords_and_values_raise_mapped_errors():
    with pytest.raises(trellis.SettingError) as e:
        trellis.lattice2d(patern="honeycomb")
    assert e.value.element == "patern" and "pattern" in str(e.value)
    with pytest.raises(trellis.SettingError) as e:
        trellis.lattice2d(cell=-1)
    assert "lattice2d.cell" in e.value.element and "out of range" in str(e.value)
    with pytest.raises(trellis.SettingError) as e:
        trellis.lattice2d(pattern="hexagons")
    assert "one of honeycomb" in str(e.value)
    with pytest.raises(trellis.SettingError):
        trellis.lattice2d(cell="big")
    with pytest.raises(trellis.SettingError):
        trellis.lattice3d(count=(2, 2))
    with pytest.raises(trellis.SettingError) as e:
        trellis.lattice2d(set={"slice.walls": 3})
    assert "does not read" in str(e.value)
    with pytest.raises(trellis.InputError) as e:
        trellis.read_lattice(os.path.join(ROOT, "examples/designs/csg_bracket.vcad"))
    assert e.value.file.endswith("csg_bracket.vcad")
    with pytest.raises(trellis.InputError) as e:
        trellis.slice("/nonexistent.vcad", machine=ENDER)
    # Precision kept: a tiny k reaches the writer as written.
    tp = trellis.plan("euler", trellis.lattice2d(pattern="square", size=(3, 3)).lattice).toolpath
    text = tp.gcode(machine=ENDER, set={"extrusion.k": 4e-7})
    assert "M82" in text or "M83" in text


def test_a_million_points_as_one_array_quickly():
    # A 1,000,000-point toolpath: a dense 3D lattice's Euler plan, then read as numpy.
    r = trellis.plan("euler", trellis.lattice3d(cell_type="cubic", cell=1, count=(66, 66, 80)).lattice)
    tp = r.toolpath
    assert tp.point_count >= 1_000_000, tp.point_count
    t0 = time.perf_counter()
    pts = tp.points
    elapsed = time.perf_counter() - t0
    assert pts.shape == (tp.point_count, 3) and pts.dtype == np.float64
    assert elapsed < 0.05, elapsed


def test_progress_reaches_python_and_ctrl_c_cancels_within_a_second():
    seen = []
    trellis.plan("gippo", trellis.lattice2d(pattern="voronoi", density=3, size=(10, 10)).lattice,
                 iterations=300, progress=lambda stage, f: seen.append((stage, f)))
    assert seen and all(0 <= f <= 1 for _, f in seen)
    # A long GIPPO run interrupted by SIGINT from a timer thread.
    lat = trellis.lattice2d(pattern="voronoi", density=4, size=(30, 30)).lattice
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        trellis.plan("gippo", lat, iterations=10_000_000, force=True)  # beyond the time budget on purpose
    assert time.perf_counter() - t0 < 1.5
    timer.join()
    # And a long PBF run.
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        trellis.pbf(size=(20, 20, 20), resolution=0.01, force=True)
    assert time.perf_counter() - t0 < 1.5
    timer.join()


def test_jobs_from_files_and_dicts(tmp_path):
    r = trellis.run_job(os.path.join(ROOT, "examples/jobs/penrose_lattice.toml"), output_dir=tmp_path / "a",
                        set={"lattice2d.cell": 1.5})
    assert r.lattice is not None and any(f.endswith(".lattice.json") for f in r.files)
    r2 = trellis.run_job({"job": {"route": "lattice2d", "name": "d", "output_dir": str(tmp_path / "b")},
                          "lattice2d": {"pattern": "penrose", "cell": 1.5, "size": [10.0, 10.0]},
                          "output": {"png": False}})
    assert r2.lattice.edge_count == r.lattice.edge_count
    # rerun of a file made from Python: the same bytes.
    out = tmp_path / "s.gcode"
    trellis.slice(os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), out, machine=ENDER,
                  strategy="none")
    trellis.rerun(out, tmp_path / "again.gcode")
    assert filecmp.cmp(out, tmp_path / "again.gcode", shallow=False)


def test_readers_and_pictures(tmp_path):
    r = trellis.slice(os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), tmp_path / "p.gcode",
                      machine=ENDER, toolpath=tmp_path / "p.json", strategy="none")
    back = trellis.read_toolpath(tmp_path / "p.json")
    assert back.point_count == r.toolpath.point_count
    g = trellis.read_toolpath(tmp_path / "p.gcode")
    assert g.layer_count == r.toolpath.layer_count
    laser = trellis.pbf(tmp_path / "g.cli", size=(2.5, 2.5, 0.3))
    cli_back = trellis.read_toolpath(tmp_path / "g.cli")
    assert cli_back.layer_count == laser.toolpath.layer_count
    assert np.allclose(cli_back.points, laser.toolpath.points, atol=1e-5)
    # The same geometry as the file written by the route (whose header also carries the job).
    geometry = lambda b: b[b.index(b"$$HEADEREND"):]
    assert geometry(laser.toolpath.cli()) == geometry((tmp_path / "g.cli").read_bytes())
    assert b"$$BINARY" in laser.toolpath.cli(binary=True)
    png = r.toolpath._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_fields_built_in_python_slice_like_their_vcad_file(tmp_path):
    part = trellis.difference(
        trellis.union(trellis.rectprism(40, 30, 10), trellis.cylinder(10, 10).translate(0, 0, 8), blend=2),
        trellis.cylinder(5, 40),
        trellis.torus(10, 1.5).translate(0, 0, 12),
        trellis.cylinder(2.5, 40).rotate(90, 0, 0))
    assert "union(2)" in part.vcad() and "rotate(90, 0, 0)" in part.vcad()
    a = trellis.slice(part, machine=ENDER).toolpath
    b = trellis.slice(os.path.join(ROOT, "examples/designs/csg_bracket.vcad"), machine=ENDER).toolpath
    assert a.path_count == b.path_count
    assert np.allclose(a.points, b.points)
    graded = trellis.fgrade(["0.5 + x/24", "0.5 - x/24"], ["a", "b"], trellis.rectprism(20, 10, 0.6))
    r = trellis.slice(graded, machine=MIXING, strategy=2, colors=4)
    assert len(np.unique(r.toolpath.mixture.round(4), axis=0)) == 4
    with pytest.raises(trellis.InputError) as e:
        trellis.parse_vcad("union() {\n  spere(2);\n}\n")
    assert e.value.line == 2
    with pytest.raises(trellis.SettingError):
        trellis.tpms("gyriod", 2.5)


def test_analysis_and_check_as_dicts(tmp_path):
    lat = tmp_path / "l.json"
    trellis.lattice2d(lat, pattern="snub-square", cell=1.2, size=(10, 10))
    trellis.plan("euler", lat, tmp_path / "p.json", machine=ENDER, gcode=tmp_path / "p.gcode", center=True)
    a = trellis.analyze(tmp_path / "p.gcode", lat, align=True)
    assert a["missing_edges"] == 0 and abs(a["extrusion_ratio"] - 1) < 2e-3
    cells = tmp_path / "octet.json"
    trellis.lattice3d(cells, cell_type="octet", cell=7, count=(2, 2, 1))
    trellis.plan("aero", cells, tmp_path / "o.json", machine=BATH, gcode=tmp_path / "o.nc")
    c = trellis.check(cells, tmp_path / "o.nc")
    assert c["collisions"] == 0 and c["struts_printed_once"] == c["struts"] > 0


def test_machine_errors_write_nothing(tmp_path):
    # A graded design with Strategy 2 on the single-nozzle Ender: no mixing hotend.
    out = tmp_path / "g.gcode"
    with pytest.raises(trellis.MachineError) as e:
        trellis.slice(os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), out,
                      machine=ENDER, strategy=2, colors=4)
    assert "mixing" in str(e.value)
    assert not out.exists()
    # A part bigger than the bed.
    with pytest.raises(trellis.MachineError) as e:
        trellis.slice(os.path.join(ROOT, "examples/designs/fgm_column2_plate.vcad"), out,
                      machine=ENDER, strategy="none", set={"machine.bed_x": 5})
    assert "machine.bed_x" in str(e.value)
    assert not out.exists()


def test_graded_report_gives_material_and_time_per_colour(tmp_path):
    # §4.1 of the FGM paper reports material and time per colour. The report's part colours are
    # checked against the G-code read back: the same mixtures, the same total length, and their
    # volume against the filament the G-code extrudes. (Per colour, lengths differ: the first
    # 960 mm of path -- the look-ahead that flushes the mixer -- are deposited in one mixture;
    # the look-ahead replay is tests/slice/test_fgm.cpp's and tests/machine/test_mixing_lag.cpp's.)
    graded = trellis.fgrade(["0.5 + x/24", "0.5 - x/24"], ["a", "b"], trellis.rectprism(20, 10, 0.6))
    trellis.slice(graded, tmp_path / "g.gcode", machine=MIXING, strategy=2, colors=4,
                  report=tmp_path / "g.json")
    report = json.loads((tmp_path / "g.json").read_text())
    colours = report["fgm"]["part_colours"]
    assert len(colours) == 4
    back = trellis.read_toolpath(tmp_path / "g.gcode")
    points, offsets = back.points, back.path_offsets
    printed = {}
    for i in range(back.path_count):
        p = points[offsets[i]:offsets[i + 1]]
        key = tuple(np.round(back.mixture[i], 4))
        printed[key] = printed.get(key, 0.0) + float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
    assert set(printed) == {tuple(np.round(c["mixture"], 4)) for c in colours}
    assert sum(printed.values()) == pytest.approx(sum(c["length_mm"] for c in colours), rel=1e-3)
    for c in colours:
        assert c["mass_g"] > 0 and c["time_s"] > 0
    filament_volume = report["gcode"]["filament_mm"] * math.pi * 1.75 ** 2 / 4
    assert sum(c["volume_mm3"] for c in colours) == pytest.approx(filament_volume, rel=0.01)
    assert report["fgm"]["part_mass_g"] == pytest.approx(sum(c["mass_g"] for c in colours))
    # Read as deposited (the default) or as commanded: the same print, and analyze counts the
    # IR paths of the same reading.
    commanded = trellis.read_toolpath(tmp_path / "g.gcode", commanded_mixtures=True)
    assert commanded.extrusion_length == pytest.approx(back.extrusion_length, rel=1e-9)
    assert trellis.analyze(tmp_path / "g.gcode")["toolpath_paths"] == back.path_count
    assert trellis.analyze(tmp_path / "g.gcode", commanded_mixtures=True)["toolpath_paths"] == \
        commanded.path_count


def test_library_errors_name_setting_keys_not_flags(tmp_path):
    # A pbf cell finer than 8 x pbf.resolution: the library names the key (the keyword is named
    # after it); the command line shows "--resolution (pbf.resolution)" for the same error.
    out = tmp_path / "fine.cli"
    with pytest.raises(trellis.SettingError) as e:
        trellis.pbf(str(out), cell=0.05)
    assert "lower pbf.resolution" in str(e.value), e.value
    assert "--" not in str(e.value), e.value
    assert not out.exists()


def test_lasers_that_differ_in_every_format(tmp_path):
    """Toolpath.lasers: the profile's lasers (skywriting per laser too) on the route's toolpath,
    and read back equal from the toolpath JSON, the .cli and the 3MF."""
    unequal = os.path.join(ROOT, "profiles", "pbf_316l_2laser_unequal.toml")
    r = trellis.pbf(tmp_path / "u.cli", machine=unequal, size=(5, 5, 0.2), toolpath=tmp_path / "u.json",
                    set={"lasers.skywriting": [False, True], "lasers.skywriting_time": [120, 180]})
    lasers = r.toolpath.lasers
    assert len(lasers) == 2
    assert [l["hatch_power"] for l in lasers] == [150, 100]
    assert [l["mark_delay"] for l in lasers] == [80, 100]
    assert [l["skywriting"] for l in lasers] == [False, True]
    assert [l["skywriting_time"] for l in lasers] == [120, 180]
    trellis.pbf(tmp_path / "u.3mf", machine=unequal, size=(5, 5, 0.2),
                set={"lasers.skywriting": [False, True], "lasers.skywriting_time": [120, 180]})
    for name in ("u.json", "u.cli", "u.3mf"):
        assert trellis.read_toolpath(tmp_path / name).lasers == lasers, name
    # One laser: nothing declared.
    assert trellis.pbf(size=(2.5, 2.5, 0.2)).toolpath.lasers == []
