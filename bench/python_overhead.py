#!/usr/bin/env python3
"""Python vs CLI wall time on the same jobs, paired runs in one process tree (the machine is
noisy: quote the ratio's range). Also the cost of reading a 1M-point toolpath as numpy.

    PYTHONPATH=build/release/python /usr/bin/python3 bench/python_overhead.py build/release/apps/trellis/trellis
"""
import os
import statistics
import subprocess
import sys
import tempfile
import time

import trellis

cli = os.path.abspath(sys.argv[1])
root = os.path.join(os.path.dirname(__file__), "..")
ender = os.path.join(root, "profiles", "ender3_s1_pro_tpu.toml")
laser = os.path.join(root, "profiles", "pbf_316l_25um.toml")
bracket = os.path.join(root, "examples", "designs", "csg_bracket.vcad")

jobs = {
    "slice bracket": (lambda out: trellis.slice(bracket, out, machine=ender),
                      ["slice", bracket, "--machine", ender]),
    "pbf 4 cells": (lambda out: trellis.pbf(out, machine=laser, size=(10, 10, 4)),
                    ["pbf", "--machine", laser, "--size", "10,10,4"]),
    "gippo penrose 500": (lambda out: trellis.plan("gippo", lat_file, out, iterations=500),
                          ["plan", "gippo", None, "--iterations", "500"]),
}
with tempfile.TemporaryDirectory() as d:
    lat_file = os.path.join(d, "p.json")
    trellis.lattice2d(lat_file, pattern="penrose", cell=1.2, size=(20, 20))
    for name, (py_call, args) in jobs.items():
        args = [lat_file if a is None else a for a in args]
        ratios = []
        for i in range(5):
            out = os.path.join(d, f"o{i}")
            t0 = time.perf_counter()
            subprocess.run([cli, *args, "-o", out + ".cli_out"], check=True, capture_output=True)
            t_cli = time.perf_counter() - t0
            t0 = time.perf_counter()
            py_call(out + ".py_out")
            t_py = time.perf_counter() - t0
            ratios.append(t_py / t_cli)
        print(f"{name:20s} python/cli wall time: median {statistics.median(ratios):.3f}, "
              f"range {min(ratios):.3f}-{max(ratios):.3f} (5 pairs)")
    tp = trellis.plan("euler", trellis.lattice3d(cell_type="cubic", cell=1, count=(66, 66, 80)).lattice).toolpath
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        tp._arrays = None
        pts = tp.points
        times.append(time.perf_counter() - t0)
    print(f"{tp.point_count} points as one numpy array: median {statistics.median(times) * 1000:.1f} ms "
          f"(range {min(times) * 1000:.1f}-{max(times) * 1000:.1f})")
