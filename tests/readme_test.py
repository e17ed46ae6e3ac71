#!/usr/bin/env python3
"""Runs the README's commands as written and checks what they print.

Every line `$ COMMAND` inside a ``` block is run with bash, in order, in one fresh folder that
has the repository's examples/ and profiles/ beside it (so the README's relative paths work) and
`trellis` on the PATH. The lines the README shows under a command must appear in what it
printed (times, minutes and megabytes may differ); a command whose shown output has
`trellis: error` must exit 2, every other command 0.

usage: readme_test.py TRELLIS_BINARY REPO_ROOT
"""
import os
import shutil
import re
import subprocess
import sys
import tempfile


def commands(readme):
    """(line number, command, shown output lines) for every `$ ` line in a code block."""
    out, in_block, current = [], False, None
    lines = readme.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            in_block = not in_block
            current = None
        elif in_block and line.startswith("$ "):
            cmd, start = line[2:], i + 1
            while cmd.endswith("\\") and i + 1 < len(lines):
                i += 1
                cmd = cmd[:-1] + " " + lines[i].strip()
            current = (start, cmd, [])
            out.append(current)
        elif in_block and current is not None:
            current[2].append(line)
        i += 1
    return out


def normal(text):
    text = re.sub(r"\d+(\.\d+)? s\b", "T s", text)
    text = re.sub(r"~\d+(\.\d+)? min", "~T min", text)
    text = re.sub(r"peak \d+ MB", "peak M MB", text)
    return text


def main():
    binary, root = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    readme = open(os.path.join(root, "README.md"), encoding="utf-8").read()
    cmds = commands(readme)
    work = tempfile.mkdtemp(prefix="trellis_readme_")
    os.symlink(os.path.join(root, "examples"), os.path.join(work, "examples"))
    os.symlink(os.path.join(root, "profiles"), os.path.join(work, "profiles"))
    bindir = os.path.join(work, ".bin")
    os.mkdir(bindir)
    os.symlink(binary, os.path.join(bindir, "trellis"))
    # Python examples use Debian's python3 and the package as built (PYTHONPATH from ctest).
    if os.path.exists("/usr/bin/python3"):
        os.symlink("/usr/bin/python3", os.path.join(bindir, "python3"))
    env = dict(os.environ, PATH=bindir + os.pathsep + os.environ["PATH"])
    failures = 0
    for line_no, cmd, shown in cmds:
        r = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True,
                           timeout=600)
        printed = normal(r.stdout + r.stderr)
        expect_error = any(s.startswith("trellis: error") for s in shown)
        want = 2 if expect_error else 0
        problems = []
        if r.returncode != want:
            problems.append(f"exit {r.returncode}, expected {want}")
        for s in shown:
            if s.strip() and s.strip() != "..." and normal(s) not in printed:
                problems.append(f"missing output line: {s}")
        if problems:
            failures += 1
            print(f"README.md:{line_no}: $ {cmd}")
            for p in problems:
                print(f"    {p}")
            print("    printed:\n      " + "\n      ".join((r.stdout + r.stderr).splitlines()[:12]))
    print(f"{len(cmds) - failures} passed, {failures} failed")
    if not failures:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failures or not cmds else 0


if __name__ == "__main__":
    sys.exit(main())
