"""Shared by every paper reproduction under examples/papers/<paper>/reproduce.py.

A reproduction computes what a paper's table or figure reports, prints each value beside the
paper's, writes its pictures into an output folder and returns rows that make_table.py turns into
the tables of docs/papers.md. Only values that come out the same on every machine belong in a row
(counts, lengths, ratios, scores; not run times).

    row("Table 1, honeycomb", "pore area", paper=55.0, ours=54.2, unit="%", why="...")

`paper` may be None (no published value, or the paper's result is physical) and `ours` may be None
(cannot be computed); `why` then says so: a row is never left out silently.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def cli():
    """The trellis command: $TRELLIS_CLI, else the release build of this checkout, else PATH."""
    env = os.environ.get("TRELLIS_CLI")
    if env:
        return env
    built = os.path.join(ROOT, "build", "release", "apps", "trellis", "trellis")
    if os.path.exists(built):
        return built
    found = shutil.which("trellis")
    if not found:
        sys.exit("trellis not found: build it (make) or set TRELLIS_CLI")
    return found


def run(*args, cwd=None):
    """Run `trellis ARGS`; stop with its stderr when it fails. Returns stdout."""
    r = subprocess.run([cli(), *map(str, args)], capture_output=True, text=True, cwd=cwd)
    if r.returncode != 0:
        sys.exit(f"trellis {' '.join(map(str, args))} failed ({r.returncode}):\n{r.stderr}")
    return r.stdout


def run_json(*args, cwd=None):
    """Run a trellis command that prints JSON (e.g. `analyze --json`) and parse it."""
    return json.loads(run(*args, cwd=cwd))


def path(*parts):
    """A file of this checkout (examples/designs/..., profiles/...)."""
    return os.path.join(ROOT, *parts)


def difference(paper, ours):
    """ours relative to the paper, as text: '+3.1 %', '0', or '' when either is not a number."""
    if not isinstance(paper, (int, float)) or not isinstance(ours, (int, float)):
        return ""
    if paper == ours:
        return "0"
    if paper == 0:
        return f"{ours - paper:+.3g}"
    return f"{100.0 * (ours - paper) / abs(paper):+.1f} %"


def row(item, quantity, paper, ours, unit="", why=""):
    """One line of a paper's table; printed as it is made."""
    r = {"item": item, "quantity": quantity, "paper": paper, "ours": ours, "unit": unit,
         "difference": difference(paper, ours), "why": why}
    print(f"{item}: {quantity}: paper {fmt(paper)}{unit and ' ' + unit}, ours {fmt(ours)}"
          f"{unit and ' ' + unit}  {r['difference']}  {why}")
    return r


def fmt(v):
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def main(paper, reproduce, figures):
    """Entry point of a reproduce.py: parses --out DIR (pictures and rows.json go there), --quick
    (smaller runs where the paper's own size takes minutes; rows then say so) and --only a,b (some
    of `figures`, the names of its tables and figures), calls reproduce(out, quick, only) -> list of
    rows, writes OUT/rows.json."""
    ap = argparse.ArgumentParser(description=f"Reproduce the {paper} paper's tables and figures.")
    ap.add_argument("--out", default=os.path.join(os.getcwd(), f"papers-{paper.lower()}"),
                    help="folder for pictures and rows.json (default ./papers-<paper>)")
    ap.add_argument("--quick", action="store_true", help="smaller runs (used by the tests)")
    ap.add_argument("--only", help=f"comma-separated, some of: {', '.join(figures)}")
    a = ap.parse_args()
    only = tuple(figures)
    if a.only:
        only = tuple(a.only.split(","))
        unknown = [n for n in only if n not in figures]
        if unknown:
            ap.error(f"--only: unknown {', '.join(unknown)} (one of {', '.join(figures)})")
    os.makedirs(a.out, exist_ok=True)
    rows = reproduce(a.out, a.quick, only)
    with open(os.path.join(a.out, "rows.json"), "w") as f:
        json.dump({"paper": paper, "quick": a.quick, "rows": rows}, f, indent=1)
    print(f"{len(rows)} rows; pictures and rows.json in {a.out}")
