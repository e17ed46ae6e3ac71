#!/usr/bin/env python3
"""Same reports before and after a change to the G-code reader: `trellis analyze` (and, given
--lattice, `trellis check LATTICE FILE`) of each file with a baseline build and with this one, the
JSON reports compared (keys that time the run itself left out, as bench/same_bytes.py does),
stdout and stderr too.

Make a baseline before changing anything, as for bench/same_bytes.py:
    mkdir -p /tmp/base && cp build/release/apps/trellis/trellis build/release/src/libtrellis.so.0.1 /tmp/base/
Then, after the change and a build:
    bench/analyze_same.py /tmp/base FILE.gcode... [--build build/release] [--hostile] [--lattice L]
--hostile adds, for each file, a copy in hostile spellings (lower case, tabs, CRLF, comments,
line numbers and checksums, bad lines, no newline at the end; made here, seeded).
Exit 0 when every report is the same, 1 otherwise.
"""
import argparse
import json
import os
import random
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DROP = {"seconds", "time_s", "peak_memory_mb"}


def clean(o):
    if isinstance(o, dict):
        return {k: clean(v) for k, v in o.items()
                if k not in DROP and not k.endswith("_seconds") and "elapsed" not in k}
    if isinstance(o, list):
        return [clean(v) for v in o]
    return o


def hostile(text, seed):
    rng = random.Random(seed)
    out = []
    for n, line in enumerate(text.split("\n")):
        pick = rng.randrange(12)
        if pick == 0:
            line = line.lower()
        elif pick == 1:
            line = line.replace(" ", "\t")
        elif pick == 2:
            line += "\r"
        elif pick == 3:
            line += " ; a comment G1 X5"
        elif pick == 4:
            line = f"N{n} {line}*71"
        elif pick == 5:
            line = "   " + line + "   "
        elif pick == 6:
            line += " (note)"
        elif pick == 7 and rng.random() < 0.05:
            line = "G1 X1e5 Y2"
        elif pick == 8 and rng.random() < 0.05:
            line = "G1 X Y"
        elif pick == 9:
            line = line.replace(" ", "  ")
        out.append(line)
    return "\n".join(out).rstrip("\n")


def report(binary, libdir, route, path, work, lattice=None):
    env = dict(os.environ)
    if libdir:
        env["LD_LIBRARY_PATH"] = libdir
        env["TRELLIS_MODULE_DIR"] = libdir
    out = os.path.join(work, "report.json")
    if os.path.exists(out):
        os.remove(out)
    args = [binary, route] + ([lattice] if route == "check" else []) + [path, "--report", out]
    p = subprocess.run(args, env=env, capture_output=True, text=True)
    data = clean(json.load(open(out))) if os.path.exists(out) else None
    return p.returncode, data, p.stdout, p.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("base", help="folder holding the baseline trellis and libtrellis.so.0.1")
    ap.add_argument("files", nargs="+")
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--hostile", action="store_true")
    ap.add_argument("--lattice", help="a lattice file: `check` each file against it too")
    a = ap.parse_args()
    new_bin = os.path.join(a.build, "apps", "trellis", "trellis")
    base_bin = os.path.join(a.base, "trellis")
    bad = 0
    with tempfile.TemporaryDirectory(prefix="analyze_same.") as work:
        files = list(a.files)
        if a.hostile:
            for k, f in enumerate(a.files):
                h = os.path.join(work, f"hostile_{k}_" + os.path.basename(f))
                with open(f, encoding="latin-1") as src, open(h, "w", encoding="latin-1", newline="") as dst:
                    dst.write(hostile(src.read(), k))
                files.append(h)
        for f in files:
            for route in ("analyze", "check") if a.lattice else ("analyze",):
                base = report(base_bin, a.base, route, f, work, a.lattice)
                new = report(new_bin, None, route, f, work, a.lattice)
                same = base[0] == new[0] and base[1] == new[1] and base[2] == new[2] and base[3] == new[3]
                print(f"{route:8s} {os.path.basename(f):40s} exit {base[0]}/{new[0]}  "
                      f"{'same' if same else 'DIFFERENT'}")
                if not same:
                    bad += 1
                    for i, what in ((1, "report"), (2, "stdout"), (3, "stderr")):
                        if base[i] != new[i]:
                            print(f"    {what} differs")
    n = len(files) * (2 if a.lattice else 1)
    print(f"{n - bad} of {n} reports the same")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
