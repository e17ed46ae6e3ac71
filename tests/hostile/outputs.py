"""Outputs that must never lose a file (issue 47), run by hostile_test.py.

Classes, each counted in the summary:
  input      an output that is one of the run's inputs, for every kind of command: exit 2, a
             message naming both roles and the path, nothing written
  two        two outputs on one path: the same
  devnull    /dev/null (and a link to it, and /dev/stdout) as output: exit 0 and /dev/null still
             the character device 1,3 after EVERY run (restored and reported if not)
  fifo       a FIFO output read by a reader process: it gets the file, the FIFO stays a FIFO
  symlink    an output path that is a symbolic link: refused, the link and its file untouched;
             with --follow-symlinks the file it points to is written and the link kept
  empty      an empty path: exit 2, nothing written
  folder     `-o dir/` and the like: exit 2, no folder made
  failed     a job or command failing after it made folders: every folder it made removed
  signal     SIGINT, SIGTERM, SIGHUP during long writes: exit 130/143/129, no temporary and no
             folder left, checked after every run
  stale      temporaries left by kill -9 (and the preview folder holding only them) are removed by
             the next run writing the same output; a live run's temporaries there are kept
"""
import errno
import os
import shutil
import signal
import stat
import subprocess
import tempfile
import threading
import time

TINY_LATTICE = b'{"nodes": [[0,0,0],[10,0,0],[10,10,0],[0,10,0]], "edges": [[0,1],[1,2],[2,3],[3,0]]}\n'
TINY_VCAD = b"root((-5,-5,0),(5,5,2),(0.1,0.1,0.1)) {\ncylinder(2,4);\n}\n"
TEMP_MARK = ".trellis-tmp."
# A closed mesh: a tetrahedron, 10 mm.
TETRA = "".join(
    f"facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {x} {y} {z}\n" for x, y, z in f) + "endloop\nendfacet\n"
    for f in (((0, 0, 0), (0, 10, 0), (10, 0, 0)), ((0, 0, 0), (10, 0, 0), (0, 0, 10)),
              ((0, 0, 0), (0, 0, 10), (0, 10, 0)), ((10, 0, 0), (0, 10, 0), (0, 0, 10))))
TETRA = ("solid t\n" + TETRA + "endsolid t\n").encode()


def root_aero(root):
    return os.path.join(root, "tests", "data", "aero")


class Env:
    def __init__(self, trellis, root):
        self.trellis = trellis
        self.root = root
        self.profile = os.path.join(root, "profiles", "ender3_s1_pro_tpu.toml")
        self.syringe = os.path.join(root, "profiles", "fresh_nonplanar_2syringe.toml")
        self.designs = os.path.join(root, "examples", "designs")
        self.problems = []
        self.counts = {}
        self.template = tempfile.mkdtemp(prefix="hostile_outputs_")
        self.make_inputs()

    def run(self, args, cwd, **kw):
        return subprocess.run([self.trellis] + args, cwd=cwd, capture_output=True, timeout=60, **kw)

    def make_inputs(self):
        d = self.template
        open(os.path.join(d, "l.json"), "wb").write(TINY_LATTICE)
        open(os.path.join(d, "a.vcad"), "wb").write(TINY_VCAD)
        open(os.path.join(d, "t.stl"), "wb").write(TETRA)
        open(os.path.join(d, "m.vcad"), "w").write('root((-1,-1,0),(11,11,10),(0.5,0.5,0.5)) {\nmesh("t.stl");\n}\n')
        for part in ("vertices", "edges"):
            shutil.copy(os.path.join(root_aero(self.root), f"cubic_{part}.csv"), os.path.join(d, f"c_{part}.csv"))
        shutil.copy(self.profile, os.path.join(d, "p.toml"))
        for args in (["plan", "euler", "l.json", "-o", "tp.json"],
                     ["gcode", "tp.json", "--machine", "p.toml", "-o", "g.gcode"],
                     ["surface", "corrugation", "-o", "s.stl"],
                     ["run", "shard.toml", "--shard", "1/1"]):
            if args[0] == "run":
                open(os.path.join(d, "shard.toml"), "w").write(
                    '[job]\nroute = "pbf"\nname = "x"\noutput_dir = "sh"\n[pbf]\nsize = [3, 3, 3]\n'
                    '[output]\npng = false\n')
            r = self.run(args, d)
            if r.returncode != 0:
                raise RuntimeError(f"preparing {args}: {r.stderr.decode()}")

    def folder(self):
        d = tempfile.mkdtemp(prefix="hostile_out_")
        shutil.rmtree(d)
        shutil.copytree(self.template, d, symlinks=True)
        os.makedirs(os.path.join(d, "out"), exist_ok=True)
        open(os.path.join(d, "out", "keep.txt"), "w").write("here before\n")
        return d

    def count(self, cls):
        self.counts[cls] = self.counts.get(cls, 0) + 1

    def fail(self, cls, name, why, err=b""):
        self.problems.append(f"[{cls}] {name}: {why}" + (f"\n    stderr: {err.decode(errors='replace').strip()[:300]}" if err else ""))


def snapshot(folder):
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            p = os.path.join(dirpath, n)
            st = os.lstat(p)
            # Folder mtimes may move (a temporary came and went); contents may not.
            out[os.path.relpath(p, folder)] = (st.st_mode, 0 if stat.S_ISDIR(st.st_mode) else st.st_size,
                                               0 if stat.S_ISDIR(st.st_mode) else st.st_mtime_ns)
    return out


def changes(before, after):
    added = sorted(set(after) - set(before))
    changed = sorted(k for k in before if k in after and after[k] != before[k])
    removed = sorted(set(before) - set(after))
    if added or changed or removed:
        return f"files changed: added {added} changed {changed} removed {removed}"
    return None


def refused(env, cls, name, args, phrases, setup=None):
    """The run is refused (exit 2) naming `phrases`, and the folder is left exactly as it was."""
    d = env.folder()
    try:
        if setup:
            setup(d)
        before = snapshot(d)
        r = env.run(args, d)
        err = r.stderr.decode(errors="replace")
        problems = []
        if r.returncode != 2:
            problems.append(f"exit {r.returncode}, expected 2")
        for ph in phrases:
            if ph not in err:
                problems.append(f"message does not name {ph!r}")
        c = changes(before, snapshot(d))
        if c:
            problems.append(c)
        env.count(cls)
        if problems:
            env.fail(cls, name, "; ".join(problems) + f"\n    {' '.join(args)}", r.stderr)
    finally:
        shutil.rmtree(d, ignore_errors=True)


def job_file(body):
    def setup(d):
        open(os.path.join(d, "job.toml"), "w").write(body)
    return setup


def input_cases(env):
    P = env.profile
    over = "would overwrite"
    cases = [
        ("gcode -o profile", ["gcode", "tp.json", "--machine", "p.toml", "-o", "p.toml"], ["the machine profile", "p.toml"]),
        ("gcode -o toolpath", ["gcode", "tp.json", "--machine", "p.toml", "-o", "tp.json"], ["the input", "tp.json"]),
        ("slice -o design", ["slice", "a.vcad", "--machine", P, "-o", "a.vcad"], ["the input", "a.vcad"]),
        ("slice --toolpath design", ["slice", "a.vcad", "--machine", P, "-o", "out/x.gcode", "--toolpath", "./a.vcad"], ["the input"]),
        ("plan euler -o lattice", ["plan", "euler", "l.json", "-o", "l.json"], ["the toolpath", "the input", "l.json"]),
        ("plan gippo --report lattice", ["plan", "gippo", "l.json", "-o", "out/t.json", "--report", "l.json"], ["the report", "the input"]),
        ("plan --gcode profile", ["plan", "euler", "l.json", "-o", "out/t.json", "--machine", "p.toml", "--gcode", "p.toml"], ["the G-code", "the machine profile"]),
        ("nonplanar -o surface", ["nonplanar", "s.stl", "--machine", env.syringe, "-o", "s.stl"], ["the input", "s.stl"]),
        ("pbf -o design", ["pbf", "a.vcad", "-o", "a.vcad"], ["the input", "a.vcad"]),
        ("lattice3d --mesh", ["lattice3d", "--kind", "foam", "--mesh", "s.stl", "-o", "s.stl"], ["lattice3d.mesh"]),
        ("view -o gcode", ["view", "g.gcode", "-o", "g.gcode"], ["the HTML (-o)", "the file to show", "g.gcode"]),
        ("view -o design", ["view", "tp.json", "--design", "l.json", "-o", "l.json"], ["the design (--design)"]),
        ("render --layer -o toolpath", ["render", "tp.json", "--layer", "0", "-o", "tp.json"], ["the PNG (-o)", "the toolpath"]),
        ("analyze --report gcode", ["analyze", "g.gcode", "--report", "g.gcode"], ["the report (--report)", "the G-code"]),
        ("compare --report design", ["compare", "l.json", "g.gcode", "--report", "l.json"], ["the design"]),
        ("check --report print", ["check", "l.json", "tp.json", "--report", "tp.json"], ["the print"]),
        ("walls -o lattice", ["walls", "l.json", "-o", "l.json"], ["the mesh (-o)", "the lattice"]),
        ("rerun -o its input", ["rerun", "tp.json", "-o", "l.json"], ["the input", "l.json"]),
        ("merge -o a shard", ["merge", "sh/x.cli.shard-1-of-1.json", "-o", "sh/x.cli.shard-1-of-1"], ["the shard"]),
        ("merge -o its manifest", ["merge", "sh/x.cli.shard-1-of-1.json", "-o", "sh/x.cli.shard-1-of-1.json"], ["the shard manifest"]),
        ("hard link", ["walls", "l.json", "-o", "hard.stl"], ["the lattice"]),
    ]
    for name, args, phrases in cases:
        setup = (lambda d: os.link(os.path.join(d, "l.json"), os.path.join(d, "hard.stl"))) if name == "hard link" else None
        refused(env, "input", name, args, [over] + phrases, setup)
    # Inputs no role names, read by the run (an AERO edges file, a design's mesh): an output can
    # only land on them under a name of another format, refused by its name before anything runs.
    for name, args, phrases in [
        ("aero -o its edges file", ["plan", "aero", "c_vertices.csv", "-o", "c_edges.csv"], ["c_edges.csv", "name it so"]),
        ("slice --toolpath the design's mesh", ["slice", "m.vcad", "--machine", P, "-o", "out/x.gcode",
                                                "--toolpath", "t.stl"], ["t.stl", "name it so"]),
    ]:
        refused(env, "input", name, args, phrases)
    refused(env, "input", "job toolpath = its input", ["run", "job.toml"], [over, "the toolpath", "the input"],
            job_file('[job]\nroute = "plan"\nname = "j"\ninput = "l.json"\noutput_dir = "."\ntoolpath = "l.json"\n'
                     '[output]\npng = false\n'))
    refused(env, "input", "job output = the job file", ["run", "job.toml"], [over, "the job file"],
            job_file('[job]\nroute = "lattice2d"\nname = "j"\noutput_dir = "."\noutput = "job.toml"\n'))


def two_output_cases(env):
    P = env.profile
    one = "are one file"
    cases = [
        ("--report = -o", ["plan", "gippo", "l.json", "-o", "out/x.json", "--report", "out/x.json"], ["the toolpath", "the report"]),
        ("--toolpath = --report", ["slice", "a.vcad", "--machine", P, "-o", "out/x.gcode", "--toolpath", "out/t.json", "--report", "out/./t.json"], ["the report", "the toolpath"]),
        ("--gcode = -o", ["plan", "euler", "l.json", "-o", "out/t.json", "--machine", P, "--gcode", "out/t.json"], ["the toolpath", "the G-code"]),
        ("--preview = --report", ["check", "l.json", "tp.json", "--report", "out/r", "--preview", "out/r"], ["the report (--report)", "the preview folder (--preview)"]),
        ("analyze --png = --report", ["analyze", "g.gcode", "--report", "out/r", "--png", "out/r"], ["the report (--report)"]),
        ("pbf --report = -o", ["pbf", "--size", "3,3,3", "-o", "out/x.cli", "--report", "out/x.cli"], ["the output", "the report"]),
    ]
    for name, args, phrases in cases:
        refused(env, "two", name, args, [one] + phrases)
    refused(env, "two", "job toolpath = report", ["run", "job.toml"], [one, "the report", "the toolpath"],
            job_file('[job]\nroute = "plan"\nname = "j"\ninput = "l.json"\noutput_dir = "out"\ntoolpath = "x.json"\n'
                     'report = "x.json"\n'))


def devnull_ok(env, name):
    st = os.stat("/dev/null")
    if stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 3):
        return True
    env.fail("devnull", name, "/dev/null IS NO LONGER THE CHARACTER DEVICE 1,3 (restored)")
    if os.geteuid() == 0:
        os.remove("/dev/null")
        os.mknod("/dev/null", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        os.chmod("/dev/null", 0o666)
    return False


def devnull_cases(env):
    P = env.profile
    cases = [
        ("lattice2d", ["lattice2d", "--size", "10,10", "-o", "/dev/null"]),
        ("lattice3d", ["lattice3d", "--count", "1,1,1", "-o", "/dev/null"]),
        ("plan + report", ["plan", "euler", "l.json", "-o", "/dev/null", "--report", "/dev/null"]),
        ("plan --gcode", ["plan", "euler", "l.json", "-o", "/dev/null", "--machine", P, "--gcode", "/dev/null"]),
        ("gcode", ["gcode", "tp.json", "--machine", "p.toml", "-o", "/dev/null"]),
        ("slice streamed", ["slice", "a.vcad", "--machine", P, "-o", "/dev/null"]),
        ("slice + toolpath + report", ["slice", "a.vcad", "--machine", P, "-o", "/dev/null", "--toolpath", "/dev/null", "--report", "/dev/null"]),
        ("pbf", ["pbf", "--size", "3,3,3", "-o", "/dev/null"]),
        ("surface", ["surface", "corrugation", "-o", "/dev/null"]),
        ("view", ["view", "tp.json", "-o", "/dev/null"]),
        ("render", ["render", "tp.json", "--layer", "0", "-o", "/dev/null"]),
        ("walls", ["walls", "l.json", "-o", "/dev/null"]),
        ("analyze", ["analyze", "g.gcode", "--report", "/dev/null"]),
        ("check", ["check", "l.json", "tp.json", "--report", "/dev/null"]),
        ("rerun", ["rerun", "g.gcode", "-o", "/dev/null"]),
        ("merge", ["merge", "sh/x.cli.shard-1-of-1.json", "-o", "/dev/null"]),
        ("link to /dev/null", ["lattice2d", "--size", "10,10", "-o", "null.json"]),
    ]
    for name, args in cases:
        d = env.folder()
        try:
            if name == "link to /dev/null":
                os.symlink("/dev/null", os.path.join(d, "null.json"))
            before = snapshot(d)
            r = env.run(args, d)
            env.count("devnull")
            ok = devnull_ok(env, name)
            if r.returncode not in (0, 1 if args[0] == "check" else 0):
                env.fail("devnull", name, f"exit {r.returncode}", r.stderr)
            c = changes(before, snapshot(d))
            if ok and c:
                env.fail("devnull", name, c)
        finally:
            shutil.rmtree(d, ignore_errors=True)
    # Every layer's PNG beside a device: refused, nothing written next to /dev/null.
    d = env.folder()
    try:
        before = set(os.listdir("/dev"))
        r = env.run(["render", "tp.json", "-o", "/dev/null"], d)
        env.count("devnull")
        new = sorted(set(os.listdir("/dev")) - before)
        if r.returncode != 2 or new or b"--layer" not in r.stderr:
            env.fail("devnull", "render every layer -o /dev/null", f"exit {r.returncode}, new in /dev: {new}", r.stderr)
        for n in new:
            if n.startswith("null.layer"):
                os.unlink(os.path.join("/dev", n))
        devnull_ok(env, "render every layer -o /dev/null")
    finally:
        shutil.rmtree(d, ignore_errors=True)
    # /dev/stdout into a pipe: the file arrives on stdout.
    d = env.folder()
    r = env.run(["lattice2d", "--size", "10,10", "-o", "/dev/stdout"], d)
    env.count("devnull")
    devnull_ok(env, "/dev/stdout")
    if r.returncode != 0 or b'"nodes"' not in r.stdout:
        env.fail("devnull", "/dev/stdout", f"exit {r.returncode}, lattice on stdout: {b'nodes' in r.stdout}", r.stderr)
    shutil.rmtree(d, ignore_errors=True)


def read_fifo(path, into):
    with open(path, "rb") as f:
        into.append(f.read())


def unblock_reader(fifo, reader):
    """Opens the FIFO for writing so a reader still waiting in open() sees end of file.

    A reader that has already read and closed it is no longer there to open against
    (ENXIO), so the open is retried only while the reader thread lives."""
    for _ in range(50):
        try:
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
            return
        except OSError as e:
            if e.errno != errno.ENXIO:
                raise
        reader.join(0.1)
        if not reader.is_alive():
            return


def fifo_cases(env):
    P = env.profile
    cases = [
        ("lattice2d", ["lattice2d", "--size", "10,10", "-o", "fifo"], b'"nodes"'),
        ("gcode", ["gcode", "tp.json", "--machine", "p.toml", "-o", "fifo"], b"G1 "),
        ("slice streamed", ["slice", "a.vcad", "--machine", P, "-o", "fifo"], b"G1 "),
        ("slice + report", ["slice", "a.vcad", "--machine", P, "-o", "out/x.gcode", "--report", "fifo"], b'"job"'),
        ("pbf", ["pbf", "--size", "3,3,3", "-o", "fifo"], b"$$HEADERSTART"),
        ("view", ["view", "tp.json", "-o", "fifo"], b"<html"),
        ("walls", ["walls", "l.json", "-o", "fifo"], b""),
    ]
    for name, args, marker in cases:
        d = env.folder()
        try:
            fifo = os.path.join(d, "fifo")
            os.mkfifo(fifo)
            before = snapshot(d)
            got = []
            reader = threading.Thread(target=read_fifo, args=(fifo, got), daemon=True)
            reader.start()
            r = env.run(args, d)
            reader.join(2)
            if reader.is_alive():  # trellis never opened it: unblock the reader
                unblock_reader(fifo, reader)
            reader.join(5)
            env.count("fifo")
            data = got[0] if got else b""
            problems = []
            if r.returncode != 0:
                problems.append(f"exit {r.returncode}")
            if not data or marker not in data:
                problems.append(f"the reader got {len(data)} bytes without {marker!r}")
            if not stat.S_ISFIFO(os.lstat(fifo).st_mode):
                problems.append("the FIFO was replaced")
            # The FIFO's times move as it is written; out/x.gcode is an output of its own.
            after = {k: v for k, v in snapshot(d).items() if not k.startswith("out/x.gcode")}
            after["fifo"] = before["fifo"] if stat.S_ISFIFO(after["fifo"][0]) else after["fifo"]
            c = changes(before, after)
            if c:
                problems.append(c)
            if problems:
                env.fail("fifo", name, "; ".join(problems), r.stderr)
        finally:
            shutil.rmtree(d, ignore_errors=True)


def symlink_cases(env):
    P = env.profile
    cases = [
        ("lattice2d -o", ["lattice2d", "--size", "10,10", "-o", "link.json"]),
        ("plan --report", ["plan", "euler", "l.json", "-o", "out/t.json", "--report", "link.json"]),
        ("gcode -o", ["gcode", "tp.json", "--machine", "p.toml", "-o", "link.gcode"]),
        ("slice -o", ["slice", "a.vcad", "--machine", P, "-o", "link.gcode"]),
        ("view -o", ["view", "tp.json", "-o", "link.html"]),
        ("walls -o", ["walls", "l.json", "-o", "link.stl"]),
        ("analyze --report", ["analyze", "g.gcode", "--report", "link.json"]),
        ("run job output", ["run", "job.toml"]),
    ]

    # Each link is named for the format written through it (outputs are refused otherwise).
    def link_name(args):
        return next((a for a in args if a.startswith("link")), "link.json")

    for name, args in cases:
        def setup(d, name=name, args=args):
            if name.startswith("run"):
                open(os.path.join(d, "job.toml"), "w").write(
                    '[job]\nroute = "lattice2d"\nname = "j"\noutput_dir = "out"\noutput = "link.json"\n'
                    '[lattice2d]\nsize = [10, 10]\n')
                open(os.path.join(d, "out", "victim"), "w").write("keep\n")
                os.symlink("victim", os.path.join(d, "out", "link.json"))
            else:
                open(os.path.join(d, "victim"), "w").write("keep\n")
                os.symlink("victim", os.path.join(d, link_name(args)))
        refused(env, "symlink", name, args, ["is a symbolic link", "--follow-symlinks"], setup)
        # Asked: the file it points to is written, the link kept.
        d = env.folder()
        try:
            setup(d)
            link = os.path.join(d, "out", "link.json") if name.startswith("run") else os.path.join(d, link_name(args))
            r = env.run(args + ["--follow-symlinks"], d)
            env.count("symlink")
            victim = open(os.path.join(os.path.dirname(link), "victim"), "rb").read()
            if r.returncode != 0 or not os.path.islink(link) or victim == b"keep\n":
                env.fail("symlink", name + " --follow-symlinks",
                         f"exit {r.returncode}, link kept {os.path.islink(link)}, file written {victim != b'keep'}", r.stderr)
        finally:
            shutil.rmtree(d, ignore_errors=True)


def empty_cases(env):
    P = env.profile
    cases = [
        ["lattice2d", "-o", ""],
        ["lattice3d", "-o", ""],
        ["plan", "euler", "l.json", "-o", ""],
        ["plan", "euler", "l.json", "-o", "out/t.json", "--report", ""],
        ["plan", "euler", "l.json", "-o", "out/t.json", "--machine", P, "--gcode", ""],
        ["gcode", "tp.json", "--machine", "p.toml", "-o", ""],
        ["slice", "a.vcad", "--machine", P, "-o", "out/x.gcode", "--preview", ""],
        ["slice", "a.vcad", "--machine", P, "-o", "out/x.gcode", "--toolpath", ""],
        ["pbf", "--size", "3,3,3", "-o", ""],
        ["surface", "corrugation", "-o", ""],
        ["view", "tp.json", "-o", ""],
        ["render", "tp.json", "-o", ""],
        ["walls", "l.json", "-o", ""],
        ["analyze", "g.gcode", "--report", ""],
        ["check", "l.json", "tp.json", "--preview", ""],
        ["rerun", "tp.json", "-o", ""],
        ["merge", "sh/x.cli.shard-1-of-1.json", "-o", ""],
        ["run", "shard.toml", "-o", ""],
    ]
    for args in cases:
        refused(env, "empty", " ".join(a or "''" for a in args[:1] + args[-2:]), args, ["empty path"])


def folder_cases(env):
    P = env.profile
    cases = [
        ["lattice2d", "--size", "10,10", "-o", "nd/"],
        ["plan", "euler", "l.json", "-o", "nd/"],
        ["plan", "euler", "l.json", "-o", "out/t.json", "--report", "nd/sub/"],
        ["gcode", "tp.json", "--machine", "p.toml", "-o", "nd/x/"],
        ["slice", "a.vcad", "--machine", P, "-o", "nd/"],
        ["view", "tp.json", "-o", "nd/"],
        ["walls", "l.json", "-o", "nd/."],
        ["analyze", "g.gcode", "--report", "nd/"],
        ["lattice2d", "--size", "10,10", "-o", "out"],
    ]
    for args in cases:
        refused(env, "folder", " ".join(args[:1] + args[-2:]), args, ["names a folder"])
    refused(env, "folder", "job lattice = ./", ["run", "job.toml"], ["names a folder"],
            job_file('[job]\nroute = "plan"\nname = "j"\noutput_dir = "fresh"\nlattice = "./"\n'
                     '[lattice2d]\nsize = [10, 10]\n'))
    refused(env, "folder", "job toolpath = sub/", ["run", "job.toml"], ["names a folder"],
            job_file('[job]\nroute = "plan"\nname = "j"\ninput = "l.json"\noutput_dir = "fresh/deep"\n'
                     'toolpath = "sub/"\n'))


def failed_cases(env):
    # Each fails after it made folders and staged outputs: everything it made goes again.
    refused(env, "failed", "job preview inside its toolpath", ["run", "job.toml"], ["j.toolpath.json"],
            job_file('[job]\nroute = "plan"\nname = "j"\ninput = "l.json"\noutput_dir = "fresh/deep"\n'
                     'preview = "j.toolpath.json/p"\n'))
    refused(env, "failed", "plan preview inside its toolpath",
            ["plan", "euler", "l.json", "-o", "fresh/a/t.json", "--report", "fresh/a/r.json", "--preview", "fresh/a/t.json/p"],
            ["t.json"])

    # Two outputs on one path only the run sees (a preview's name): refused when it comes.
    refused(env, "failed", "job lattice = its first preview", ["run", "job.toml"], ["layer_0000.png"],
            job_file('[job]\nroute = "plan"\nname = "x"\noutput_dir = "fresh/x"\nmachine = "p.toml"\n'
                     'preview = "p"\nlattice = "p/layer_0000.png"\n[lattice2d]\ncell = 5\nsize = [40, 20]\n'))
    refused(env, "failed", "job of a missing input", ["run", "job.toml"], ["missing.json"],
            job_file('[job]\nroute = "plan"\nname = "j"\ninput = "missing.json"\noutput_dir = "fresh/deep"\n'))


def temporaries(folder):
    return sorted(os.path.relpath(os.path.join(p, n), folder)
                  for p, _, files in os.walk(folder) for n in files if TEMP_MARK in n)


def signal_cases(env):
    """Each signal during long writes: its exit status, and the folder as it was after every run."""
    designs = env.designs
    long_runs = [
        ["pbf", "--size", "12,12,12", "--threads", "1", "-o", "out/x.cli"],
        ["slice", os.path.join(designs, "csg_bracket.vcad"), "--resolution", "0.02", "--threads", "1",
         "--machine", env.profile, "-o", "fresh/x.gcode", "--report", "fresh/r.json"],
        ["run", "long.toml"],
    ]
    job = ('[job]\nroute = "pbf"\nname = "x"\noutput_dir = "fresh/x"\n[pbf]\nsize = [12, 12, 12]\n'
           '[run]\nthreads = 1\n')
    interrupted = {}
    for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)):
        interrupted[sig.name] = 0
        for args in long_runs:
            for delay in (0.3, 1.5):
                d = env.folder()
                try:
                    open(os.path.join(d, "long.toml"), "w").write(job)
                    before = snapshot(d)
                    p = subprocess.Popen([env.trellis] + args, cwd=d, stdout=subprocess.DEVNULL,
                                         stderr=subprocess.PIPE)
                    time.sleep(delay)
                    p.send_signal(sig)
                    try:
                        _, err = p.communicate(timeout=20)
                    except subprocess.TimeoutExpired:
                        p.kill()
                        p.communicate()
                        env.fail("signal", f"{sig.name} {' '.join(args)}", "did not stop")
                        continue
                    if p.returncode == 0:
                        continue  # finished before the signal: nothing to check
                    interrupted[sig.name] += 1
                    env.count("signal " + sig.name)
                    name = f"{sig.name} after {delay} s {' '.join(args[:2])}"
                    if p.returncode != code:
                        env.fail("signal", name, f"exit {p.returncode}, expected {code}", err)
                    # It says what was stopped and that nothing was written.
                    said = err.decode(errors="replace")
                    if f"trellis {args[0]} " not in said or "nothing was written" not in said:
                        env.fail("signal", name, "no message naming the command and what was left",
                                 err)
                    c = changes(before, snapshot(d))
                    if c:
                        env.fail("signal", name, c)
                finally:
                    shutil.rmtree(d, ignore_errors=True)
    for sig, n in interrupted.items():
        if n < 3:
            env.fail("signal", sig, f"only {n} run(s) were still running when signalled")


def owner(temporary):
    """The PID in a temporary's name (.NAME.trellis-tmp.PID.XXXXXX)."""
    return int(os.path.basename(temporary).split(TEMP_MARK)[1].split(".")[0])


def start_until_temporary(env, args, d, mark):
    """Starts a run; returns it and its temporaries once one named `mark`... is in out/."""
    p = subprocess.Popen([env.trellis] + args, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.monotonic()
    while p.poll() is None and time.monotonic() - t0 < 60:
        mine = [t for t in temporaries(os.path.join(d, "out")) if owner(t) == p.pid]
        if any(t.startswith(mark) for t in mine):
            return p, mine
        time.sleep(0.002)
    return p, []


def stale_cases(env):
    """kill -9 while a temporary exists (the output's, and previews' in a folder the run made);
    the next run writing the same output removes every temporary of the killed run and the preview
    folder that held only those, and keeps the temporaries of a live run writing there too."""
    long_runs = [
        ("pbf", "x.cli", ["pbf", "--size", "12,12,12", "--threads", "1", "-o", "out/x.cli", "--preview", "out/p"],
         ["pbf", "--size", "3,3,3", "-o", "out/x.cli"]),
        ("slice", "x.gcode", ["slice", os.path.join(env.designs, "csg_bracket.vcad"), "--threads", "1", "--machine",
                              env.profile, "-o", "out/x.gcode", "--preview", "out/p", "--preview-layers", "200"],
         ["slice", "a.vcad", "--machine", env.profile, "-o", "out/x.gcode"]),
        ("run", "x.cli", ["run", "long.toml"], ["run", "short.toml"]),
    ]
    for name, output, args, again in long_runs:
        mark = "." + output + TEMP_MARK
        d = env.folder()
        live = None
        try:
            open(os.path.join(d, "long.toml"), "w").write(
                '[job]\nroute = "pbf"\nname = "x"\noutput_dir = "out"\n[pbf]\nsize = [12, 12, 12]\n'
                '[output]\npreview_layers = 200\n[run]\nthreads = 1\n')
            open(os.path.join(d, "live.toml"), "w").write(
                '[job]\nroute = "pbf"\nname = "x"\noutput_dir = "out"\n[pbf]\nsize = [12, 12, 12]\n'
                '[output]\npreview_layers = 400\nimage_size = 3000\n[run]\nthreads = 1\n')
            open(os.path.join(d, "short.toml"), "w").write(
                '[job]\nroute = "pbf"\nname = "x"\noutput_dir = "out"\n[pbf]\nsize = [3, 3, 3]\n'
                '[output]\npng = false\n')
            p, _ = start_until_temporary(env, args, d, mark)
            if p.poll() is None:
                p.send_signal(signal.SIGKILL)
            p.wait()
            env.count("stale")
            killed = [t for t in temporaries(os.path.join(d, "out")) if owner(t) == p.pid]
            if not any(t.startswith(mark) for t in killed):
                env.fail("stale", name, "no temporary was caught before the run ended")
                continue
            folders = {t.split(os.sep)[0] for t in killed if os.sep in t}
            # A live run writing the same output, its previews elsewhere: its output's temporary is
            # staged until its many large previews are drawn.
            live_args = {"run": ["run", "live.toml"],
                         "pbf": [a if a != "out/p" else "out/q" for a in args] +
                                ["--preview-layers", "400", "--image-size", "3000"],
                         "slice": [a if a != "out/p" else "out/q" for a in args] + ["--resolution", "0.02"]}[name]
            live, live_temps = start_until_temporary(env, live_args, d, mark)
            if not live_temps or live.poll() is not None:
                env.fail("stale", name, f"the live run {live_args} made no temporary or ended before the next run")
                continue
            r = env.run(again, d)
            after = temporaries(os.path.join(d, "out"))
            remaining = [t for t in after if owner(t) == p.pid]
            if r.returncode != 0 or remaining:
                env.fail("stale", name, f"exit {r.returncode}; left after the next run: {remaining}", r.stderr)
            for f in folders:
                if os.path.exists(os.path.join(d, "out", f)):
                    env.fail("stale", name, f"the killed run's preview folder out/{f} is still there")
            if live.poll() is not None:
                env.fail("stale", name, "the live run ended before its temporaries could be checked")
            elif [t for t in live_temps if t not in after]:
                env.fail("stale", name, f"a live run's temporary was removed: {sorted(set(live_temps) - set(after))}")
        finally:
            if live is not None and live.poll() is None:
                live.send_signal(signal.SIGKILL)
                live.wait()
            shutil.rmtree(d, ignore_errors=True)


def checks(trellis, root):
    """Runs every class; returns (problems, counts per class)."""
    env = Env(trellis, root)
    try:
        for f in (input_cases, two_output_cases, devnull_cases, fifo_cases, symlink_cases, empty_cases,
                  folder_cases, failed_cases, signal_cases, stale_cases):
            f(env)
    finally:
        shutil.rmtree(env.template, ignore_errors=True)
    return env.problems, env.counts
