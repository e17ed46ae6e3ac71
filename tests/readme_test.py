#!/usr/bin/env python3
"""Runs the README's commands and every `--help` example as written and checks what they print.

Every line `$ COMMAND` inside a ``` block is run with bash, in order, in one fresh folder that
has the repository's examples/ and profiles/ beside it (so the README's relative paths work) and
`trellis` on the PATH. The lines the README shows under a command must appear in what it
printed (times, minutes and megabytes may differ); a command whose shown output has
`trellis: error` must exit 2, every other command 0.

Then every example in `trellis --help` and in each command's `--help` (lines beginning
`  trellis `, with their indented continuation lines) runs in the same folder, in the order the
help texts give them (the top-level help first: later examples read its outputs); each must
exit 0.

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


def help_examples(binary):
    """(where, command) for every example line of `trellis --help` and each command's --help."""
    top = subprocess.run([binary, "--help"], capture_output=True, text=True).stdout
    names, in_list = [], False
    for line in top.splitlines():
        if line.startswith("Subcommands:"):
            in_list = True
        elif in_list and line.strip():
            names.append(line.split()[0])
    out = []
    for name in [None] + names:
        args = [binary, "--help"] if name is None else [binary, name, "--help"]
        text = subprocess.run(args, capture_output=True, text=True).stdout
        where = "trellis --help" if name is None else f"trellis {name} --help"
        lines = text.splitlines()
        for i, line in enumerate(lines):
            if not line.startswith("  trellis "):
                continue
            cmd = line.strip()
            j = i + 1
            while j < len(lines) and lines[j].startswith("      ") and lines[j].lstrip().startswith("-"):
                cmd += " " + lines[j].strip()
                j += 1
            out.append((where, cmd))
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
    examples = help_examples(binary)
    for where, cmd in examples:
        r = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True,
                           timeout=600)
        if r.returncode != 0:
            failures += 1
            print(f"{where}: {cmd}\n    exit {r.returncode}\n    printed:\n      " +
                  "\n      ".join((r.stdout + r.stderr).splitlines()[:12]))
    print(f"{len(cmds) + len(examples) - failures} passed, {failures} failed "
          f"({len(cmds)} README commands, {len(examples)} --help examples)")
    if not failures:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failures or not cmds or not examples else 0


if __name__ == "__main__":
    sys.exit(main())
