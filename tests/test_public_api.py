"""Every public name the README shows users exists where the README says it is.

The names are read from the README itself: in its Python code blocks every ``coplan.<...>``
name and every ``from coplan... import ...`` line; in its prose every code span that names a
``coplan.<...>`` Python path (file-format names such as ``coplan.plan/1`` are not paths).
The package's ``__all__`` is checked too, and ``python -m coplan.schema``.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

import coplan

ROOT = Path(__file__).resolve().parents[1]
# the README and the user docs it links to (docs/usage.md, docs/benchmarks.md)
README = "\n".join((ROOT / f).read_text(encoding="utf-8") for f in ("README.md", "docs/usage.md", "docs/benchmarks.md"))
PY_BLOCKS = re.findall(r"```python\n(.*?)```", README, re.S)
DOTTED = re.compile(r"\bcoplan(?:\.[A-Za-z_]\w*)+(?![\w/-])")  # (not a file format: coplan.compare-rows/2)


def _code_names() -> set[str]:
    names = set()
    for block in PY_BLOCKS:
        for line in block.splitlines():
            code = line.split("#", 1)[0]
            m = re.match(r"\s*from\s+(coplan[\w.]*)\s+import\s+(.+)", code)
            if m:
                names |= {f"{m.group(1)}.{n.split(' as ')[0].strip()}" for n in m.group(2).strip("() ").split(",") if n.strip()}
                continue
            names |= set(DOTTED.findall(code))
    return names


def _prose_names() -> set[str]:
    prose = re.sub(r"```.*?```", "", README, flags=re.S)
    names = set()
    for span in re.findall(r"`([^`\n]+)`", prose):
        for n in DOTTED.findall(span):
            if not re.search(re.escape(n) + r"/", span):
                names.add(n)
    return names


def _resolve(dotted: str):
    """Import the longest module prefix of ``dotted`` and take the rest as attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(dotted)


CODE_NAMES = sorted(_code_names())
PROSE_NAMES = sorted(_prose_names())


def test_the_readme_names_what_it_is_known_to_name():
    """The parser finds the names (a README rewrite that loses them fails here, not silently)."""
    found = set(CODE_NAMES) | set(PROSE_NAMES)
    for name in ("coplan.solve", "coplan.load_plan", "coplan.view", "coplan.optimal.OptimalOptions",
                 "coplan.live.cell.LiveCell", "coplan.plausible.BOUNDS", "coplan.verify.verify"):
        assert name in found, name
    assert not any("/" in n for n in found)


@pytest.mark.parametrize("name", CODE_NAMES)
def test_every_name_in_the_readmes_code_exists(name):
    assert _resolve(name) is not None


@pytest.mark.parametrize("name", PROSE_NAMES)
def test_every_python_path_in_the_readmes_prose_exists(name):
    assert _resolve(name) is not None


@pytest.mark.parametrize("name", coplan.__all__)
def test_every_name_in_coplans_all_exists(name):
    assert getattr(coplan, name) is not None


def test_the_documented_entry_points_are_the_real_ones():
    from coplan.planners.optimal import OptimalOptions
    from coplan.problem.generate import row_problem
    from coplan.problem.plausible import BOUNDS
    from coplan.verify.verifier import verify

    assert coplan.optimal.OptimalOptions is OptimalOptions
    assert coplan.generate.row_problem is row_problem
    assert coplan.plausible.BOUNDS is BOUNDS
    assert coplan.verify.verify is verify
    assert callable(coplan.solve) and callable(coplan.load_problem) and callable(coplan.load_plan)


def test_python_m_coplan_schema_is_a_runnable_module():
    """``python -m coplan.schema`` (regenerates the shipped schemas; not run here, it writes the
    package's files): a module, not a package, with its ``__main__`` block."""
    import importlib.util

    spec = importlib.util.find_spec("coplan.schema")
    assert spec is not None and spec.origin.endswith("schema.py") and spec.submodule_search_locations is None
    assert 'if __name__ == "__main__":' in Path(spec.origin).read_text(encoding="utf-8")
    assert callable(importlib.import_module("coplan.schema").write_shipped)


def test_a_choice_that_is_none_of_them_is_refused_with_every_choice_listed():
    from coplan.kinds import GantryMode, PlannerKind, StopRule

    assert PlannerKind("optimal") is PlannerKind.OPTIMAL and StopRule("fixed") is StopRule.FIXED
    for kind, bad, words in ((PlannerKind, "fastest", "planner kind: expected one of 'heuristic', 'coordinated', 'optimal'; "
                                                      "found 'fastest'"),
                             (GantryMode, "moving", "gantry mode: expected one of 'stop-and-go', 'continuous', 'auto'"),
                             (StopRule, 3, "found 3")):
        with pytest.raises(ValueError, match=re.escape(words)):
            kind(bad)


def test_the_subpackages_the_docs_name_are_attributes_of_coplan():
    """(``import coplan; coplan.sweep.run_sweep(...)``, as docs/usage.md shows it, raised
    AttributeError: ``sweep`` was not among the lazily imported subpackages.)"""
    import subprocess
    import sys

    code = ("import coplan\nassert callable(coplan.sweep.run_sweep) and callable(coplan.sweep.load_sweep)\n"
            "assert callable(coplan.report.compare) and callable(coplan.row.plan_row)\n"
            "assert {'sweep', 'report', 'row'} <= set(dir(coplan))\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr


def test_coplan_allocate_is_the_stage_function_whatever_was_imported_first():
    """``coplan.allocate`` is in ``__all__`` as the allocation function; importing the package of
    that name (a solve does) bound the name to the package: "'module' object is not callable"
    after a solve, in a fresh process. The package is callable as its function now."""
    import subprocess
    import sys

    code = ("import coplan\np = coplan.load_problem('crossing_paths')\n"
            "coplan.solve(p, planner='heuristic')\n"
            "a = coplan.allocate(p, 'makespan')\nassert type(a).__name__ == 'Allocation', a\n"
            "assert coplan.allocate.allocate(p, 'makespan').assignment == a.assignment\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr


def test_coplan_verify_is_the_stage_function_as_allocate_is():
    """``coplan.verify(problem, plan)`` verifies (it said "'module' object is not callable": the
    name is the stage's package); ``coplan.verify.verify`` is the same function."""
    import subprocess
    import sys

    code = ("import coplan\np = coplan.load_problem('crossing_paths')\n"
            "r = coplan.solve(p, planner='heuristic')\n"
            "v = coplan.verify(p, r.plan)\nassert type(v).__name__ == 'Verification', v\n"
            "assert v.passed == coplan.verify.verify(p, r.plan).passed == r.verification.passed\n"
            "assert 'verify' in dir(coplan) and callable(coplan.verify)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
