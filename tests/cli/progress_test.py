#!/usr/bin/env python3
"""Progress on stderr (issue 46, item 4), as a user sees it.

  progress_test.py TRELLIS SOURCE_DIR

- Into a pipe without --progress: nothing but the run's own lines (no progress, no estimate).
- Into a pipe with --progress: each estimate made before the run, then plain lines
  "trellis pbf: layers 40%  ETA 3 s", one per line, the % never falling within a stage, the
  stage reaching 100%, at least one ETA.
- --progress=false (--no-progress) under a terminal: nothing.
- Under a terminal (a pty) without asking: the line redrawn in place (carriage returns, the
  rest of the line erased), an ETA, and the line cleared before the summary is printed.
- `trellis render` and a non-planar run with normal offsets (the loops the issue found silent)
  report their own stages.
- A run refused by its estimate says so in well under 2 s, naming the estimate and the setting.
"""
import os
import pty
import re
import select
import subprocess
import sys
import tempfile
import time

TRELLIS = os.path.abspath(sys.argv[1])
SRC = os.path.abspath(sys.argv[2])
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL", what)


# A job of about 3 s of CPU on one thread (2,400 layers): long enough for several plain lines (one
# a second), an ETA and the terminal form (shown after a second) even on a fast, idle machine.
PBF = ["pbf", "--size", "6,6,48", "--threads", "1"]
LINE = re.compile(r"^trellis pbf: (\S.*?) +(\d+)%(?:  ETA (.+))?$")


def pipe_run(args, cwd):
    return subprocess.run([TRELLIS] + args, cwd=cwd, capture_output=True, text=True)


def pty_run(args, cwd):
    """stderr of a run under a pseudo-terminal (stdout to a pipe), raw."""
    master, slave = pty.openpty()
    p = subprocess.Popen([TRELLIS] + args, cwd=cwd, stdout=subprocess.PIPE, stderr=slave)
    os.close(slave)
    data = b""
    while True:
        r, _, _ = select.select([master], [], [], 0.5)
        if r:
            try:
                chunk = os.read(master, 4096)
            except OSError:
                break
            if not chunk:
                break
            data += chunk
        elif p.poll() is not None:
            break
    out = p.stdout.read().decode()
    p.wait()
    os.close(master)
    return p.returncode, out, data.decode(errors="replace")


with tempfile.TemporaryDirectory() as d:
    # Not asked, not a terminal: silent.
    r = pipe_run(PBF + ["-o", "a.cli"], d)
    check(r.returncode == 0, f"pbf failed: {r.stderr}")
    check("%" not in r.stderr and "estimate" not in r.stderr,
          f"progress into a pipe without --progress: {r.stderr!r}")

    # Asked, into a pipe: estimates, then plain lines.
    r = pipe_run(PBF + ["-o", "b.cli", "--progress"], d)
    check(r.returncode == 0, f"pbf --progress failed: {r.stderr}")
    lines = r.stderr.splitlines()
    check("\r" not in r.stderr and "\033" not in r.stderr, "plain lines carry terminal controls")
    estimates = [l for l in lines if re.match(r"^trellis pbf: estimate [0-9.e+-]+ s, \d+ MB: \S", l)]
    check(len(estimates) >= 1, f"no estimate line: {lines}")
    progress = [LINE.match(l) for l in lines if "estimate" not in l and "%" in l]
    check(all(progress) and len(progress) >= 3, f"progress lines: {lines}")
    progress = [m for m in progress if m]
    stages = {}
    for m in progress:
        pct = int(m.group(2))
        check(pct >= stages.get(m.group(1), -1), f"% fell within stage {m.group(1)}: {lines}")
        stages[m.group(1)] = pct
    check(stages.get("layers") == 100, f"the layers stage never reached 100%: {lines}")
    etas = [m.group(3) for m in progress if m.group(3)]
    check(len(etas) >= 1 and all(re.match(r"^\d+ s$|^\d+ min \d\d s$", e) for e in etas),
          f"no ETA in the progress lines: {lines}")

    # A terminal, not asked: one line redrawn in place, cleared at the end.
    rc, out, err = pty_run(PBF + ["-o", "c.cli"], d)
    check(rc == 0, f"pbf under a pty failed: {err}")
    draws = err.count("\r")
    check(draws >= 3, f"under a terminal, {draws} redraws: {err!r}")
    check("\033[K" in err, f"no erase-line in the terminal form: {err!r}")
    check(err.endswith("\r\033[K") or err.rstrip("\n").endswith("\r\033[K"),
          f"the progress line is not cleared at the end: {err[-80:]!r}")
    check("ETA" in err, f"no ETA on the terminal: {err!r}")
    check("estimate" not in err, "estimates on a terminal without --progress")
    check("wrote c.cli" in out, f"summary missing: {out!r}")

    # A terminal, --no-progress: nothing.
    rc, out, err = pty_run(PBF + ["-o", "d.cli", "--no-progress"], d)
    check(rc == 0 and "%" not in err, f"--no-progress under a terminal: {err!r}")

    # The loops the issue found silent: render's layers and normal offsets.
    r = pipe_run(["pbf", "--size", "3,3,1", "-o", "e.cli", "--toolpath", "e.json"], d)
    check(r.returncode == 0, f"pbf toolpath: {r.stderr}")
    r = pipe_run(["render", "e.json", "-o", "png", "--image-size", "200", "--progress"], d)
    check(r.returncode == 0 and re.search(r"^trellis render: layers 100%$", r.stderr, re.M)
          and re.search(r"^trellis render: estimate .* image\(s\) of 200 x 200 px", r.stderr, re.M),
          f"render --progress: {r.stderr!r}")
    fresh = os.path.join(SRC, "profiles", "fresh_nonplanar_2syringe.toml")
    r = pipe_run(["nonplanar", "--machine", fresh, "--set", "surface.kind=corrugation",
                  "--layers", "2", "--offset", "normal", "--bead-width", "0.8", "-o", "f.gcode",
                  "--progress"], d)
    check(r.returncode == 0 and re.search(r"^trellis nonplanar: normal offsets 100%$", r.stderr, re.M)
          and "(normal offsets)" in r.stderr, f"nonplanar normal --progress: {r.stderr!r}")

    # Refused by the estimate: fast, with the estimate and the setting to change.
    r = pipe_run(["lattice3d", "--cell-type", "octet", "--cell", "7", "--count", "3,3,2", "-o",
                  "octet.json"], d)
    check(r.returncode == 0, f"lattice3d: {r.stderr}")
    for args, setting in [
            (["pbf", "--cell", "250", "--size", "100,100,100", "--max-time", "10", "-o", "g.cli"],
             "run.max_time"),
            (["plan", "aero", "octet.json", "--tries", "100000", "--max-time", "10", "-o", "h.json",
              "--machine", os.path.join(SRC, "profiles", "embedded_aero_410um.toml")], "aero.tries"),
            (["render", "e.json", "-o", "png2", "--image-size", "8000", "--max-time", "1"], "run.max_time"),
            (["nonplanar", "--machine", fresh, "--set", "surface.kind=corrugation", "--layers", "200",
              "--offset", "normal", "--max-time", "60", "-o", "i.gcode"], "nonplanar.layers")]:
        t = time.monotonic()
        r = pipe_run(args, d)
        took = time.monotonic() - t
        check(r.returncode == 2 and "refused before starting" in r.stderr and "(estimate)" in r.stderr
              and setting in r.stderr, f"{args[0]} not refused with {setting}: {r.stderr!r}")
        check(took < 2.0, f"{args[0]}: refused after {took:.2f} s")
        check(not [f for f in os.listdir(d) if f[0] in "ghi" and f.endswith((".cli", ".json", ".gcode"))],
              f"{args[0]}: a refused run wrote a file")

if failures:
    sys.exit(f"{len(failures)} failure(s)")
print("progress: all checks passed")
