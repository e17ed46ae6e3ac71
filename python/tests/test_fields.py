"""Fields you can probe: evaluate, sample, bounds and mesh through the kernel the slicer uses."""
import os
import signal
import threading
import time

import numpy as np
import pytest

import trellis

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


def test_sphere_distance_is_the_analytic_distance():
    rng = np.random.default_rng(7)
    centre = np.array([3.0, -2.0, 5.0])
    f = trellis.sphere(8).translate(*centre)
    pts = rng.uniform(-20, 20, (5000, 3))
    out = f.evaluate(pts)
    assert out["distance"].shape == (5000,) and out["fractions"].shape == (5000, 0)
    assert np.allclose(out["distance"], np.linalg.norm(pts - centre, axis=1) - 8, atol=1e-9)
    lo, hi = f.bounds()
    assert np.allclose(lo, centre - 8) and np.allclose(hi, centre + 8)


def test_graded_fractions_sum_to_one_and_follow_their_expressions():
    body = trellis.rectprism(20, 10, 4)
    f = trellis.fgrade(["0.5 + x/40", "0.5 - x/40"], ["a", "b"], body)
    assert f.materials == ["a", "b"]
    rng = np.random.default_rng(1)
    pts = rng.uniform([-10, -5, -2], [10, 5, 2], (2000, 3))
    out = f.evaluate(pts)
    assert out["fractions"].shape == (2000, 2)
    assert np.allclose(out["fractions"].sum(axis=1), 1.0)
    assert np.allclose(out["fractions"][:, 0], 0.5 + pts[:, 0] / 40)
    assert np.all(out["distance"] <= 1e-12)  # every point inside the box


def test_sample_equals_evaluate_at_the_grid_points():
    f = trellis.fgrade(["0.5 + x/40", "0.5 - x/40"], ["a", "b"],
                       trellis.union(trellis.gyroid(4) & trellis.cube(12), trellis.sphere(3)))
    g = f.sample(0.7, box=((-6, -6, -6), (6, 5, 4)))
    nx, ny, nz = len(g["x"]), len(g["y"]), len(g["z"])
    assert g["distance"].shape == (nx, ny, nz) and g["fractions"].shape == (nx, ny, nz, 2)
    assert (nx, ny, nz) == (int(12 / 0.7) + 1, int(11 / 0.7) + 1, int(10 / 0.7) + 1)
    assert np.allclose(g["x"], -6 + 0.7 * np.arange(nx))
    X, Y, Z = np.meshgrid(g["x"], g["y"], g["z"], indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    e = f.evaluate(pts)
    assert np.allclose(g["distance"].ravel(), e["distance"], rtol=0, atol=1e-12)
    assert np.array_equal(g["fractions"].reshape(-1, 2), e["fractions"])
    # The default box is the design's bounds; an unbounded design asks for one.
    assert trellis.sphere(2).sample(0.5)["distance"].shape == (9, 9, 9)
    with pytest.raises(trellis.SettingError):
        trellis.gyroid(4).sample(0.5)


def test_sphere_mesh_is_closed_on_the_sphere_with_its_volume(tmp_path):
    r, step = 6.0, 0.25
    m = trellis.sphere(r).translate(1, 2, 3).mesh(step, stl=tmp_path / "s.stl")
    v, faces = m.vertices, m.faces
    assert v.shape[1] == 3 and faces.shape[1] == 3 and len(faces) > 1000
    assert np.all(np.abs(np.linalg.norm(v - [1, 2, 3], axis=1) - r) < step)
    assert abs(m.volume() - 4 / 3 * np.pi * r ** 3) / (4 / 3 * np.pi * r ** 3) < 0.02
    # Closed: every edge in exactly two faces, once each way.
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    directed = {tuple(e) for e in edges}
    assert len(directed) == len(edges) and all((b, a) in directed for a, b in directed)
    # The STL the library wrote reads back as the same closed solid.
    back = trellis.slice(trellis.mesh(tmp_path / "s.stl"), machine=os.path.join(
        ROOT, "profiles", "ender3_s1_pro_tpu.toml")).toolpath
    assert back.layer_count > 0


def test_a_parsed_design_gives_the_values_of_the_built_one():
    built = trellis.difference(trellis.union(trellis.rectprism(40, 30, 10), trellis.cylinder(10, 10).translate(0, 0, 8),
                                             blend=2), trellis.cylinder(5, 40))
    parsed = trellis.Field.from_vcad(built.vcad())
    pts = np.random.default_rng(3).uniform(-25, 25, (3000, 3))
    assert np.array_equal(built.evaluate(pts)["distance"], parsed.evaluate(pts)["distance"])
    with open(os.path.join(ROOT, "examples/designs/csg_bracket.vcad")) as f:
        bracket = trellis.Field.from_vcad(f.read())
    assert np.all(np.isfinite(bracket.evaluate(pts)["distance"]))
    with pytest.raises(trellis.InputError) as e:
        trellis.Field.from_vcad("union() {\n  spere(2);\n}\n")
    assert e.value.line == 2


def test_bad_points_and_oversized_grids_are_refused():
    f = trellis.sphere(5)
    with pytest.raises(trellis.InputError) as e:
        f.evaluate(np.array([[0, 0, 0], [np.nan, 0, 0]]))
    assert e.value.element == "points[1]"
    with pytest.raises(trellis.InputError):
        f.evaluate(np.zeros((3, 2)))
    # A grid beyond the budget: refused with the estimate, before allocating it.
    with pytest.raises(trellis.TrellisError) as e:
        f.sample(0.001, max_memory=100)
    assert "refused before starting" in str(e.value) and e.value.element == "run.max_memory"
    with pytest.raises(trellis.TrellisError) as e:
        f.mesh(0.001, max_memory=100)
    assert "refused before starting" in str(e.value)
    with pytest.raises(trellis.InputError):
        f.sample(0.0)


def test_long_field_calls_report_progress_and_stop_on_ctrl_c():
    f = trellis.gyroid(3, 0.3) & trellis.cube(30)
    seen = []
    f.sample(0.5, progress=lambda stage, x: seen.append((stage, x)))
    assert seen and all(0 <= x <= 1 for _, x in seen)
    # A user expression is the slowest field to evaluate: each call below takes seconds.
    slow = trellis.function((-10, -10, -10), (10, 10, 10), "sin(x)*cos(y)+sin(y)*cos(z)+sin(z)*cos(x)")
    points = np.random.default_rng(0).uniform(-10, 10, (4_000_000, 3))
    for call in (lambda: f.mesh(0.04, force=True), lambda: slow.sample(0.1, force=True),
                 lambda: slow.evaluate(points)):
        timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
        t0 = time.perf_counter()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            call()
        assert time.perf_counter() - t0 < 1.5
        timer.join()


def test_a_3mf_level_set_design_slices_as_its_vcad_function(tmp_path):
    # The specification's sphere (3MF Volumetric & Implicit, Part II ch. 3, through a functioncall)
    # read by the library from the path: the same moves as the same sphere as a .vcad function().
    design = os.path.join(ROOT, "tests", "data", "3mf_volumetric", "spec_sphere_functioncall.3mf")
    vcad = tmp_path / "ball.vcad"
    vcad.write_text('root((-12,-12,-12),(12,12,12),(0.5,0.5,0.5)) '
                    '{ function((-12,-12,-12),(12,12,12),"sqrt(x^2+y^2+z^2)-10"); }\n')
    prof = os.path.join(ROOT, "profiles", "ender3_s1_pro_tpu.toml")
    opts = dict(machine=prof, layer_height=0.5, set={"extrusion.nozzle_diameter": 0.8},
                bead_width=0.4, walls=2, infill=0.2, strategy="none")
    moves = []
    for src, out in ((design, tmp_path / "a.gcode"), (str(vcad), tmp_path / "b.gcode")):
        trellis.slice(src, str(out), **opts)
        moves.append([l for l in out.read_text().splitlines() if l and not l.startswith(";")])
    assert len(moves[0]) > 5000
    assert moves[0] == moves[1]
