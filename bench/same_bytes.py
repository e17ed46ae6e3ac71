#!/usr/bin/env python3
"""Same bytes before and after a change: every example job run with two builds, outputs compared.

A refactor (issue 42) must leave every output as it was. This runs each job under examples/jobs
with a baseline library and with this build's, in two folders laid out alike (so the job header
each output embeds names the same paths), and compares every file: byte for byte, except JSON
whose run timings and memory (keys `seconds`, `time_s`, `peak_memory_mb`, `*_seconds`,
`*elapsed*`) are left out, and G-code lines that print the run's own time. It also times both
runs per job and prints the ratio (noisy on a shared machine: read it as a range, not a verdict).

Make a baseline before changing anything (the binary finds its library through its RUNPATH,
which LD_LIBRARY_PATH overrides):
    mkdir -p /tmp/base && cp build/release/apps/trellis/trellis build/release/src/libtrellis.so.0.1 \
        build/release/src/trellis/trellis_*.so /tmp/base/
Then, after the change and a build:
    bench/same_bytes.py /tmp/base [--build build/release] [--jobs a.toml b.toml] [--slow]
A job whose input is another job's output (tiny_gcode reads tiny_plan's) fails alike on both
sides unless that output exists. Exit 0 when every output is the same, 1 otherwise (the differing files are listed).
"""
import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Jobs over a minute on this machine: run only with --slow.
SLOW = {"palette_plate_fgm.toml"}
DROP = {"seconds", "time_s", "peak_memory_mb"}


def clean(o):
    if isinstance(o, dict):
        return {k: clean(v) for k, v in o.items()
                if k not in DROP and not k.endswith("_seconds") and "elapsed" not in k}
    if isinstance(o, list):
        return [clean(v) for v in o]
    return o


def digest(path):
    b = open(path, "rb").read()
    if path.endswith(".json"):
        try:
            return hashlib.sha1(json.dumps(clean(json.loads(b)), sort_keys=True).encode()).hexdigest()
        except ValueError:
            pass
    return hashlib.sha1(b).hexdigest()


def tree(d):
    out = {}
    for root, _, files in os.walk(d):
        for f in files:
            p = os.path.join(root, f)
            out[os.path.relpath(p, d)] = digest(p)
    return out


def run(binary, libdir, job, work):
    """Runs `trellis run JOB -o out` in `work`; returns (seconds, exit code, stderr)."""
    env = dict(os.environ)
    if libdir:
        env["LD_LIBRARY_PATH"] = libdir + (":" + env["LD_LIBRARY_PATH"] if env.get("LD_LIBRARY_PATH") else "")
        env["TRELLIS_MODULE_DIR"] = libdir  # the loadable modules (cairo, CGAL, OpenVDB, 3MF)
    t = time.monotonic()
    p = subprocess.run([binary, "run", job, "-o", "out", "--no-progress"], cwd=work, env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return time.monotonic() - t, p.returncode, p.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("base", help="folder holding the baseline trellis, libtrellis.so.0.1 and trellis_*.so")
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--jobs", nargs="*", help="job files (default: examples/jobs/*.toml)")
    ap.add_argument("--slow", action="store_true", help="include the jobs over a minute")
    a = ap.parse_args()
    jobs = a.jobs or sorted(os.path.join(ROOT, "examples", "jobs", f)
                            for f in os.listdir(os.path.join(ROOT, "examples", "jobs"))
                            if f.endswith(".toml") and (a.slow or f not in SLOW))
    new_bin = os.path.join(a.build, "apps", "trellis", "trellis")
    base_bin = os.path.join(a.base, "trellis")
    work = tempfile.mkdtemp(prefix="same_bytes.")
    bad = 0
    try:
        for job in jobs:
            job = os.path.abspath(job)
            name = os.path.basename(job)
            dirs = {}
            times = {}
            for side, binary, lib in (("base", base_bin, a.base), ("new", new_bin, None)):
                d = os.path.join(work, name, side)
                os.makedirs(d)
                times[side], code, err = run(binary, lib, job, d)
                if code:
                    print(f"{name}: {side} exit {code}: {err.strip().splitlines()[-1:]}")
                dirs[side] = tree(os.path.join(d, "out"))
            diff = sorted(f for f in set(dirs["base"]) | set(dirs["new"])
                          if dirs["base"].get(f) != dirs["new"].get(f))
            ratio = times["new"] / times["base"] if times["base"] > 0 else float("nan")
            state = "same" if not diff else f"{len(diff)} of {len(dirs['base'])} files differ"
            print(f"{name:32s} {len(dirs['new']):4d} files  {state:28s} time new/base {ratio:.2f}"
                  f" ({times['new']:.1f} s / {times['base']:.1f} s)")
            for f in diff[:20]:
                print(f"    {f}: {'missing in base' if f not in dirs['base'] else 'missing in new' if f not in dirs['new'] else 'differs'}")
            bad += bool(diff)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(jobs) - bad} of {len(jobs)} jobs give the same outputs")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
