#!/usr/bin/env python3
"""Writes trellis/__init__.pyi (type stubs with every route's keywords) from the settings schema.

usage: PYTHONPATH=build/release/python python3 python/gen_stubs.py > python/trellis/__init__.pyi
A test fails when the checked-in stubs differ from what this prints.
"""
import inspect
import os
import sys

# The built package (PYTHONPATH), not the sources beside this script.
sys.path = [p for p in sys.path if os.path.abspath(p or ".") != os.path.dirname(os.path.abspath(__file__))]
import trellis  # noqa: E402
from trellis import _trellis  # noqa: E402

PY = {"number": "float", "integer": "int", "bool": "bool", "text": "str", "numbers": "Sequence[float]",
      "flags": "Sequence[bool]"}

def function_stub(name, fn, choices, keywords, info, ret, extra):
    """`def NAME(` its arguments before `progress`/`set` as the function declares them, `extra`,
    set=, one line per keyword `) -> RET: ...`."""
    head, star = [], False
    for p in inspect.signature(fn).parameters.values():
        if p.name in ("progress", "set") or p.kind == p.VAR_KEYWORD:
            break
        if p.kind == p.KEYWORD_ONLY and not star:
            head.append("*")
            star = True
        note = p.annotation if p.annotation is not p.empty else "Any"
        if choices and not head:  # the first argument: the route's choice setting
            note = "Literal[" + ", ".join(repr(c) for c in choices) + "]"
        if p.kind == p.VAR_POSITIONAL:  # compare(design, *gcode), view(*files): keywords after
            head.append(f"*{p.name}: {note}")
            star = True
            continue
        head.append(f"{p.name}: {note}" + ("" if p.default is p.empty else f" = {p.default!r}"))
    lines = [f"def {name}(", f"    {', '.join(head)},"]
    lines += [f"    {e}," for e in extra]
    lines.append("    set: Mapping[str, Any] | None = None,")
    lines += [keyword_line(info[key], kw) for kw, key in sorted(keywords)]
    return lines + [f") -> {ret}: ...", ""]


def keyword_line(s, name):
    t = "Literal[" + ", ".join(repr(c) for c in s["choices"]) + "]" if s["kind"] == "choice" else PY[s["kind"]]
    return f"    {name}: {t} = ...,  # {s['key']}: {s['doc']}"[:200]


def main():
    info = {s["key"]: s for s in _trellis.settings()}
    out = ['"""Type stubs generated from the settings schema by python/gen_stubs.py; do not edit."""',
           "from os import PathLike as _PathLike",
           "from typing import Any, Callable, Literal, Mapping, Sequence", "",
           "import numpy as np", "",
           "from .errors import GeometryError, InputError, SettingError, TrellisError, TrellisWarning", "",
           "PathLike = str | _PathLike[str]", "Machine = PathLike | Mapping[str, Mapping[str, Any]]", "Progress = Callable[[str, float], None]", "",
           "__version__: str", "ROLES: list[str]", "",
           "class Lattice:",
           "    nodes: np.ndarray", "    edges: np.ndarray", "    material: np.ndarray",
           "    node_count: int", "    edge_count: int", "    total_length: float",
           "    @staticmethod",
           "    def from_arrays(nodes: Any, edges: Any, material: Any = None) -> Lattice: ...",
           "    def write(self, path: PathLike) -> None: ...", "    def to_json(self) -> str: ...", "",
           "class Toolpath:"]
    for a in ["points", "path_offsets", "layer_offsets", "layer_z", "role", "tool", "width", "height",
              "speed", "power", "temperature", "mixture"]:
        out.append(f"    {a}: np.ndarray")
    out += ["    layer_count: int", "    path_count: int", "    point_count: int", "    extrusion_length: float",
            "    lasers: list[dict[str, float | bool]]",
            "    @staticmethod",
            "    def from_arrays(points: Any, path_offsets: Any = None, layer_offsets: Any = None, *, "
            "layer_z: Any = None,",
            "                    role: Any = 'strut', tool: Any = 0, width: Any = 0.0, height: Any = 0.0, "
            "speed: Any = 0.0,",
            "                    power: Any = 0.0, temperature: Any = 0.0, mixture: Any = None) -> Toolpath: ...",
            "    def arrays(self) -> dict[str, np.ndarray]: ...",
            "    def path(self, i: int) -> np.ndarray: ...", "    def to_json(self) -> str: ...",
            "    def gcode(self, machine: Machine | None = None, set: Mapping[str, Any] | None = None) -> str: ...",
            "    def cli(self, machine: Machine | None = None, set: Mapping[str, Any] | None = None, "
            "binary: bool = False) -> bytes: ...",
            "    def png(self, layer: int = 0, size: int = 600) -> bytes: ...",
            "    def view_html(self, title: str | None = None) -> str: ...",
            "    def save_view(self, path: PathLike, title: str | None = None) -> None: ...",
            "    def view_notebook(self, title: str | None = None) -> str: ...", "",
            "class Result:", "    files: list[str]", "    summary: str", "    warnings: list[tuple[str, str]]",
            "    exit_code: int", "    toolpath: Toolpath | None", "    lattice: Lattice | None", ""]
    choices = {s["key"]: s["choices"] for s in info.values()}
    # Every route of the table: its function's own arguments (trellis/__init__.py, annotated
    # there; the choice setting's as its values), then its keywords from the table and schema.
    for spec in _trellis.routes():
        route = spec["name"]
        out += function_stub(route, getattr(trellis, route), choices.get(spec["choice"]),
                             trellis._keywords(route).items(), info, "Result",
                             ["progress: Progress | None = None"])
    out += ["def run_job(job: PathLike | Mapping[str, Mapping[str, Any]], output_dir: PathLike | None = None,",
            "            set: Mapping[str, Any] | None = None, progress: Progress | None = None) -> Result: ...",
            "def rerun(path: PathLike, output: PathLike | None = None) -> list[str]: ...",
            "def settings(route: str | None = None) -> list[dict[str, Any]]: ...",
            "def read_lattice(path: PathLike, merge_tolerance: float = 1e-6) -> Lattice: ...",
            "def read_toolpath(path: PathLike, *, commanded_mixtures: bool = ...) -> Toolpath: ...",
            "def notebook_viewer() -> Any: ...",
           "def parse_vcad(text: str, name: str = ...) -> dict[str, Any]: ...",
           "from .fields import (Field, Mesh, cone, cube, cylinder, difference, fgrade, function, gyroid,",
           "                     intersection, mesh, rectprism, sphere, torus, tpms, union)", ""]
    # The reader routes' functions (trellis.check, analyze, compare, view, render): their
    # keywords are their settings (the route table's readers, RouteSpec::reads), their return
    # what each function says.
    for reader in _trellis.reader_names():
        if hasattr(trellis, reader):
            fn = getattr(trellis, reader)
            sig = inspect.signature(fn)
            extra = ["progress: Progress | None = None"] if "progress" in sig.parameters else []
            out += function_stub(reader, fn, None, trellis._reader_keywords(reader).items(), info,
                                 sig.return_annotation, extra)
    print("\n".join(out).rstrip("\n"))


if __name__ == "__main__":
    main()
