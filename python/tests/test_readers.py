"""The reader routes from Python (trellis.check, analyze, compare, view, render): each function's
result is what its command writes for the same inputs and settings (the report's bytes, the page's,
the PNGs'), its keywords are the schema's (an unknown one is refused naming it), a bad file is
refused naming the file; and the Python writers of one format refuse a name of another."""
import json
import os
import subprocess

import numpy as np
import pytest

import trellis

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("TRELLIS_CLI", "trellis")
ENDER = os.path.join(ROOT, "profiles", "ender3_s1_pro_tpu.toml")
BATH = os.path.join(ROOT, "profiles", "embedded_aero_410um.toml")
READERS = ["check", "analyze", "compare", "view", "render"]


def without_job(report):
    """A report file as the function returns it: the job it carries for `trellis rerun` taken out
    (compare's: out of every analysis)."""
    for r in report if isinstance(report, list) else [report]:
        assert isinstance(r.pop("job"), str)
    return report


def cli(*args, codes=(0,)):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert r.returncode in codes, r.stderr
    return r


@pytest.fixture(scope="module")
def prints(tmp_path_factory):
    """Generated inputs: for each of a few 2D lattices (pattern, cell, seed), the lattice and its
    prints by two planners (G-code and toolpath JSON)."""
    d = tmp_path_factory.mktemp("prints")
    cases = []
    for i, (pattern, cell, more) in enumerate([("voronoi", 1.5, {"seed": 3}), ("snub-square", 1.2, {}),
                                                ("penrose", 1.4, {})]):
        lat = d / f"l{i}.json"
        trellis.lattice2d(lat, pattern=pattern, cell=cell, size=(8 + i, 7), **more)
        files = {"lattice": lat}
        for planner in ("euler", "gippo"):
            trellis.plan(planner, lat, d / f"{planner}{i}.json", machine=ENDER,
                         gcode=d / f"{planner}{i}.gcode", center=True)
            files[planner] = d / f"{planner}{i}.gcode"
            files[planner + "_json"] = d / f"{planner}{i}.json"
        cases.append(files)
    return cases


def test_compare_is_the_commands_report(prints, tmp_path):
    for i, c in enumerate(prints):
        cli("compare", c["lattice"], c["euler"], c["gippo"], "--align", "--report", tmp_path / f"cli{i}.json")
        got = trellis.compare(c["lattice"], c["euler"], c["gippo"], align=True, report=tmp_path / f"py{i}.json")
        assert (tmp_path / f"py{i}.json").read_bytes() == (tmp_path / f"cli{i}.json").read_bytes()
        assert got == without_job(json.loads((tmp_path / f"cli{i}.json").read_text()))
        # One entry per print, in the order given, each what analyze says of it alone.
        assert [a["name"] for a in got] == [str(c["euler"]), str(c["gippo"])]
        assert got[1] == trellis.analyze(c["gippo"], c["lattice"], align=True)
        assert got[0]["design_edges"] == trellis.read_lattice(c["lattice"]).edge_count


def test_check_and_analyze_reports_are_the_commands(prints, tmp_path):
    c = prints[0]
    # (exit status 1 when the check finds something: the report is written either way)
    cli("check", c["lattice"], c["euler_json"], "--report", tmp_path / "cli_check.json", codes=(0, 1))
    got = trellis.check(c["lattice"], c["euler_json"], report=tmp_path / "py_check.json")
    assert (tmp_path / "py_check.json").read_bytes() == (tmp_path / "cli_check.json").read_bytes()
    assert got == without_job(json.loads((tmp_path / "cli_check.json").read_text()))
    # The print was centred on the bed: analyze moves it onto the design and says so, on stderr
    # there and as a TrellisWarning here.
    r = cli("analyze", c["euler"], "--design", c["lattice"], "--report", tmp_path / "cli_a.json")
    assert "to align their centres" in r.stderr
    with pytest.warns(trellis.TrellisWarning, match="to align their centres"):
        got = trellis.analyze(c["euler"], c["lattice"], report=tmp_path / "py_a.json")
    assert (tmp_path / "py_a.json").read_bytes() == (tmp_path / "cli_a.json").read_bytes()
    assert got == without_job(json.loads((tmp_path / "cli_a.json").read_text()))


def test_view_is_the_commands_page(prints, tmp_path):
    for i, c in enumerate(prints):
        shown = [c["euler"], c["gippo_json"], c["lattice"]]
        cli("view", *shown, "-o", tmp_path / f"cli{i}.html")
        path = trellis.view(*shown, output=tmp_path / f"py{i}.html")
        assert path == str(tmp_path / f"py{i}.html")
        assert (tmp_path / f"py{i}.html").read_bytes() == (tmp_path / f"cli{i}.html").read_bytes()
        # No output: the page itself, the same text but for the job a written page carries.
        written = (tmp_path / f"cli{i}.html").read_text(encoding="utf-8")
        page = trellis.view(*shown)
        assert 'id="trellis-job"' in written and 'id="trellis-job"' not in page
        start = written.rindex('<script type="application/json" id="trellis-job">')
        assert page == written[:start] + written[written.index("</script>\n", start) + 10:]
    # Over the design, replayed as check does, with the nozzle's settings as keywords (by flag
    # and by key name) and a title.
    c = prints[1]
    cli("view", c["gippo"], "--design", c["lattice"], "--nozzle-radius", "0.6", "--title", "t w",
        "-o", tmp_path / "d_cli.html")
    trellis.view(c["gippo"], design=c["lattice"], radius=0.6, title="t w", output=tmp_path / "d_py.html")
    assert (tmp_path / "d_py.html").read_bytes() == (tmp_path / "d_cli.html").read_bytes()
    # Its warnings are the command's (stderr there, TrellisWarning here).
    r = cli("view", c["gippo"], "--design", c["lattice"], "--machine", ENDER, "-o", tmp_path / "w_cli.html")
    assert "no build volume drawn" in r.stderr
    with pytest.warns(trellis.TrellisWarning, match="no build volume drawn"):
        trellis.view(c["gippo"], design=c["lattice"], machine=ENDER, output=tmp_path / "w_py.html")
    assert (tmp_path / "w_py.html").read_bytes() == (tmp_path / "w_cli.html").read_bytes()


def test_render_writes_the_commands_pngs(prints, tmp_path):
    c = prints[2]
    # One layer: that PNG.
    cli("render", c["euler"], "--layer", "0", "--image-size", "300", "-o", tmp_path / "one_cli.png")
    files = trellis.render(c["euler"], tmp_path / "one_py.png", layer=0, image_size=300)
    assert files == [str(tmp_path / "one_py.png")]
    assert (tmp_path / "one_py.png").read_bytes() == (tmp_path / "one_cli.png").read_bytes()
    # Every layer: OUT.layerNNN.png each, the paths returned in layer order (a toolpath of a few
    # layers made in numpy; the prefix given with or without .png).
    for layers in (2, 4):
        multi = tmp_path / f"multi{layers}.json"
        pts = np.array([[x + k, y, 0.2 * (k + 1)] for k in range(layers)
                        for x, y in ((0, 0), (6, 0), (6, 5))], float)
        tp = trellis.Toolpath.from_arrays(pts, np.arange(0, 3 * layers + 1, 3), np.arange(layers + 1),
                                          width=0.4, height=0.2)
        multi.write_text(tp.to_json())
        cli("render", multi, "--colour", "order", "-o", tmp_path / f"cli{layers}")
        files = trellis.render(multi, tmp_path / f"py{layers}.png", colour="order")
        assert files == [str(tmp_path / f"py{layers}.layer{k:03}.png") for k in range(layers)]
        for k in range(layers):
            assert (tmp_path / f"py{layers}.layer{k:03}.png").read_bytes() == \
                (tmp_path / f"cli{layers}.layer{k:03}.png").read_bytes()


def test_keywords_are_the_schemas(prints):
    settings = {s["key"]: s for s in trellis.settings()}
    for reader in READERS:
        keys = trellis._trellis.reader_keys(reader)
        assert keys, reader
        for key in keys:  # every keyword a setting of the reader's sections, with a flag
            assert settings[key]["flag"] and settings[key]["section"] in trellis._trellis.reader_sections(reader)
    c = prints[0]
    calls = {
        "check": lambda **k: trellis.check(c["lattice"], c["euler"], **k),
        "analyze": lambda **k: trellis.analyze(c["euler"], **k),
        "compare": lambda **k: trellis.compare(c["lattice"], c["euler"], **k),
        "view": lambda **k: trellis.view(c["euler"], **k),
        "render": lambda **k: trellis.render(c["euler"], os.devnull, layer=0, **k),
    }
    for reader, call in calls.items():
        with pytest.raises(trellis.SettingError) as e:
            call(frobnicate=1)
        assert e.value.element == "frobnicate" and "'frobnicate'" in str(e.value), reader
        assert f"trellis.{reader}()" in str(e.value)
        # A setting of a section it does not read, by its key.
        with pytest.raises(trellis.SettingError) as e:
            call(set={"slice.walls": 2})
        assert "[slice]" in str(e.value), reader


def test_bad_files_are_named(prints, tmp_path):
    c = prints[0]
    missing = tmp_path / "nowhere.gcode"
    garbage = tmp_path / "garbage.json"
    garbage.write_text("{ not json")
    calls = {
        "check": lambda f: trellis.check(c["lattice"], f),
        "analyze": lambda f: trellis.analyze(f),
        "compare": lambda f: trellis.compare(c["lattice"], c["euler"], f),
        "view": lambda f: trellis.view(f),
        "render": lambda f: trellis.render(f, tmp_path / "x.png", layer=0),
    }
    for reader, call in calls.items():
        for bad in (missing, garbage):
            with pytest.raises(trellis.TrellisError) as e:
                call(bad)
            assert str(bad) in str(e.value) or e.value.file == str(bad), (reader, str(e.value))
        assert not (tmp_path / "x.png").exists()
    # A design that is no lattice.
    with pytest.raises(trellis.TrellisError) as e:
        trellis.compare(garbage, c["euler"])
    assert str(garbage) in str(e.value) or e.value.file == str(garbage)
    # The output named for its format, as the command requires.
    with pytest.raises(trellis.SettingError) as e:
        trellis.view(c["euler"], output=tmp_path / "page.png")
    assert ".html" in str(e.value) and "page.png" in str(e.value)
    assert not (tmp_path / "page.png").exists()
    with pytest.raises(TypeError):
        trellis.view(trellis.read_toolpath(c["euler"]))
    with pytest.raises(TypeError):
        trellis.compare(c["lattice"])


def test_writers_refuse_names_of_other_formats(tmp_path):
    mesh = trellis.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float),
                        np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))
    for name in ("m.obj", "m.3mf", "m", "m.stl.json"):
        with pytest.raises(trellis.SettingError) as e:
            mesh.write_stl(tmp_path / name)
        assert str(tmp_path / name) in str(e.value) and ".stl" in str(e.value)
        assert not (tmp_path / name).exists()
    for name in ("m.stl", "M.STL"):
        mesh.write_stl(tmp_path / name)
        assert (tmp_path / name).read_bytes()[80:84] == (4).to_bytes(4, "little")
    with pytest.raises(trellis.SettingError) as e:
        trellis.sphere(2).mesh(0.5, stl=tmp_path / "s.obj")
    assert "s.obj" in str(e.value) and ".stl" in str(e.value) and not (tmp_path / "s.obj").exists()
    tp = trellis.Toolpath.from_arrays(np.array([[0, 0, 0.2], [5, 0, 0.2], [5, 5, 0.2]], float), width=0.4,
                                      height=0.2)
    for name in ("v.png", "v.json", "v"):
        with pytest.raises(trellis.SettingError) as e:
            tp.save_view(tmp_path / name)
        assert str(tmp_path / name) in str(e.value) and ".html" in str(e.value) and ".htm" in str(e.value)
        assert not (tmp_path / name).exists()
    for name in ("v.html", "v.HTM"):
        tp.save_view(tmp_path / name, title="t")
        assert (tmp_path / name).read_text(encoding="utf-8") == tp.view_html("t")
