#!/usr/bin/env python3
"""Every C++ file of the project is formatted as .clang-format says (issue 42).

Usage: format_test.py SOURCE_DIR  (exit 1 listing each file clang-format would change; the fix
is `clang-format -i FILE`, or for the whole tree
`git ls-files '*.cpp' '*.hpp' '*.h' | xargs clang-format -i`).
A self-test first formats a badly laid out file in a temporary folder beside the project's
.clang-format and checks it is caught, so the test cannot pass by checking nothing.
"""
import os
import shutil
import subprocess
import sys
import tempfile

EXTENSIONS = (".cpp", ".hpp", ".h", ".cc")
FOLDERS = ("src", "include", "apps", "python", "tests", "bench", "fuzz", "examples")


def clang_format():
    for name in ("clang-format", "clang-format-14"):
        path = shutil.which(name)
        if path:
            return path
    sys.exit("format_test: clang-format not found (scripts/install-deps.sh installs it)")


def sources(root):
    found = []
    for folder in FOLDERS:
        for base, dirs, files in os.walk(os.path.join(root, folder)):
            dirs[:] = [d for d in dirs if d not in ("node_modules", "__pycache__", "build")]
            found += [os.path.join(base, f) for f in files if f.endswith(EXTENSIONS)]
    return sorted(found)


def unformatted(tool, files):
    """Files clang-format would change, in batches (one process per file is slow)."""
    bad = []
    for i in range(0, len(files), 64):
        batch = files[i:i + 64]
        run = subprocess.run([tool, "--dry-run", "--Werror", *batch],
                             capture_output=True, text=True)
        if run.returncode != 0:
            bad += [f for f in batch if f + ":" in run.stderr]
    return bad


def self_test(tool, root):
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copy(os.path.join(root, ".clang-format"), tmp)
        good, bad = os.path.join(tmp, "good.cpp"), os.path.join(tmp, "bad.cpp")
        with open(good, "w") as f:
            f.write("int f(int a) {\n  return a + 1;\n}\n")
        with open(bad, "w") as f:
            f.write("int   f( int a ){return a+1;}\n")
        found = unformatted(tool, [good, bad])
        if found != [bad]:
            sys.exit(f"format_test self-test: expected only bad.cpp to be caught, got {found}")


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    tool = clang_format()
    self_test(tool, root)
    files = sources(root)
    bad = unformatted(tool, files)
    for f in bad:
        print(f"not formatted: {os.path.relpath(f, root)}  (clang-format -i {os.path.relpath(f, root)})")
    print(f"format_test: {len(files) - len(bad)} of {len(files)} C++ files formatted")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
