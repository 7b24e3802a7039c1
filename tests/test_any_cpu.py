"""The same input gives the same plan on any machine.

Another CPU computes the same transcendental functions a few ulps differently (NumPy's SIMD
kernels are chosen at run time). Two ways to be that other machine here:

* in-process, :func:`other_cpu.another_cpu`: every NumPy/libm transcendental answers a few ulps
  off, consistently (the same input, the same answer), as another machine's kernel would;
* a subprocess with NumPy's run-time dispatch switched off (``NPY_DISABLE_CPU_FEATURES``) and
  the most generic OpenBLAS kernel (``OPENBLAS_CORETYPE``): this machine acting as an older one.
  Before the planners quantised their choices, the AVX-512 and the baseline runs gave
  dense_overlap 17.75 s and 19.47 s (another optimum of the bound's MILP).

Each requires the identical plan: the same allocation and order, the same events and poses
(within 1e-7), the same search path (its counters).
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from other_cpu import another_cpu, nudge

from coplan.allocate import bound_details
from coplan.planners.coordinated import plan_coordinated
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.problem import load_problem, shipped_problems

SMALL = dict(search_work=4000, search_evaluations=150, refine_retimes=3)  # (the refinement improves on the search)


@pytest.fixture(scope="module")
def dense_here():
    """dense_overlap and its optimal plan on this CPU as it is (the reference both optimal tests compare with)."""
    prob = load_problem(next(p for p in shipped_problems() if p.stem == "dense_overlap"))
    return prob, plan_optimal(prob, options=OptimalOptions(**SMALL)).plan


def fingerprint(plan) -> dict:
    """What must not change: allocation, order, status, events, makespan (1e-7 s), poses (1e-7 rad)."""
    q = np.concatenate([np.asarray(plan.q[a]).ravel() for a in sorted(plan.q)])
    return {
        "status": plan.status.value,
        "allocation": {a: list(v) for a, v in sorted(plan.allocation.items())},
        "events": [[e.arm, e.fruit, e.kind.value, round(e.t_start, 7), round(e.t_end, 7)] for e in plan.events],
        "makespan": round(float(plan.metrics["makespan"]), 7),
        "samples": int(q.size),
        "q": q.tolist(),
    }


def search_path(plan) -> dict:
    s = plan.solver.get("search") or {}
    r = plan.solver.get("refine") or {}
    return {k: s.get(k) for k in ("evaluations", "checks", "improvements", "fresh_starts", "anchored")} | {
        "refine": {k: r.get(k) for k in ("retimes", "evaluations", "improvements")}}


def same(a: dict, b: dict) -> None:
    qa, qb = np.asarray(a.pop("q")), np.asarray(b.pop("q"))
    assert a == b
    assert np.max(np.abs(qa - qb), initial=0.0) < 1e-7


def test_the_perturbation_is_real():
    """Not a vacuous test: under it, IK and the MILP's raw move times really change in the last bits."""
    prob = load_problem(next(p for p in shipped_problems() if p.stem == "dense_overlap"))
    arm = prob.arms[0]
    q0, _ = arm.ik(prob.fruit_positions, prob.task.reach_margin)
    with pytest.MonkeyPatch.context() as mp, another_cpu(mp):
        q1, _ = arm.ik(prob.fruit_positions, prob.task.reach_margin)
    ok = np.isfinite(q0)
    assert np.any(q0[ok] != q1[ok])
    assert np.max(np.abs(q0[ok] - q1[ok])) < 1e-14
    x = np.linspace(0.1, 3.0, 50)
    assert np.array_equal(nudge(x, salt=3), nudge(x, salt=3)) and not np.array_equal(nudge(x, salt=3), x)


@pytest.mark.parametrize("salt", [1, 2, 3])
def test_the_bound_and_its_assignment_do_not_depend_on_the_cpu(salt):
    """dense_overlap's bound MILP has many optima; which one is returned must not be decided by
    the last bits (it was: 17.75 s vs 19.47 s coordinated, on two machines)."""
    prob = load_problem(next(p for p in shipped_problems() if p.stem == "dense_overlap"))
    here = bound_details(prob)
    with pytest.MonkeyPatch.context() as mp, another_cpu(mp, salt):
        there = bound_details(prob)
    assert here.assignment == there.assignment and here.first_fruit == there.first_fruit
    assert here.value == there.value and here.proven and there.proven


@pytest.mark.parametrize("path", shipped_problems(), ids=lambda p: p.stem)
def test_coordinated_plans_do_not_depend_on_the_cpu(path):
    prob = load_problem(path)
    here = fingerprint(plan_coordinated(prob).plan)
    with pytest.MonkeyPatch.context() as mp, another_cpu(mp, salt=7):
        there = fingerprint(plan_coordinated(prob).plan)
    same(here, there)


def test_the_optimal_plan_and_its_search_do_not_depend_on_the_cpu(dense_here):
    prob, a = dense_here
    with pytest.MonkeyPatch.context() as mp, another_cpu(mp, salt=5):
        b = plan_optimal(prob, options=OptimalOptions(**SMALL)).plan
    assert search_path(a) == search_path(b)
    same(fingerprint(a), fingerprint(b))


_CHILD = r"""
import json, sys
from coplan.planners.coordinated import plan_coordinated
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.problem import load_problem
sys.path.insert(0, sys.argv[2])
from test_any_cpu import SMALL, fingerprint, search_path
prob = load_problem(sys.argv[1])
opt = plan_optimal(prob, options=OptimalOptions(**SMALL)).plan
print(json.dumps({"coordinated": fingerprint(plan_coordinated(prob).plan), "optimal": fingerprint(opt),
                  "search": search_path(opt)}))
"""


def _dispatched() -> list[str]:
    """NumPy's run-time SIMD targets this CPU has (switching them off leaves the baseline)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]


def test_this_machine_as_an_older_cpu_gives_the_same_plans(dense_here):
    """A subprocess with NumPy's SIMD dispatch off (baseline kernels only) and OpenBLAS's most
    generic kernel: the same coordinated and optimal plans as here."""
    features = _dispatched()
    if not features:  # a CPU with nothing beyond NumPy's baseline has no other kernels to try
        pytest.skip("NumPy dispatches no SIMD target on this CPU")
    path = next(p for p in shipped_problems() if p.stem == "dense_overlap")
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=",".join(features))
    if platform.machine() in ("x86_64", "AMD64"):
        env["OPENBLAS_CORETYPE"] = "Prescott"
    here_dir = str(Path(__file__).parent)
    out = subprocess.run([sys.executable, "-c", _CHILD, str(path), here_dir], env=env, capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    there = json.loads(out.stdout.strip().splitlines()[-1])
    prob, opt = dense_here
    assert search_path(opt) == there["search"]
    same(fingerprint(plan_coordinated(prob).plan), there["coordinated"])
    same(fingerprint(opt), there["optimal"])


_SCIPY_FIRST = r"""
import json, sys
if sys.argv[1] == "scipy":
    import scipy.linalg, scipy.optimize  # their OpenBLAS loads now: the CPU's own kernel, before coplan's pin
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.problem import load_problem
from coplan.plan.model import motion_digest
from coplan.provenance import openblas_kernels
plan = plan_optimal(load_problem(sys.argv[2]), options=OptimalOptions(search_work=2000)).plan
print(json.dumps({"digest": motion_digest(plan), "makespan": plan.metrics["makespan"], "kernels": openblas_kernels(),
                  "eased": (plan.solver.get("widen") or {}).get("ease", {}).get("arms")}))
"""


def test_scipy_imported_before_coplan_gives_the_same_plan():
    """(A notebook that imported SciPy before coplan got another crossing_paths plan: poses 1.2e-5
    rad apart, the makespan 3e-10 s -- SciPy's OpenBLAS ran the CPU's kernel, and the easing's
    SLSQP answered in other last bits.) The same plan bit for bit, whichever is imported first;
    plan.json's software record names the kernel each loaded OpenBLAS runs."""
    path = next(p for p in shipped_problems() if p.stem == "crossing_paths")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "COPLAN_OPENBLAS_CORETYPE")}
    runs = {}
    for first in ("scipy", "coplan"):
        out = subprocess.run([sys.executable, "-c", _SCIPY_FIRST, first, str(path)], env=env, capture_output=True,
                             text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        runs[first] = json.loads(out.stdout.strip().splitlines()[-1])
    if runs["scipy"]["kernels"] == runs["coplan"]["kernels"]:  # (aarch64: no pin; a CPU whose own kernel is the generic one)
        pytest.skip(f"SciPy's OpenBLAS runs the same kernel whichever is imported first here ({runs['coplan']['kernels']})")
    assert runs["scipy"]["eased"], "the easing (SciPy's SLSQP) is what this test exercises"
    assert runs["scipy"]["digest"] == runs["coplan"]["digest"] and runs["scipy"]["makespan"] == runs["coplan"]["makespan"]
    assert runs["coplan"]["kernels"] and runs["scipy"]["kernels"]
