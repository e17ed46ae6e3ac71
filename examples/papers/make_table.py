"""Runs every examples/papers/<paper>/reproduce.py and writes its table into docs/papers.md,
between the markers <!-- papers:<paper>:begin --> and <!-- papers:<paper>:end -->.

    python3 examples/papers/make_table.py [--only gippo,aero] [--check] [--out DIR]

--check compares instead of writing (the test `papers` runs it so): it fails when a reproduction
fails or when docs/papers.md differs from what the reproductions print now.
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
DOC = os.path.join(ROOT, "docs", "papers.md")


def papers():
    return sorted(d for d in os.listdir(HERE)
                  if os.path.isfile(os.path.join(HERE, d, "reproduce.py")))


def interpreter():
    """A Python that can draw the figures: this one if it imports matplotlib, else Debian's
    /usr/bin/python3 if that one does (a pyenv or venv Python next to python3-matplotlib)."""
    for py in (sys.executable, "/usr/bin/python3"):
        if os.path.exists(py) and subprocess.run([py, "-c", "import matplotlib"],
                                                 capture_output=True).returncode == 0:
            return py
    return sys.executable


def cell(v):
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v).replace("|", "\\|")


def table(rows):
    lines = ["| item | quantity | paper | ours | difference | why |", "|---|---|---|---|---|---|"]
    for r in rows:
        unit = f" {r['unit']}" if r.get("unit") else ""
        p = cell(r["paper"]) + (unit if r["paper"] is not None else "")
        o = cell(r["ours"]) + (unit if r["ours"] is not None else "")
        lines.append(f"| {cell(r['item'])} | {cell(r['quantity'])} | {p} | {o} | "
                     f"{r['difference'] or '—'} | {cell(r['why'])} |")
    return "\n".join(lines)


def splice(text, name, body):
    begin, end = f"<!-- papers:{name}:begin -->", f"<!-- papers:{name}:end -->"
    if begin not in text or end not in text:
        sys.exit(f"docs/papers.md has no markers for {name}: add {begin} and {end}")
    a = text.index(begin) + len(begin)
    return text[:a] + "\n" + body + "\n" + text[text.index(end):]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", help="comma-separated papers (folders under examples/papers)")
    ap.add_argument("--check", action="store_true", help="compare with docs/papers.md, do not write")
    ap.add_argument("--out", default=os.path.join(os.getcwd(), "papers-out"),
                    help="folder for each paper's pictures and rows (default ./papers-out)")
    a = ap.parse_args()
    names = a.only.split(",") if a.only else papers()
    with open(DOC) as f:
        text = original = f.read()
    failed = []
    python = interpreter()
    for name in names:
        script = os.path.join(HERE, name, "reproduce.py")
        out = os.path.join(a.out, name)
        r = subprocess.run([python, script, "--quick", "--out", out], capture_output=True,
                           text=True)
        sys.stdout.write(r.stdout)
        if r.returncode != 0:
            failed.append(name)
            sys.stderr.write(f"{name}: reproduce.py failed ({r.returncode}):\n{r.stderr}\n")
            continue
        with open(os.path.join(out, "rows.json")) as f:
            rows = json.load(f)["rows"]
        text = splice(text, name, table(rows))
    if failed:
        sys.exit(f"failed: {', '.join(failed)}")
    if a.check:
        if text != original:
            sys.exit("docs/papers.md is stale: run python3 examples/papers/make_table.py")
        print("docs/papers.md matches the reproductions")
    elif text != original:
        with open(DOC, "w") as f:
            f.write(text)
        print("docs/papers.md updated")


if __name__ == "__main__":
    main()
