#!/usr/bin/env python3
"""The estimates made before a run, against what the run measured.

Runs a spread of small-to-medium jobs across the routes, each with --progress into a pipe (its
stderr carries the estimates: "trellis ROUTE: estimate S s, M MB: what") and --threads 1, and
measures the child's CPU time (user + system, from wait4) and peak RSS. CPU time, not wall time:
on a machine shared with other builds the wall time of a one-thread run is its CPU time plus the
time it waited for a core, which says nothing about the estimate. The estimates are for one
thread here (run.threads = 1), so the CPU time is what they predict.

  bench/estimate_calibration.py --trellis build/release/apps/trellis/trellis --source .
  ... --check   exit 1 unless every job's estimate is within FACTOR (3) of the measure both ways:
                time for jobs that ran at least --min-cpu (0.3 s) of CPU, memory for jobs that
                peaked at --min-mb (50 MB) or more (the process's own baseline, measured on a
                tiny job, added to the estimate)

Prints a table (and --json FILE writes it) with the machine's load average.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ESTIMATE = re.compile(r"^trellis [^:]*: estimate ([0-9.e+-]+) s, ([0-9.e+-]+) MB: (.*)$")


def run(argv, cwd):
    """(returncode, stdout, stderr, cpu seconds, peak RSS MB) of one child."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(argv, cwd=cwd, stdout=out, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return (p.returncode, out.read().decode(errors="replace"), err.read().decode(errors="replace"),
                usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0)


def jobs(src):
    prof = os.path.join(src, "profiles")
    bracket = os.path.join(src, "examples", "designs", "csg_bracket.vcad")
    fdm = os.path.join(prof, "ender3_s1_pro_tpu.toml")
    aero = os.path.join(prof, "embedded_aero_410um.toml")
    fresh = os.path.join(prof, "fresh_nonplanar_2syringe.toml")
    # Inputs made first (not measured).
    setup = [
        ["lattice2d", "--size", "100,100", "-o", "hc100.json"],
        ["lattice3d", "--cell-type", "octet", "--cell", "7", "--count", "3,3,2", "-o", "octet.json"],
        ["slice", bracket, "--machine", fdm, "-o", "bracket.gcode", "--toolpath", "bracket.json"],
    ]
    measured = [
        ("lattice2d honeycomb 100 mm", ["lattice2d", "--size", "100,100", "-o", "a.json"]),
        ("lattice2d voronoi 15 mm", ["lattice2d", "--pattern", "voronoi", "--density", "2",
                                     "--size", "15,15", "-o", "b.json"]),
        ("lattice3d foam", ["lattice3d", "--set", "lattice3d.kind=foam", "-o", "c.json"]),
        ("lattice3d 20 x 20 x 20 cells", ["lattice3d", "--cell-type", "octet", "--count", "20,20,20",
                                          "-o", "c2.json"]),
        ("plan gippo 100 iterations", ["plan", "gippo", "hc100.json", "-o", "d.json",
                                       "--iterations", "100"]),
        ("plan aero 300 tries", ["plan", "aero", "octet.json", "-o", "e.json", "--machine", aero,
                                 "--tries", "300"]),
        ("pbf gyroid 6 mm", ["pbf", "--size", "6,6,6", "-o", "f.cli"]),
        ("pbf gyroid 6 mm, toolpath kept", ["pbf", "--size", "6,6,6", "-o", "f2.cli",
                                            "--toolpath", "f2.json"]),
        ("pbf 250 mm cell in 10 mm", ["pbf", "--cell", "250", "--size", "10,10,10", "-o", "g.cli"]),
        ("slice bracket", ["slice", bracket, "--machine", fdm, "-o", "h.gcode"]),
        ("nonplanar vertical", ["nonplanar", "--machine", fresh, "--set", "surface.kind=corrugation",
                                "--layers", "12", "-o", "i.gcode"]),
        ("nonplanar normal 3 layers", ["nonplanar", "--machine", fresh, "--set",
                                       "surface.kind=corrugation", "--layers", "3", "--offset",
                                       "normal", "-o", "j.gcode"]),
        ("render 122 layers 400 px", ["render", "bracket.json", "-o", "png/k", "--image-size", "400"]),
    ]
    return setup, measured


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trellis", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--factor", type=float, default=3.0)
    ap.add_argument("--min-cpu", type=float, default=0.3)
    ap.add_argument("--min-mb", type=float, default=50,
                    help="memory is checked for jobs whose peak is at least this (the work, not "
                         "the process, dominates)")
    ap.add_argument("--only", help="run only the jobs whose name contains this")
    ap.add_argument("--json")
    a = ap.parse_args()
    trellis = os.path.abspath(a.trellis)
    src = os.path.abspath(a.source)
    setup, measured = jobs(src)
    failures = []
    rows = []
    with tempfile.TemporaryDirectory() as d:
        os.mkdir(os.path.join(d, "png"))
        for argv in setup:
            rc, out, err, _, _ = run([trellis] + argv, d)
            if rc:
                sys.exit(f"setup failed: trellis {' '.join(argv)}\n{err}")
        _, _, _, _, baseline = run([trellis, "lattice2d", "--size", "3,3", "-o", "tiny.json"], d)
        for name, argv in measured:
            if a.only and a.only not in name:
                continue
            rc, out, err, cpu, rss = run([trellis] + argv + ["--progress"] +
                                         ([] if argv[0] == "render" else ["--threads", "1"]), d)
            est = [ESTIMATE.match(l) for l in err.splitlines()]
            est = [(float(m.group(1)), float(m.group(2)), m.group(3)) for m in est if m]
            if rc or not est:
                failures.append(f"{name}: exit {rc}, {len(est)} estimate(s)\n{err[-800:]}")
                continue
            seconds = sum(e[0] for e in est)
            mb = max(e[1] for e in est) + baseline
            row = {"job": name, "estimate_s": seconds, "cpu_s": cpu, "estimate_mb": mb, "peak_mb": rss,
                   "estimates": [e[2] for e in est]}
            rows.append(row)
            if cpu >= a.min_cpu and not (cpu / a.factor <= seconds <= cpu * a.factor):
                failures.append(f"{name}: estimated {seconds:.3g} s, measured {cpu:.3g} s of CPU")
            if rss >= a.min_mb and not (rss / a.factor <= mb <= rss * a.factor):
                failures.append(f"{name}: estimated {mb:.0f} MB (with the {baseline:.0f} MB baseline), "
                                f"measured a peak of {rss:.0f} MB")
    load = open("/proc/loadavg").read().split()[:3] if os.path.exists("/proc/loadavg") else []
    print(f"{'job':32} {'est s':>8} {'cpu s':>8} {'ratio':>6} {'est MB':>8} {'peak MB':>8} {'ratio':>6}")
    for r in rows:
        print(f"{r['job']:32} {r['estimate_s']:8.3g} {r['cpu_s']:8.3g} "
              f"{r['estimate_s'] / max(r['cpu_s'], 1e-9):6.2f} {r['estimate_mb']:8.0f} {r['peak_mb']:8.0f} "
              f"{r['estimate_mb'] / max(r['peak_mb'], 1e-9):6.2f}")
    print(f"baseline {baseline:.0f} MB; {os.cpu_count()} cores, load average {' '.join(load)}; "
          f"time checked for jobs of at least {a.min_cpu} s CPU, memory for peaks of at least "
          f"{a.min_mb:.0f} MB")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"rows": rows, "baseline_mb": baseline, "load": load}, f, indent=1)
    for f in failures:
        print("FAIL", f)
    if a.check and failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
