"""Every example script in examples/python/ runs (with small arguments where it takes some)."""
import os
import subprocess
import sys

import pytest

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
EXAMPLES = {"gippo_six_geometries.py": ["30"], "aero_octet_trails.py": [], "fgm_table3.py": ["12"],
            "pbf_fr_a.py": [], "nonplanar_m_curve.py": []}


@pytest.mark.parametrize("script", sorted(EXAMPLES))
def test_example_runs(script):
    path = os.path.join(ROOT, "examples", "python", script)
    r = subprocess.run([sys.executable, path, *EXAMPLES[script]], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip()


def test_every_example_is_tested():
    assert sorted(f for f in os.listdir(os.path.join(ROOT, "examples", "python")) if f.endswith(".py")) \
        == sorted(EXAMPLES)


def test_type_stubs_are_up_to_date():
    gen = os.path.join(ROOT, "python", "gen_stubs.py")
    r = subprocess.run([sys.executable, gen], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(ROOT, "python", "trellis", "__init__.pyi")) as f:
        assert f.read() == r.stdout, "stale stubs: regenerate with python/gen_stubs.py"
