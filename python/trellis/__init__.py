"""Trellis: toolpaths for architected materials, from Python.

Every route of the command line is a call here, with the same settings (keyword arguments named
as the CLI flags, ``layer_height`` for ``--layer-height``; any setting by its dotted key through
``set={"extrusion.k": 0.9}``), the same defaults, the same errors and the same output files::

    import trellis
    lat = trellis.lattice2d(pattern="penrose", cell=1.2, size=(10, 10)).lattice
    res = trellis.plan("gippo", lat, machine="profiles/ender3_s1_pro_tpu.toml", gcode="p.gcode")
    pts = res.toolpath.points          # (n, 3) numpy array of every point

Wherever a call takes a file it takes the object too: a ``Lattice``, ``Toolpath`` or ``Field``
for its input, a dict of tables for ``machine`` (written beside the output, so ``rerun`` works).

Long calls release the GIL, report progress to ``progress(stage, fraction)`` and stop on Ctrl-C
(KeyboardInterrupt). Errors are ``trellis.InputError``, ``trellis.SettingError``,
``trellis.GeometryError`` and ``trellis.MachineError`` (the output would not print on the
machine; nothing written) with ``file``, ``line`` and ``element``.
"""
from __future__ import annotations

import html
import inspect
import json
import numbers
import os
import re
import shlex
import sys
import tempfile
import warnings

from . import _trellis
from .errors import GeometryError, InputError, MachineError, SettingError, TrellisError, TrellisWarning
from .fields import (Field, Mesh, cone, cube, cylinder, difference, fgrade, function, gyroid, intersection,
                     mesh, rectprism, sphere, torus, tpms, union)

__all__ = ["Field", "Mesh", "sphere", "cube", "rectprism", "cylinder", "cone", "torus", "function", "tpms",
           "gyroid", "mesh", "union", "intersection", "difference", "fgrade", "parse_vcad",
           "analyze", "check", "compare", "view", "render", "lattice2d", "lattice3d", "plan", "gcode", "slice", "pbf", "nonplanar", "surface",
           "run_job", "rerun", "settings", "read_lattice", "read_toolpath", "notebook_viewer", "Lattice",
           "Toolpath",
           "Result", "TrellisError", "InputError", "SettingError", "GeometryError", "MachineError",
           "TrellisWarning",
           "__version__"]

__version__ = _trellis.version()


class Lattice:
    """A strut lattice: ``nodes`` (n, 3), ``edges`` (m, 2) and ``material`` (m,) numpy arrays."""

    def __init__(self, core):
        self._core = core
        self._arrays = None

    @staticmethod
    def from_arrays(nodes, edges, material=None):
        """A lattice from arrays; shapes, finite coordinates and edge indices are checked."""
        return Lattice(_trellis.lattice_from_arrays(nodes, edges, material))

    def _a(self):
        if self._arrays is None:
            self._arrays = self._core.arrays()
        return self._arrays

    nodes = property(lambda self: self._a()["nodes"])
    edges = property(lambda self: self._a()["edges"])
    material = property(lambda self: self._a()["material"])
    node_count = property(lambda self: self._core.node_count)
    edge_count = property(lambda self: self._core.edge_count)
    total_length = property(lambda self: self._core.total_length)

    def write(self, path):
        self._core.write(os.fspath(path))

    def to_json(self):
        return self._core.to_json()

    def __repr__(self):
        return f"<trellis.Lattice {self.node_count} nodes, {self.edge_count} struts>"


ROLES = ["strut", "contour", "handle", "perimeter", "infill", "other", "skin", "purge", "hatch",
         "nonplanar"]


class Toolpath:
    """Layers of paths. Whole arrays, no per-point objects: ``points`` (N, 3),
    ``path_offsets`` (P + 1,) — path i is ``points[path_offsets[i]:path_offsets[i + 1]]`` —
    ``layer_offsets`` (L + 1,) into the paths, ``layer_z``, and per path ``role`` (index into
    ``trellis.ROLES``), ``tool``, ``width``, ``height``, ``speed``, ``power``,
    ``temperature`` and ``mixture`` (P, materials)."""

    def __init__(self, core):
        self._core = core
        self._arrays = None

    @staticmethod
    def from_arrays(points, path_offsets=None, layer_offsets=None, *, layer_z=None, role="strut",
                    tool=0, width=0.0, height=0.0, speed=0.0, power=0.0, temperature=0.0,
                    mixture=None):
        """A toolpath designed in numpy (the inverse of ``arrays()``:
        ``Toolpath.from_arrays(**tp.arrays())`` is ``tp`` again, array for array).

        ``points`` (N, 3) mm; ``path_offsets`` (P + 1,) — path i is
        ``points[path_offsets[i]:path_offsets[i + 1]]``, default one path of every point;
        ``layer_offsets`` (L + 1,) into the paths, default one layer; ``layer_z`` per layer,
        default its lowest point. Per path, a scalar for every path or a (P,) array: ``role``
        (names of ``trellis.ROLES`` or their indices), ``tool``, ``width``, ``height``, ``speed``
        (0 = the machine profile's), ``power``, ``temperature`` (0 = not set); ``mixture`` (k,)
        or (P, k) fractions (a row of zeros: none). Checked as every reader checks a toolpath
        file; errors are ``trellis.InputError`` naming the argument and index."""
        attributes = {"role": role, "tool": tool, "width": width, "height": height,
                      "speed": speed, "power": power, "temperature": temperature}
        if mixture is not None:
            attributes["mixture"] = mixture
        return Toolpath(_trellis.toolpath_from_arrays(points, path_offsets, layer_offsets, layer_z,
                                                      attributes))

    def arrays(self):
        """Every array at once (a dict), computed on first use."""
        if self._arrays is None:
            self._arrays = self._core.arrays()
        return self._arrays

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        arrays = self.arrays()
        if name in arrays:
            return arrays[name]
        raise AttributeError(name)

    layer_count = property(lambda self: self._core.layer_count)
    path_count = property(lambda self: self._core.path_count)
    point_count = property(lambda self: self._core.point_count)
    extrusion_length = property(lambda self: self._core.extrusion_length)
    lasers = property(lambda self: self._core.lasers,
                      doc="The lasers that differ as the build declares them (pbf with [lasers], a "
                          ".cli, 3MF or toolpath JSON that says them), laser 1 first: a dict each "
                          "with the [lasers] keys (powers, speeds, spot, jump speed, delays, "
                          "skywriting); empty when none are declared.")

    def path(self, i):
        """The points of path i, an (n, 3) view into ``points``."""
        o = self.path_offsets
        return self.points[o[i]:o[i + 1]]

    def to_json(self):
        return self._core.to_json()

    def gcode(self, machine=None, set=None):
        """The G-code text for a machine profile (str)."""
        with _MachineFile(machine) as path:
            return _trellis.gcode_text(self._core, path, set or {})

    def cli(self, machine=None, set=None, binary=False):
        """The laser build file (Common Layer Interface, ASCII or binary) as bytes."""
        with _MachineFile(machine) as path:
            return _trellis.cli_bytes(self._core, path, set or {}, binary)

    def png(self, layer=0, size=600):
        """A PNG (bytes) of one layer."""
        return self._core.png(layer, size)

    def _repr_png_(self):
        return self.png(self.layer_count // 2)

    def view_html(self, title=None):
        """The interactive 3D viewer of ``trellis view`` for this toolpath: one self-contained
        HTML page (str) that needs no server and no network."""
        return self._core.view_html(title or self._core.source or "toolpath")

    def save_view(self, path, title=None):
        """Writes the viewer page (``view_html``) to ``path``, which is named .html or .htm as
        `trellis view -o` requires (else ``trellis.SettingError``, nothing written)."""
        self._core.save_view(os.fspath(path), title or self._core.source or "toolpath")

    def view_notebook(self, title=None):
        """This toolpath's view for a notebook page (str): its data only (layers packed and
        deflated) and a call to the viewer script that ``notebook_viewer()`` puts on the page."""
        return self._core.view_notebook(title or self._core.source or "toolpath")

    def _repr_html_(self):
        # Jupyter shows the viewer inline, in a sandboxed iframe; the viewer's script goes into
        # the notebook once (the first view of the kernel session carries it), every view its
        # data only.
        return _notebook_script_once() + self.view_notebook()

    def __repr__(self):
        return (f"<trellis.Toolpath {self.layer_count} layers, {self.path_count} paths, "
                f"{self.point_count} points>")


class _NotebookState:
    """Which cell of this kernel session carried the viewer script (None: not sent yet)."""
    sent = False
    cell = None


def _cell_id():
    """Which notebook cell is running: the id Jupyter sends with the request (JupyterLab), else
    the cell's source as IPython recorded it; None outside IPython."""
    try:
        from IPython import get_ipython
    except ImportError:
        return None
    shell = get_ipython()
    if shell is None:
        return None
    parent = getattr(shell, "get_parent", None)
    cell = ((parent() or {}).get("metadata") or {}).get("cellId") if parent else None
    if cell is None:
        inputs = shell.user_ns.get("_ih") or [""]
        cell = "source:" + inputs[-1]
    return cell


def _notebook_script_once():
    """The viewer script when this view is the first of the session, or in the cell that sent it
    first (run again, that cell's new output must carry it again); else ''."""
    cell = _cell_id()
    if _NotebookState.sent and (cell is None or cell != _NotebookState.cell):
        return ""
    _NotebookState.sent, _NotebookState.cell = True, cell
    return _trellis.viewer_notebook_script()


class _NotebookViewer:
    def _repr_html_(self):
        _NotebookState.sent, _NotebookState.cell = True, _cell_id()
        return (_trellis.viewer_notebook_script()
                + '<div style="font:12px system-ui,sans-serif;color:#666">Trellis viewer script '
                  f'{html.escape(__version__)} loaded: every toolpath view in this notebook uses it.'
                  '</div>')


def notebook_viewer():
    """Displayed in a notebook cell, puts the viewer's script on the page; every ``Toolpath``
    shown after it carries only its data. The first view of a kernel session does this by itself;
    call it in a cell above when the output that carried the script was cleared."""
    return _NotebookViewer()


class Result:
    """What a route wrote and made: ``files``, ``summary``, ``warnings``, and the in-memory
    ``toolpath`` / ``lattice`` when the route makes one."""

    def __init__(self, d):
        self.files = list(d["files"])
        self.summary = d["summary"]
        self.warnings = list(d.get("warnings", []))
        self.exit_code = d.get("exit_code", 0)
        self.toolpath = Toolpath(d["toolpath"]) if d.get("toolpath") is not None else None
        self.lattice = Lattice(d["lattice"]) if d.get("lattice") is not None else None

    def __repr__(self):
        return f"<trellis.Result {self.summary!r}>"


def _keywords(route, choice=None):
    """keyword (flag with _) -> setting key of the route's function: the flags of the settings of
    its sections that the route uses, with ``choice`` (a value of the route's choice setting, such
    as the planner) those that value uses; from the route table and the schema
    (``route_keywords`` in job/job.hpp), never listed here."""
    return _trellis.route_keywords(route, choice or "")


_SCHEMA = []


def _schema():
    """The settings (``_trellis.settings()``), read once."""
    if not _SCHEMA:
        _SCHEMA.extend(_trellis.settings())
    return _SCHEMA


def _foreign_keyword(route, name):
    """Why ``name`` is no keyword of the route when it is another section's flag, naming its
    setting key; else None."""
    sections = set(_trellis.route_sections(route))
    for s in _schema():
        if s["flag"] and s["flag"].replace("-", "_") == name and s["section"] not in sections:
            return (f"'{name}' is {s['key']}, a setting of [{s['section']}], which the {route} "
                    "route does not read")
    return None


def _path(p):
    return "" if p is None else os.fspath(p)


def _call(route, input, outputs, machine, set, progress, kwargs, command=None, extra=None,
          choice=None):
    keywords = _keywords(route, choice)
    values = dict(extra or {})
    for name, value in kwargs.items():
        if name not in keywords:
            key = _keywords(route).get(name) if choice else None
            if key:  # the route's, but not this planner's (kind's)
                when = next(s["when"] for s in _schema() if s["key"] == key)
                raise SettingError(f"'{name}' is {key}, which trellis.{route}({choice!r}) does not "
                                   f"use: it is used only when {when}", element=name)
            foreign = _foreign_keyword(route, name)
            if foreign:
                raise SettingError(foreign, element=name)
            near = [k for k in keywords if k.startswith(name[:3])][:3]
            raise SettingError(f"unknown keyword '{name}' for trellis.{command or route}()"
                               + (f" (did you mean {', '.join(near)}?)" if near else "")
                               + "; any setting can be given as set={'section.key': value}",
                               element=name)
        values[keywords[name]] = value
    for key, value in (set or {}).items():
        values[key] = value
    outs = {k: _path(v) for k, v in outputs.items() if v is not None}
    cmd = "python: trellis." + (command or route) + "(" + ", ".join(
        [repr(_path(input))] if input else []) + ")"
    return Result(_trellis.run(route, _path(input), outs, _path(machine), values, cmd, progress))


_SIDECAR = ("output", "toolpath", "gcode", "report", "lattice")


def _sidecar(text, suffix, outputs):
    """`text` as a file a route reads: beside the call's first output and named after it
    (``p.gcode`` → ``p.gcode.toolpath.json``), so the job every output embeds names a file that
    stays and ``trellis.rerun(output)`` regenerates it; in a temporary file, removed after the
    call, when the call writes no file. Returns (path, remove_after)."""
    first = next((outputs[k] for k in _SIDECAR if outputs.get(k) is not None), None)
    if first is None:
        fd, path = tempfile.mkstemp(suffix=suffix, prefix="trellis_")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        return path, True
    path = os.fspath(first) + suffix
    fd, tmp = tempfile.mkstemp(suffix=".tmp", prefix=".trellis_",
                               dir=os.path.dirname(os.path.abspath(path)))
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        os.remove(tmp)
        raise
    return path, False


def _object_text(obj):
    """An in-memory input (``Lattice``, ``Toolpath``, ``Field``, ``Mesh``, or a machine profile as
    a dict of tables) as (file text, suffix); None for a path."""
    if isinstance(obj, Lattice):
        return obj.to_json(), ".lattice.json"
    if isinstance(obj, Toolpath):
        return obj.to_json(), ".toolpath.json"
    if isinstance(obj, Field):
        obj._compiled()  # errors name the line and column before anything is written
        return obj.vcad(), ".design.vcad"
    if isinstance(obj, Mesh):
        return obj.obj_text(), ".mesh.obj"
    if isinstance(obj, dict):
        return _toml(obj), ".machine.toml"
    return None


def _call_object(route, input, outputs, machine, set, progress, kwargs, command=None, extra=None,
                 choice=None):
    """_call with the input and the machine each a file or an in-memory object, written as a
    file beside the first output (see _sidecar) and removed again if the call fails."""
    written = []
    ok = False
    try:
        paths = []
        for obj in (input, machine):
            text = _object_text(obj)
            if text is None:
                paths.append(obj)
                continue
            path, remove_after = _sidecar(*text, outputs)
            written.append((path, remove_after))
            paths.append(path)
        result = _call(route, paths[0], outputs, paths[1], set, progress, kwargs, command, extra,
                       choice)
        ok = True
        return result
    finally:
        for path, remove_after in written:
            if remove_after or not ok:
                try:
                    os.remove(path)
                except FileNotFoundError:
                    pass


class _MachineFile:
    """A machine profile given as a dict, in a temporary file for the call's duration."""

    def __init__(self, machine):
        self.machine = machine
        self.temp = None

    def __enter__(self):
        if isinstance(self.machine, dict):
            self.temp, _ = _sidecar(_toml(self.machine), ".machine.toml", {})
            return self.temp
        return _path(self.machine)

    def __exit__(self, *exc):
        if self.temp:
            os.remove(self.temp)


def lattice2d(output: PathLike | None = None, *, preview: PathLike | None = None, progress=None,
              set=None, **settings):
    """A 2D lattice from the atlas ([lattice2d] settings: pattern, cell, size, ...)."""
    return _call_object("lattice2d", None, {"output": output, "preview": preview}, None, set, progress,
                 settings)


def lattice3d(output: PathLike | None = None, *, preview: PathLike | None = None, progress=None,
              set=None, **settings):
    """A 3D lattice: unit cells (cell_type, cell, count) or a Voronoi foam (kind='foam')."""
    return _call_object("lattice3d", None, {"output": output, "preview": preview}, None, set, progress,
                 settings)


def plan(planner: str, lattice: PathLike | Lattice, output: PathLike | None = None, *,
         machine: Machine | None = None, gcode: PathLike | None = None,
         report: PathLike | None = None, preview: PathLike | None = None, progress=None, set=None,
         **settings):
    """Plans paths over a lattice (a file or a ``Lattice``): planner 'gippo', 'euler' or 'aero'."""
    planners = next(s["choices"] for s in _trellis.settings() if s["key"] == "plan.planner")
    if planner not in planners:
        raise SettingError(f"unknown planner '{planner}' (expected {', '.join(planners[:-1])} or "
                           f"{planners[-1]})", element="planner")
    return _call_object("plan", lattice, {"toolpath": output, "gcode": gcode, "report": report,
                                          "preview": preview}, machine, set, progress, settings,
                        command=planner, extra={"plan.planner": planner}, choice=planner)


def gcode(toolpath: PathLike | Toolpath, output: PathLike | None = None, *, machine: Machine,
          progress=None, set=None, **settings):
    """G-code (or .nc) from a toolpath (a file or a ``Toolpath``) for a machine profile."""
    return _call_object("gcode", toolpath, {"output": output}, machine, set, progress, settings)


def slice(design: PathLike | Field, output: PathLike | None = None, *, machine: Machine,
          report: PathLike | None = None, toolpath: PathLike | None = None,
          preview: PathLike | None = None, progress=None, set=None, **settings):
    """Slices a .vcad design, a mesh, or a ``Field`` built in Python: walls, skins, infill;
    graded designs with strategy=1 or 2."""
    return _call_object("slice", design, {"output": output, "report": report, "toolpath": toolpath,
                                          "preview": preview}, machine, set, progress, settings)


def parse_vcad(text, name="<vcad>"):
    """Checks .vcad text (errors name the line and column); returns {'has_root': bool}."""
    return _trellis.parse_vcad(text, name)


def _core_or_path(obj, kind, name):
    if isinstance(obj, kind):
        return obj._core
    if isinstance(obj, (Lattice, Toolpath, Field)):
        raise TypeError(f"{name} must be a file or a trellis.{kind.__name__}, "
                        f"got a trellis.{type(obj).__name__}")
    return os.fspath(obj)


def _reader_keywords(reader):
    """keyword (flag with _) -> setting key, for the settings a reader route takes
    (trellis check, analyze, ...: the schema's flags of its sections)."""
    info = {s["key"]: s for s in _trellis.settings()}
    return {info[k]["flag"].replace("-", "_"): k for k in _trellis.reader_keys(reader)}


def _nozzle_key(name):
    """The [nozzle] setting a check's keyword names by its key's name (radius, cone, ...)."""
    key = f"nozzle.{name}"
    return key if any(s["key"] == key for s in _schema()) else None


def _file(obj, name, instead=None):
    """A file argument of a reader that reads files only: its path, else TypeError naming the
    argument (and what to call instead for an in-memory object)."""
    if isinstance(obj, (Lattice, Toolpath, Field, Mesh)):
        raise TypeError(f"{name} must be a file, got a trellis.{type(obj).__name__}"
                        + (f" ({instead})" if instead else ""))
    return os.fspath(obj)


def _read(reader, design, prints, machine, set, kwargs, fallback=None, output=None, report=None,
          preview=None, progress=None):
    """Runs a reader route as its command does (``_trellis.read_run``): its keywords the schema's
    flags of its sections (``reader_keys``), its warnings as ``TrellisWarning``s (the command
    prints them). Returns read_run's dict: report, files, summary, warnings, exit_code."""
    keywords = _reader_keywords(reader)
    values = {}
    for name, value in kwargs.items():
        key = keywords.get(name) or (fallback(name) if fallback else None)
        if key is None:
            raise SettingError(f"unknown keyword '{name}' for trellis.{reader}() (expected one of "
                               f"{', '.join(sorted(keywords))}); any setting it reads can be "
                               "given as set={'section.key': value}", element=name)
        values[key] = value
    values.update(set or {})
    with _MachineFile(machine) as path:
        r = _trellis.read_run(reader, design, prints, path, values, _path(output), _path(report),
                              _path(preview), progress)
    for kind, text in r["warnings"]:
        warnings.warn(f"trellis.{reader}: {text} [{kind}]", TrellisWarning, stacklevel=3)
    return r


def analyze(gcode: PathLike | Toolpath, design: PathLike | Lattice | None = None, *,
            machine: Machine | None = None, report: PathLike | None = None,
            preview: PathLike | None = None, set=None, **settings) -> dict[str, Any]:
    """Measures a print against a design lattice: the same numbers as `trellis analyze`, as a
    dict. ``gcode`` is any G-code file (ours or another slicer's) or a ``Toolpath`` (measured as
    planned: no filament or retractions, which the machine adds); ``design`` a lattice file or a
    ``Lattice``. Keywords are the [analyze] and [read] settings (bead_width, layer_height, align,
    strict, commanded_mixtures, ...): graded G-code with a mixing look-ahead is measured with its
    mixtures as deposited, or as commanded with ``commanded_mixtures=True``. ``report`` also
    writes the report JSON (the bytes of ``--report``), ``preview`` a folder of layer PNGs."""
    return json.loads(_read("analyze", None if design is None else _core_or_path(design, Lattice, "design"),
                            _core_or_path(gcode, Toolpath, "gcode"), machine, set, settings,
                            report=report, preview=preview)["report"])


def check(lattice: PathLike | Lattice, print_file: PathLike | Toolpath, *,
          machine: Machine | None = None, report: PathLike | None = None,
          preview: PathLike | None = None, set=None, **settings) -> dict[str, Any]:
    """Replays a print against the nozzle model (collisions, struts missing or repeated), as a
    dict; ``lattice`` a file or a ``Lattice``, ``print_file`` G-code, a toolpath file or a
    ``Toolpath``. Keywords are the [check], [nozzle] and [lattice] settings (snap,
    nozzle_radius, ...; the nozzle's also by their keys' names: radius, tip_clearance,
    node_clearance, cone). ``report`` also writes the report JSON (``--report``), ``preview`` a
    folder with the picture of the collisions ringed."""
    return json.loads(_read("check", _core_or_path(lattice, Lattice, "lattice"),
                            _core_or_path(print_file, Toolpath, "print_file"), machine, set, settings,
                            _nozzle_key, report=report, preview=preview)["report"])


def compare(design: PathLike, *gcode: PathLike, report: PathLike | None = None,
            preview: PathLike | None = None, set=None, **settings) -> list[dict[str, Any]]:
    """Prints side by side against one design, as `trellis compare DESIGN GCODE...`: the report,
    a list with one dict per file in the order given (each what ``analyze`` returns for it).
    ``design`` a lattice file, ``gcode`` any number of G-code files (any slicer's), toolpath JSON
    or 3MF toolpaths. Keywords are the [analyze] and [read] settings (bead_width, align, strict,
    ...). ``report`` also writes the report JSON (``--report``), ``preview`` a folder of layer
    PNGs per file."""
    if not gcode:
        raise TypeError("trellis.compare() needs a design and at least one print file")
    prints = [_file(g, f"gcode[{i}]", "trellis.analyze measures a Toolpath")
              for i, g in enumerate(gcode)]
    return json.loads(_read("compare", _file(design, "design"), prints, None, set, settings,
                            report=report, preview=preview)["report"])


def view(*files: PathLike, output: PathLike | None = None, design: PathLike | None = None,
         machine: Machine | None = None, set=None, **settings) -> str:
    """The interactive 3D viewer of `trellis view FILES... -o OUTPUT`: one self-contained HTML
    page of G-code (any slicer's), .nc, laser .cli, toolpath JSON, 3MF toolpaths, lattices and
    `trellis check` reports. With ``output`` it writes the page there (carrying its job, for
    `trellis rerun`) and returns its path; without, it returns the page (str, without a job). ``design`` (a lattice file) shows the prints in design coordinates
    over it, coloured by deviation, and replayed as ``check`` does; ``machine`` draws the
    profile's build volume. Keywords are the [view], [check], [nozzle], [lattice] and [read]
    settings (title, snap, nozzle_radius, ...; the nozzle's also by their keys' names)."""
    if not files:
        raise TypeError("trellis.view() needs at least one file to show")
    prints = [_file(f, f"files[{i}]", "a Toolpath shows itself: Toolpath.view_html()")
              for i, f in enumerate(files)]
    design = None if design is None else _file(design, "design")
    if output is not None:
        _read("view", design, prints, machine, set, settings, _nozzle_key, output=output)
        return os.fspath(output)
    with tempfile.TemporaryDirectory(prefix="trellis_view_") as folder:
        page = os.path.join(folder, "view.html")
        _read("view", design, prints, machine, set, settings, _nozzle_key, output=page)
        with open(page, encoding="utf-8") as f:
            return _without_page_job(f.read())


_PAGE_JOB = '<script type="application/json" id="trellis-job">'


def _without_page_job(html):
    """A page returned, not written: without the job block a written page carries for `trellis
    rerun` (its paths would be relative to a folder that is gone)."""
    start = html.rfind(_PAGE_JOB)
    if start < 0:
        return html
    end = html.index("</script>\n", start) + len("</script>\n")
    return html[:start] + html[end:]


def render(toolpath: PathLike, output: PathLike, *, machine: Machine | None = None, progress=None,
           set=None, **settings) -> list[str]:
    """Layer PNGs of a print, as `trellis render TOOLPATH -o OUTPUT`: with ``layer=`` one PNG,
    ``output``; without, every layer as OUTPUT.layerNNN.png (``output`` without .png is the
    prefix). Returns the paths written, in layer order. ``toolpath`` a toolpath JSON, G-code of
    any slicer, a laser .cli or a 3MF toolpath (a ``Toolpath`` in memory: ``Toolpath.png``);
    ``machine`` the profile whose valve commands an .nc is read with. Keywords are the [render]
    and [read] settings (layer, colour, image_size, ...)."""
    return _read("render", None, [_file(toolpath, "toolpath", "Toolpath.png(layer) draws one")],
                 machine, set, settings, output=output, progress=progress)["files"]


def pbf(output: PathLike | None = None, *, envelope: PathLike | Field | None = None,
        machine: Machine | None = None, report: PathLike | None = None,
        toolpath: PathLike | None = None, preview: PathLike | None = None, progress=None, set=None,
        **settings):
    """Laser powder-bed paths for a TPMS sheet lattice (.cli); ``envelope`` a design file or a
    ``Field``. A mesh file (STL, OBJ, 3MF) as ``envelope``, or a .vcad with a solid strategy
    (rectilinear, meander, stripe, island), is scanned as a solid part: contours, then hatch."""
    return _call_object("pbf", envelope, {"output": output, "report": report, "toolpath": toolpath,
                                   "preview": preview}, machine, set, progress, settings)


def nonplanar(surface: PathLike | None = None, output: PathLike | None = None, *, machine: Machine,
              report: PathLike | None = None, toolpath: PathLike | None = None,
              preview: PathLike | None = None, progress=None, set=None, **settings):
    """Non-planar layers on a surface mesh (a file or a ``Mesh``), a height function (height_fn,
    domain) or a test surface (set={'surface.kind': 'corrugation'})."""
    return _call_object("nonplanar", surface, {"output": output, "report": report, "toolpath": toolpath,
                                        "preview": preview}, machine, set, progress, settings)


def surface(kind: str, output: PathLike | None = None, *, machine: Machine | None = None,
            preview: PathLike | None = None, progress=None, set=None, **settings):
    """The non-planar paper's test surfaces (STL), or the angle test (toolpath JSON / G-code)."""
    return _call_object("surface", None, {"output": output, "preview": preview}, machine, set, progress,
                        settings, extra={"surface.kind": kind}, choice=kind)


def _route_function(spec):
    """The function of a route of the table (``_trellis.routes()``) that has none of its own
    above: ``NAME([CHOICE,] [INPUT,] output=None, *, machine=None, <its other outputs>=None,
    progress=None, set=None, **settings)``, CHOICE a value of its choice setting, INPUT its input
    (a file or an in-memory object), the keywords its settings (``_keywords``). Adding a route to
    the table adds its function, keywords and stub here with no edit."""
    name, choice, P = spec["name"], spec["choice"], inspect.Parameter
    params, notes = [], {}

    def param(arg, kind, note, **default):
        params.append(P(arg, kind, **default))
        notes[arg] = note

    arg = choice.split(".", 1)[1] if choice else None
    if arg:
        param(arg, P.POSITIONAL_OR_KEYWORD, "str")
    if spec["input"]:
        param(spec["input"], P.POSITIONAL_OR_KEYWORD, "PathLike | None", default=None)
    param("output", P.POSITIONAL_OR_KEYWORD, "PathLike | None", default=None)
    param("machine", P.KEYWORD_ONLY, "Machine | None", default=None)
    for out in spec["outputs"][1:]:
        param(out, P.KEYWORD_ONLY, "PathLike | None", default=None)
    params += [P("progress", P.KEYWORD_ONLY, default=None), P("set", P.KEYWORD_ONLY, default=None),
               P("settings", P.VAR_KEYWORD)]
    signature = inspect.Signature(params)

    def run(*args, **kwargs):
        a = signature.bind(*args, **kwargs).arguments
        outputs = {out: a.get("output" if i == 0 else out) for i, out in enumerate(spec["outputs"])}
        return _call_object(name, a.get(spec["input"]) if spec["input"] else None, outputs,
                            a.get("machine"), a.get("set"), a.get("progress"), a.get("settings", {}),
                            extra={choice: a[arg]} if arg else None, choice=a[arg] if arg else None)

    run.__name__ = run.__qualname__ = name
    run.__signature__ = signature
    run.__annotations__ = dict(notes, **{"return": "Result"})
    run.__doc__ = (f"The {name} route (`trellis {name}`; job route = \"{name}\"): keywords are its "
                   "settings, any setting by its key through set={'section.key': value}.")
    return run


def run_job(job, output_dir=None, set=None, progress=None):
    """Runs a job file (a path), or a job given as a dict of tables ({'job': {...}, ...})."""
    if isinstance(job, dict):
        fd, path = tempfile.mkstemp(suffix=".toml", prefix="trellis_job_", dir=os.getcwd())
        with os.fdopen(fd, "w") as f:
            f.write(_toml(job))
        try:
            return Result(_trellis.run_job_file(path, _path(output_dir),
                                                [f"{k}={_text(v)}" for k, v in (set or {}).items()],
                                                progress))
        finally:
            os.remove(path)
    return Result(_trellis.run_job_file(os.fspath(job), _path(output_dir),
                                        [f"{k}={_text(v)}" for k, v in (set or {}).items()],
                                        progress))


def _text(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return ",".join(repr(float(x)) for x in v)
    return str(v)


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_key(key):
    """A key (or a table name) in TOML: its dotted parts bare when they can be, else quoted."""
    if not isinstance(key, str) or not key:
        raise TypeError(f"job keys and table names are non-empty strings, got {key!r}")
    parts = key.split(".")
    if all(_BARE_KEY.fullmatch(p) for p in parts):
        return key
    return _toml_string(key)


def _toml_string(s):
    out = []
    for c in s:
        if c in ('"', "\\"):
            out.append("\\" + c)
        elif c == "\n":
            out.append("\\n")
        elif c == "\t":
            out.append("\\t")
        elif c == "\r":
            out.append("\\r")
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04X}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def _toml_value(v, key):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))
    if isinstance(v, os.PathLike):
        return _toml_string(os.fspath(v))
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x, key) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x, k)}" for k, x in v.items()) + "}"
    raise TypeError(f"job value of '{key}' must be a string, number, bool, list or dict, "
                    f"got {type(v).__name__} {v!r}")


def _toml(tables):
    """A job dict as TOML text: {'job': {...}, 'slice': {...}, 'part': [{...}, {...}]} — tables,
    arrays of tables ([[part]]) and their sub-tables ([part.slice]); every key and string
    escaped, so no value can start a table or a key of its own."""
    lines = []

    def table(name, body, array):
        if not isinstance(body, dict):
            raise TypeError(f"job table '{name}' must be a dict, got {type(body).__name__} {body!r}")
        lines.append(f"[[{name}]]" if array else f"[{name}]")
        subs = []
        for k, v in body.items():
            if isinstance(v, dict):
                subs.append((k, v, False))
            elif isinstance(v, (list, tuple)) and v and all(isinstance(x, dict) for x in v):
                subs.append((k, v, True))
            else:
                lines.append(f"{_toml_key(k)} = {_toml_value(v, k)}")
        for k, v, is_array in subs:
            for item in (v if is_array else [v]):
                table(f"{name}.{_toml_key(k)}", item, is_array)

    if not isinstance(tables, dict):
        raise TypeError(f"a job is a dict of tables, got {type(tables).__name__}")
    for name, body in tables.items():
        if isinstance(body, (list, tuple)):
            for item in body:
                table(_toml_key(name), item, True)
        else:
            table(_toml_key(name), body, False)
    return "\n".join(lines) + "\n"


def rerun(path, output=None):
    """Regenerates an output from the job in its header (byte for byte)."""
    return _trellis.rerun(os.fspath(path), _path(output))


def settings(route=None):
    """Every setting (dicts: key, kind, unit, default, range, doc, flag), or a route's."""
    all_settings = _trellis.settings()
    if route is None:
        return all_settings
    sections = set(_trellis.route_sections(route))
    return [s for s in all_settings if s["section"] in sections]


def read_lattice(path, merge_tolerance=1e-6):
    """A lattice file (JSON, CSV, AERO pairs, OBJ) as a ``Lattice``."""
    return Lattice(_trellis.read_lattice(os.fspath(path), merge_tolerance))


def read_toolpath(path, *, commanded_mixtures=False):
    """A toolpath JSON, a laser build file (.cli, ASCII or binary), a 3MF toolpath (the 3MF
    Toolpath Extension, docs/formats.md), or G-code / .nc (read back into design coordinates), as
    a ``Toolpath``. Graded G-code with a mixing look-ahead reads with each path's mixture as
    deposited, or as commanded with ``commanded_mixtures=True``."""
    return Toolpath(_trellis.read_toolpath(os.fspath(path), commanded_mixtures))


# Every route of the table has its function: those above, else one made from its row.
for _spec in _trellis.routes():
    if _spec["name"] not in globals():
        globals()[_spec["name"]] = _route_function(_spec)
        __all__.append(_spec["name"])
