#!/usr/bin/env python3
"""Writes trellis/__init__.pyi (type stubs with every route's keywords) from the settings schema.

usage: PYTHONPATH=build/release/python python3 python/gen_stubs.py > python/trellis/__init__.pyi
A test fails when the checked-in stubs differ from what this prints.
"""
import os
import sys

# The built package (PYTHONPATH), not the sources beside this script.
sys.path = [p for p in sys.path if os.path.abspath(p or ".") != os.path.dirname(os.path.abspath(__file__))]
import trellis  # noqa: E402
from trellis import _trellis  # noqa: E402

PY = {"number": "float", "integer": "int", "bool": "bool", "text": "str", "numbers": "Sequence[float]"}

ROUTES = [
    ("lattice2d", "lattice2d", "output: PathLike | None = None, *, preview: PathLike | None = None", "Result"),
    ("lattice3d", "lattice3d", "output: PathLike | None = None, *, preview: PathLike | None = None", "Result"),
    ("plan", "gippo", "planner: Literal['gippo', 'euler', 'aero'], lattice: PathLike | Lattice, "
     "output: PathLike | None = None, *, machine: Machine | None = None, gcode: PathLike | None = None, "
     "report: PathLike | None = None, preview: PathLike | None = None", "Result"),
    ("gcode", "gcode", "toolpath: PathLike | Toolpath, output: PathLike | None = None, *, machine: Machine",
     "Result"),
    ("slice", "slice", "design: PathLike | Field, output: PathLike | None = None, *, machine: Machine, "
     "report: PathLike | None = None, toolpath: PathLike | None = None, preview: PathLike | None = None",
     "Result"),
    ("pbf", "pbf", "output: PathLike | None = None, *, envelope: PathLike | Field | None = None, "
     "machine: Machine | None = None, report: PathLike | None = None, toolpath: PathLike | None = None, "
     "preview: PathLike | None = None", "Result"),
    ("nonplanar", "nonplanar", "surface: PathLike | None = None, output: PathLike | None = None, *, "
     "machine: Machine, report: PathLike | None = None, toolpath: PathLike | None = None, "
     "preview: PathLike | None = None", "Result"),
    ("surface", "surface", "kind: str, output: PathLike | None = None, *, machine: Machine | None = None, "
     "preview: PathLike | None = None", "Result"),
]


# The reader routes (trellis check, analyze): their keywords are their settings (job/readers.hpp).
READERS = [
    ("analyze", "gcode: PathLike | Toolpath, design: PathLike | Lattice | None = None, *"),
    ("check", "lattice: PathLike | Lattice, print_file: PathLike | Toolpath, *"),
]


def keyword_line(s, name):
    t = "Literal[" + ", ".join(repr(c) for c in s["choices"]) + "]" if s["kind"] == "choice" else PY[s["kind"]]
    return f"    {name}: {t} = ...,  # {s['key']}: {s['doc']}"[:200]


def main():
    info = {s["key"]: s for s in _trellis.settings()}
    out = ['"""Type stubs generated from the settings schema by python/gen_stubs.py; do not edit."""',
           "from os import PathLike as _PathLike",
           "from typing import Any, Callable, Literal, Mapping, Sequence", "",
           "import numpy as np", "",
           "from .errors import GeometryError, InputError, SettingError, TrellisError", "",
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
    for route, command, head, ret in ROUTES:
        kws = trellis._keywords(route, command if route == "plan" else route)
        if route == "plan":
            for extra in ("euler", "aero"):
                for k, v in trellis._keywords("plan", extra).items():
                    kws.setdefault(k, v)
        params = [keyword_line(info[key], name) for name, key in sorted(kws.items())]
        fn = "slice" if route == "slice" else route
        out.append(f"def {fn}(")
        out.append(f"    {head},")
        out.append("    progress: Progress | None = None,")
        out.append("    set: Mapping[str, Any] | None = None,")
        out += params
        out.append(f") -> {ret}: ...")
        out.append("")
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
    for reader, head in READERS:
        out.append(f"def {reader}(")
        out.append(f"    {head},")
        out.append("    machine: Machine | None = None,")
        out.append("    set: Mapping[str, Any] | None = None,")
        out += [keyword_line(info[key], name) for name, key in sorted(trellis._reader_keywords(reader).items())]
        out.append(") -> dict[str, Any]: ...")
        out.append("")
    print("\n".join(out).rstrip("\n"))


if __name__ == "__main__":
    main()
