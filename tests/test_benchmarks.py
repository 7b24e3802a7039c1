"""The benchmark scripts (``benchmarks/``) are run by hand, minutes each; these checks keep them
runnable as the package changes: each takes ``--help`` (and stops there: two of them ran the
whole benchmark), and every name each imports from coplan -- at the top or inside a function --
is still there (a function moved or renamed would otherwise break a script only on its next run)."""

from __future__ import annotations

import ast
import importlib
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
SCRIPTS = sorted(p for p in BENCHMARKS.glob("*.py") if p.name != "run_header.py")


def test_there_are_benchmark_scripts():
    assert len(SCRIPTS) >= 10


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_a_benchmark_script_says_its_usage_and_stops(script):
    res = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=120,
                         cwd=BENCHMARKS)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("usage:") and script.name in res.stdout.splitlines()[0]


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_every_name_a_benchmark_imports_from_coplan_is_there(script):
    tree = ast.parse(script.read_text(encoding="utf-8"))
    found = [(n.module, a.name) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("coplan")
             for a in n.names]
    found += [(a.name, None) for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names if a.name.startswith("coplan")]
    assert found, "no coplan import: is this a benchmark of coplan?"
    for module, name in found:
        mod = importlib.import_module(module)
        if name is not None:
            assert hasattr(mod, name) or importlib.util.find_spec(f"{module}.{name}") is not None, f"{module}.{name}"
