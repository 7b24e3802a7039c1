"""The notebooks in ``notebooks/`` run top to bottom on a fresh kernel, headless.

The kernel is this interpreter (a kernelspec written to a temporary folder and found via
``JUPYTER_PATH``), so the notebooks import the coplan under test, whether it is installed
editable or not. The optimal planner's search in ``compare_schedules`` gets a small work
budget and a short refinement, no polishing NLP and no widening (``COPLAN_NOTEBOOK_QUICK``):
its plans are still verified, only less searched.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
NAMES = ["compare_schedules.ipynb", "workspace_analysis.ipynb", "design_sweep.ipynb", "row_analysis.ipynb"]
KERNEL = "coplan-test-python"


@pytest.fixture
def kernel(tmp_path, monkeypatch) -> str:
    spec = tmp_path / "jupyter" / "kernels" / KERNEL
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": f"coplan tests ({sys.executable})",
        "language": "python",
    }))
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("COPLAN_NOTEBOOK_QUICK", "1")
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # (the notebooks' temporary folders go with the test's)
    return KERNEL


def _outputs(nb, kind: str) -> list:
    return [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if kind in o.get("data", {})]


@pytest.mark.parametrize("name", NAMES)
def test_notebook_is_stored_clean_and_uses_public_api(name):
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(not c.outputs and c.execution_count is None for c in code), "store notebooks without outputs"
    src = "\n".join(c.source for c in code)
    assert not re.search(r"from coplan[\w.]* import [^\n]*\b_\w", src), "private names imported"
    assert "plt.show()" not in src or "import matplotlib.pyplot" in src
    assert any(c.cell_type == "markdown" for c in nb.cells)


@pytest.mark.parametrize("name", NAMES)
def test_notebook_runs_top_to_bottom(name, kernel, tmp_path):
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    client = nbclient.NotebookClient(
        nb, kernel_name=kernel, timeout=240, resources={"metadata": {"path": str(tmp_path)}}, allow_errors=False,
    )
    client.execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    pngs = _outputs(nb, "image/png")
    tables = [o["data"]["text/markdown"] for o in _outputs(nb, "text/markdown") if o["data"]["text/markdown"].startswith("|")]
    viewers = [o["data"]["text/html"] for o in _outputs(nb, "text/html") if 'title="coplan plan viewer"' in o["data"]["text/html"]]
    if name in ("compare_schedules.ipynb", "workspace_analysis.ipynb", "row_analysis.ipynb"):  # the notebooks that use coplan.view
        assert len(viewers) == 1 and viewers[0].startswith("<iframe srcdoc="), "coplan.view renders inline"
    if name == "compare_schedules.ipynb":
        assert len(pngs) >= 6  # Gantt, clearance, joints x2, other problems
        assert _outputs(nb, "image/gif"), "the inline animation"
        from coplan.problem import load_problem, shipped_problems

        for path in shipped_problems():
            assert load_problem(path).name in tables[0]
        assert "| heuristic |" in tables[0] and "| optimal |" in tables[0]
    elif name == "row_analysis.ipynb":
        assert len(pngs) >= 4  # stops along the row, idle by cause, fruit per hour per arm, fruit per hour against speed
        assert any(t.startswith("| rule | stops |") and "| optimised |" in t and "| fewest |" in t for t in tables)
        moving = [t for t in tables if t.startswith("| mode |")]  # on the move beside the best stop rule, both verified
        assert len(moving) == 1 and "| on the move, " in moving[0] and moving[0].count("| True |") == 2, moving
    elif name == "design_sweep.ipynb":
        assert len(pngs) >= 3  # throughput vs spacing, ratio distribution, Pareto front
        assert any(t.startswith("| n_arms |") for t in tables) and any(t.startswith("| arms | density") for t in tables)
    else:
        assert len(pngs) >= 5  # single arm, cell, spacing chart, two spacings
        spacing = next(t for t in tables if t.startswith("| spacing (m)"))
        # (its prose: the last column says what the verifier refuses; the heuristic's splines break the jerk limit in
        # every plan -- the column said "unsafe / unsafe" on every row, read as a clearance verdict)
        body = [ln for ln in spacing.splitlines()[2:] if ln.startswith("|") and "invalid" not in ln]
        assert body and all(ln.rstrip(" |").rsplit("|", 1)[1].count("jerk") == 2 for ln in body), spacing
