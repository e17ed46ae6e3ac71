#!/usr/bin/env python3
"""The library's modules include only the modules below them (docs/architecture.md).

Each folder of include/trellis/ and src/ is a module with a rank; a file may include its own
module and modules of lower rank, never one above it or beside it on the same rank (those are
kept apart so either can change alone). Both `#include "trellis/MOD/..."` and relative
`#include "../MOD/..."` count. The library never includes the front ends (apps/, python/).
A module folder missing from RANK fails the test too: a new module takes its place in the order
here and in docs/architecture.md.
The algorithm modules (NO_JSON) write no JSON: they return results and src/job turns them into
reports (job/reports.hpp), so none of their files includes nlohmann/json (directly, or through
core/json_document.hpp) except the file formats listed in JSON_FORMATS.

Usage: layering_test.py SOURCE_DIR  (exit 1 listing every include against the order).
A self-test first builds a small tree with one include against the order and checks it is caught.
"""
import os
import re
import sys
import tempfile

# The order, lowest first; modules on one rank do not include each other.
RANK = {
    "core": 0,
    "toolpath": 1, "geom": 1,
    "field": 2, "machine": 2,
    "lattice": 3,
    "plan": 4,
    "slice": 5,
    "analysis": 6, "render": 6,
    "view": 7,
    "settings": 8,
    "job": 9,
}
# Modules that return results and write no documents; the files among them that are a JSON file
# format (read and written as such), each with why.
NO_JSON = ("analysis", "geom", "plan", "slice", "toolpath")
JSON_FORMATS = {
    "src/toolpath/json.cpp": "the toolpath JSON file format (docs/formats.md)",
}
JSON_INCLUDE = re.compile(r'^\s*#\s*include\s+[<"](?:nlohmann/|(?:\.\./)*core/json_document\.hpp|'
                          r'trellis/core/json_document\.hpp)', re.M)
INCLUDE = re.compile(r'^\s*#\s*include\s+"(?:trellis/([a-z0-9_]+)/|\.\./([a-z0-9_]+)/|\.\./\.\./(apps|python)/)',
                     re.M)


def violations(root):
    found = []
    for top in ("include/trellis", "src"):
        base = os.path.join(root, top)
        for d, _, files in os.walk(base):
            rel = os.path.relpath(d, base)
            if rel == ".":
                continue
            mod = rel.split(os.sep)[0]
            if mod == "trellis":  # src/trellis/: the build's module output folder, no sources
                continue
            if mod not in RANK:
                found.append(f"{os.path.join(top, rel)}: module '{mod}' has no place in the order")
                continue
            for f in files:
                if not f.endswith((".cpp", ".hpp", ".inc", ".h")):
                    continue
                path = os.path.join(d, f)
                text = open(path, encoding="utf-8", errors="replace").read()
                rel_path = os.path.relpath(path, root).replace(os.sep, "/")
                if mod in NO_JSON and rel_path not in JSON_FORMATS:
                    for m in JSON_INCLUDE.finditer(text):
                        line = text.count("\n", 0, m.start()) + 1
                        found.append(f"{rel_path}:{line}: {mod} writes no JSON (reports are src/job's, "
                                     "job/reports.hpp); a JSON file format is listed in JSON_FORMATS")
                for m in INCLUDE.finditer(text):
                    line = text.count("\n", 0, m.start()) + 1
                    where = f"{os.path.relpath(path, root)}:{line}"
                    if m.group(3):
                        found.append(f"{where}: the library includes the front end {m.group(3)}/")
                        continue
                    other = m.group(1) or m.group(2)
                    if other == mod:
                        continue
                    if other not in RANK:
                        found.append(f"{where}: includes unknown module '{other}'")
                    elif RANK[other] >= RANK[mod]:
                        side = "beside" if RANK[other] == RANK[mod] else "above"
                        found.append(f"{where}: {mod} (rank {RANK[mod]}) includes {other} "
                                     f"(rank {RANK[other]}), {side} it")
    return found


def self_test():
    with tempfile.TemporaryDirectory() as t:
        for mod, body in (("core", '#include "trellis/core/vec.hpp"\n'),
                          ("geom", '#include "trellis/core/vec.hpp"\n#include "../slice/x.hpp"\n'),
                          ("machine", '#include "trellis/field/field.hpp"\n'),
                          ("analysis", '#include <nlohmann/json.hpp>\n'),
                          ("toolpath", '#include "../core/json_document.hpp"\n')):
            os.makedirs(os.path.join(t, "src", mod))
            with open(os.path.join(t, "src", mod, "a.cpp"), "w") as f:
                f.write(body)
        os.makedirs(os.path.join(t, "src", "lattice"))
        with open(os.path.join(t, "src", "lattice", "a.cpp"), "w") as f:  # not an algorithm module
            f.write("#include <nlohmann/json.hpp>\n")
        with open(os.path.join(t, "src", "toolpath", "json.cpp"), "w") as f:  # a listed format
            f.write("#include <nlohmann/json.hpp>\n")
        v = violations(t)
        assert len(v) == 4, v
        assert any(x.startswith("src/analysis/a.cpp:1: analysis writes no JSON") for x in v), v
        assert any(x.startswith("src/toolpath/a.cpp:1: toolpath writes no JSON") for x in v), v
        assert "src/geom/a.cpp:2: geom (rank 1) includes slice (rank 5), above it" in v, v
        assert any("machine (rank 2) includes field (rank 2), beside it" in x for x in v), v


def main():
    self_test()
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    v = violations(root)
    for x in v:
        print(x)
    if v:
        print(f"{len(v)} includes against the layer order (docs/architecture.md)")
        return 1
    print("every include follows the layer order")
    return 0


if __name__ == "__main__":
    sys.exit(main())
