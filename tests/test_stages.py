"""The optimal planner's flow: named stages run in turn over one incumbent, each reported."""

from __future__ import annotations

import coplan.planners.optimal.planner as planner_mod
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.planners.optimal.stages import STAGES
from coplan.problem import load_problem, shipped_problems

SMALL = OptimalOptions(search_work=3000, refine_retimes=4)


def _crossing():
    return load_problem(next(p for p in shipped_problems() if p.stem == "crossing_paths"))


def test_every_stage_runs_in_order_and_says_what_it_did():
    res = plan_optimal(_crossing(), options=SMALL)
    log = res.plan.solver["stages"]
    assert [s["stage"] for s in log] == [n for n, _ in STAGES] == \
        ["coordinated", "retime", "search", "refine", "polish", "widen", "regroup"]
    assert all(isinstance(s["result"], str) and s["wall_seconds"] >= 0 for s in log)
    assert log[0]["result"] == "planned" and log[4]["result"] == "skipped"  # polish is off by default
    assert res.plan.solver["search"] is not None and res.plan.solver["widen"] is not None
    # the widened plan keeps the widening's goal: nothing to regroup for
    assert log[6]["result"] == "skipped" and "the widening's goal" in res.plan.solver["regroup"]["reason"]


def test_a_stage_is_one_line_to_add_or_take_out(monkeypatch):
    seen = []

    def audit(run):  # a stage: sees the incumbent every earlier stage left
        seen.append((run.inc.source, run.inc.makespan))
        return "audited"

    no_search = tuple((n, s) for n, s in STAGES if n not in ("search", "refine")) + (("audit", audit),)
    monkeypatch.setattr(planner_mod, "STAGES", no_search)
    res = plan_optimal(_crossing(), options=SMALL)
    assert [s["stage"] for s in res.plan.solver["stages"]][-1] == "audit"
    assert res.plan.solver["search"] is None and res.plan.solver["refine"] is None
    assert res.verification.passed and seen and abs(seen[0][1] - res.plan.metrics["makespan"]) < 1e-3
