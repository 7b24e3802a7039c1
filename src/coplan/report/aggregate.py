"""Per planner, over every problem it ran on: counts, medians and worst cases of the rows of a
comparison (:func:`coplan.report.comparison.compare`: ``compare.json`` ``aggregate``)."""

from __future__ import annotations

import math
import statistics
from typing import Any

from ..kinds import PlanStatus

__all__ = ["aggregate"]

_MEDIANS = ("makespan", "makespan_ratio", "throughput", "cycle_time_worst", "min_clearance", "certified_clearance",
            "peak_jerk", "planning_time")


def _median(vals: list) -> float | None:
    v = [x for x in vals if isinstance(x, (int, float)) and math.isfinite(x)]
    return statistics.median(v) if v else None


def _worst(rows: list[dict], key: str, highest: bool) -> dict | None:
    ok = [r for r in rows if isinstance(r.get(key), (int, float)) and math.isfinite(r[key])]
    if not ok or (highest and max(r[key] for r in ok) == 0):  # (a most of 0 named one problem of many)
        return None
    r = (max if highest else min)(ok, key=lambda r: r[key])
    return {"problem": r["problem"], "file": r.get("file"), "value": r[key]}


def _worst_jerk(rows: list[dict]) -> dict | None:
    """The worst peak jerk / limit; where a plan's acceleration jumps its jerk is unbounded (its
    sampled peak grows with the rate: no figure to rank), said so with the first such problem."""
    stepping = [r for r in rows if r.get("acceleration_steps")]
    if not stepping:
        return _worst(rows, "peak_jerk", True)
    r = stepping[0]
    return {"problem": r["problem"], "file": r.get("file"), "value": None, "unbounded": True}


def aggregate(rows: list[dict], planners: list[str]) -> dict[str, Any]:
    """Per planner: counts, medians and worst cases over every problem it ran on."""
    out: dict[str, Any] = {}
    for label in planners:
        mine = [r for r in rows if r["planner"] == label]
        ok = [r for r in mine if not r.get("error")]
        statuses: dict[str, int] = {}
        for r in ok:
            statuses[r["status"]] = statuses.get(r["status"], 0) + 1
        rel = [k for k in (ok[0] if ok else {}) if k.startswith("makespan_vs_")]
        out[label] = {
            "runs": len(mine),
            "errors": len(mine) - len(ok),
            "passed": sum(r["passed"] for r in ok),
            "complete": sum(r["passed"] and r["complete"] for r in ok),
            "collision_free": sum(r["collision_count"] == 0 for r in ok),
            "statuses": statuses,
            "fruit_harvested": sum(r["harvested"] or 0 for r in ok),
            "fruit_reachable": sum(r["reachable"] or 0 for r in ok),
            # (a problem with nothing to plan -- no reachable fruit, makespan 0 -- is no plan's median)
            "median": {k: _median([r.get(k) for r in ok if r.get("status") != PlanStatus.INFEASIBLE]) for k in _MEDIANS + tuple(rel)},
            "worst": {
                "makespan_ratio": _worst(ok, "makespan_ratio", True),
                "min_clearance": _worst(ok, "min_clearance", False),
                "collision_count": _worst(ok, "collision_count", True),
                "peak_jerk": _worst_jerk(ok),
                "planning_time": _worst(ok, "planning_time", True),
            },
        }
    return out
