"""The `trellis` command of the installed package (the console entry point pip writes into the
environment's bin/): replaces itself with the CLI shipped in trellis/bin, so its output, exit
code and signals are the CLI's own."""
import os
import sys


def main():
    exe = os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin", "trellis")
    try:
        os.execv(exe, [exe, *sys.argv[1:]])
    except OSError as e:
        sys.exit(f"trellis: cannot run the bundled CLI {exe}: {e.strerror}\n"
                 "  (it is part of the package that `pip install` installs: reinstall it)")
