#!/usr/bin/env python3
"""Runs the commands of README.md and docs/*.md and every `--help` example as written, checks what
they print, and checks that every relative link in those files points at something that exists.

Every line `$ COMMAND` inside a ``` block is run with bash, in order (README.md first, then
docs/*.md by name), in one fresh folder that has the repository's examples/ and profiles/ beside
it (so the documents' relative paths work) and `trellis` on the PATH. The lines a document shows
under a command must appear in what it printed (times, minutes and megabytes may differ); a
command whose shown output has `trellis: error` must exit 2, every other command 0. A line that
looks like a command (`$ ` after any indentation) but is not in a ``` block at the start of a
line is an error: nothing a document shows as a command goes unrun.

Links: every `[text](target)` and `![alt](target)` outside code in README.md and docs/*.md whose
target is not a URL must name an existing file or folder (relative to the document), and a
`#anchor` into a Markdown file must be one of its headings (GitHub's rule for heading ids).

Then every example in `trellis --help` and in each command's `--help` (lines beginning
`  trellis `, with their indented continuation lines) runs in the same folder, in the order the
help texts give them (the top-level help first: later examples read its outputs); each must
exit 0.

usage: readme_test.py TRELLIS_BINARY REPO_ROOT
       readme_test.py --links-only REPO_ROOT
"""
import os
import shutil
import re
import subprocess
import sys
import tempfile


def commands(readme):
    """(line number, command, shown output lines, block number) for every `$ ` line in a code
    block."""
    out, in_block, current, block = [], False, None, 0
    lines = readme.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            in_block = not in_block
            block += in_block
            current = None
        elif in_block and line.startswith("$ "):
            cmd, start = line[2:], i + 1
            while cmd.endswith("\\") and i + 1 < len(lines):
                i += 1
                cmd = cmd[:-1] + " " + lines[i].strip()
            current = (start, cmd, [], block)
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


def command_like_lines(text):
    """Line numbers of every line that reads as a command (`$ ` after any indentation), whether
    or not `commands` would run it; continuation lines are part of their command."""
    out, lines, i = [], text.splitlines(), 0
    while i < len(lines):
        if lines[i].lstrip().startswith("$ "):
            out.append(i + 1)
            while lines[i].rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
        i += 1
    return out


def documents(root):
    """README.md, then docs/*.md by name: the files whose commands run, in that order."""
    docs = os.path.join(root, "docs")
    return [os.path.join(root, "README.md")] + sorted(
        os.path.join(docs, f) for f in os.listdir(docs) if f.endswith(".md"))


def prose(text, keep_code=False):
    """(line number, line) outside fenced code, with inline code spans blanked unless
    keep_code."""
    out, fence = [], None
    for n, line in enumerate(text.splitlines(), 1):
        stripped = line.lstrip()
        if fence is None and stripped.startswith(("```", "~~~")):
            fence = stripped[:3]
        elif fence is not None and stripped.startswith(fence):
            fence = None
        elif fence is None:
            out.append((n, line if keep_code else re.sub(r"`[^`]*`", "``", line)))
    return out


def heading_ids(text):
    """GitHub's ids of a Markdown file's headings: lower case, punctuation dropped, spaces to
    hyphens, repeats numbered -1, -2, ..."""
    ids, seen = set(), {}
    for _, line in prose(text, keep_code=True):
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        slug = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        ids.add(slug if n == 0 else f"{slug}-{n}")
    return ids


def broken_links(path, root):
    """(line, target, why) for every relative link of one document that points nowhere."""
    text = open(path, encoding="utf-8").read()
    out = []
    for n, line in prose(text):
        for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", line):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):
                continue  # a URL (http:, https:, mailto:)
            file_part, _, anchor = target.partition("#")
            dest = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) \
                if file_part else path
            if not os.path.exists(dest):
                out.append((n, target, "no such file"))
            elif not os.path.realpath(dest).startswith(os.path.realpath(root) + os.sep):
                out.append((n, target, "outside the repository"))
            elif anchor and dest.endswith(".md") and anchor not in heading_ids(
                    open(dest, encoding="utf-8").read()):
                out.append((n, target, f"no heading #{anchor} in {os.path.relpath(dest, root)}"))
    return out


def check_links(root):
    """Prints every broken relative link of README.md and docs/*.md; returns (checked, broken)."""
    checked = broken = 0
    for path in documents(root):
        text = open(path, encoding="utf-8").read()
        checked += sum(len(re.findall(r"\]\(([^)\s]+)", line)) for _, line in prose(text))
        for n, target, why in broken_links(path, root):
            broken += 1
            print(f"{os.path.relpath(path, root)}:{n}: link ({target}): {why}")
    return checked, broken


def normal(text):
    text = re.sub(r"\d+(\.\d+)? s\b", "T s", text)
    text = re.sub(r"~\d+(\.\d+)? min", "~T min", text)
    text = re.sub(r"peak \d+ MB", "peak M MB", text)
    return text


def run_documents(root, work, env):
    """Runs every document's commands; returns (commands run, failures, summary per file)."""
    failures, total, summary = 0, 0, []
    for path in documents(root):
        name = os.path.relpath(path, root)
        text = open(path, encoding="utf-8").read()
        cmds = commands(text)
        run_blocks, run_lines = set(), set()
        for line_no, cmd, shown, block in cmds:
            run_blocks.add(block)
            run_lines.add(line_no)
            try:
                r = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True,
                                   text=True, timeout=600)
            except subprocess.TimeoutExpired:
                failures += 1
                print(f"{name}:{line_no}: $ {cmd}\n    still running after 600 s")
                continue
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
                print(f"{name}:{line_no}: $ {cmd}")
                for p in problems:
                    print(f"    {p}")
                head = (r.stdout + r.stderr).splitlines()[:12]
                print("    printed:\n      " + "\n      ".join(head))
        total += len(cmds)
        # A line shown as a command in an indented or ~~~ fence, or outside any fence, would
        # otherwise be skipped without a word.
        not_run = [n for n in command_like_lines(text) if n not in run_lines]
        for n in not_run:
            failures += 1
            print(f"{name}:{n}: shown as a command but not run (a `$ ` line runs only at the "
                  "start of a line inside a ``` block)")
        summary.append(f"{name}: {len(cmds)} command(s) in {len(run_blocks)} block(s) run"
                       + (f", {len(not_run)} shown but NOT run" if not_run else ""))
        if name == "README.md" and not cmds:
            failures += 1
            print("README.md: no commands found")
    return total, failures, summary


def main():
    if sys.argv[1] == "--links-only":
        root = os.path.abspath(sys.argv[2])
        checked, broken = check_links(root)
        print(f"{len(documents(root))} documents, {checked} links, {broken} broken")
        return 1 if broken or not checked else 0
    binary, root = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
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
    total, failures, summary = run_documents(root, work, env)
    examples = help_examples(binary)
    for where, cmd in examples:
        r = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True,
                           timeout=600)
        if r.returncode != 0:
            failures += 1
            print(f"{where}: {cmd}\n    exit {r.returncode}\n    printed:\n      " +
                  "\n      ".join((r.stdout + r.stderr).splitlines()[:12]))
    print("\n".join(summary))
    print(f"{total + len(examples)} run, {failures} failed "
          f"({total} document commands, {len(examples)} --help examples)")
    if not failures:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failures or not examples else 0


if __name__ == "__main__":
    sys.exit(main())
