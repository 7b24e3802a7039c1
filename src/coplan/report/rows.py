"""A row's stop rules and on the move side by side (``coplan compare ROW.yaml``).

Entry point: :func:`compare_rows` -> :class:`RowComparison`: the row planned stop and go with
each stop rule (fixed stride, fewest stops, optimised; the same cell planner at every stop) and
on the move (the speed searched, as ``coplan solve ROW --gantry continuous``), each plan
verified in the row frame and written to ``<out>/<rule>/`` (``<out>/continuous/`` on the
move); ``compare.json`` and ``compare.md`` with, per plan, the stops, the row time, fruit per
hour, the share of the harvestable fruit harvested, the ratios to the row's lower bounds (the
stop-by-stop one for stop-and-go plans only: a plan on the move is not one it bounds), the
carriage's mean speed on the move, the planning time, and which plan harvests most fruit per
hour (``best``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from ..kinds import GantryMode, PlannerKind, PlanStatus, SpeedProfile, StopRule
from ..output import atomic_text, check_folder, is_run_folder, keep_reports
from ..plan import jsonable
from ..problem.given import as_problem
from ..problem.model import Problem
from ..progress import Tick, nested, speaker, ticker

__all__ = ["RowComparison", "compare_rows", "ROW_COLUMNS", "ON_THE_MOVE", "columns", "cell_text", "to_markdown"]

#: the name of the plan on the move in the comparison (its ``rule`` is None: it does not stop)
ON_THE_MOVE = "on the move"

#: (key, heading) of the comparison's table.
ROW_COLUMNS = (("name", "plan"), ("stops", "stops"), ("row_time", "row time, s"), ("fruit_per_hour", "fruit / h"),
               ("share_harvested", "harvested, of harvestable"), ("ratio_any_plan_bound", "/ bound (any plan)"),
               ("ratio_stop_and_go_bound", "/ bound (stop by stop, no overlap)"), ("speed", "speed, m/s"), ("planning_time", "planning, s"),
               ("first_motion_seconds", "first motion, s"), ("verified", "verified"))


@dataclass
class RowComparison:
    problem: str
    cell_planner: str = PlannerKind.COORDINATED.value  # the cell planner at every stop (it was recorded nowhere)
    rows: list[dict] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    gantry: str = GantryMode.AUTO.value  # which modes were compared (auto: both)

    @property
    def best(self) -> dict | None:
        """The verified plan with every harvestable fruit and the most fruit per hour, its lead
        over the best of the other mode where both were compared; None where no plan qualifies."""
        ok = [r for r in self.rows if r["verified"] and r["status"] == PlanStatus.SUCCESS.value and r["fruit_per_hour"]]
        if not ok:
            return None
        top = max(ok, key=lambda r: r["fruit_per_hour"])
        out = {"name": top["name"], "mode": top["mode"], "fruit_per_hour": top["fruit_per_hour"]}
        other = [r for r in ok if r["mode"] != top["mode"]]
        if other:
            runner = max(other, key=lambda r: r["fruit_per_hour"])
            out |= {"over": runner["name"], "gain": top["fruit_per_hour"] / runner["fruit_per_hour"] - 1.0}
        return out

    def to_dict(self) -> dict:
        return {"format": "coplan.compare-rows/2", "problem": self.problem, "cell_planner": self.cell_planner,
                "gantry": self.gantry, "rows": self.rows, "best": self.best, "notes": self.notes}

    @property
    def title(self) -> str:
        if self.gantry == GantryMode.CONTINUOUS.value:
            return f"{self.problem}: on the move (the speed searched)"
        what = "stop rules" if self.gantry == GantryMode.STOP_AND_GO.value else "stop rules and on the move"
        return f"{self.problem}: {what} side by side ({self.cell_planner} cell planner at each stop)"

    def best_text(self) -> str | None:
        """One line: which plan harvests most fruit per hour, and by how much over the other mode."""
        b = self.best
        if b is None:
            return None
        other = "" if "over" not in b else b["over"] if b["over"] == ON_THE_MOVE else f"the {b['over']} stops"
        lead = f", {100 * b['gain']:.1f} % more than {other}" if other else ""
        from ..row.metrics import late_start

        top = next(r for r in self.rows if r["name"] == b["name"])
        # (an optimal cell planner's row started 35.5 s after its planning began, which fruit per hour leaves out)
        wait = top.get("first_motion_seconds")
        late = (f"; its first motion {wait:.1f} s after planning starts, which fruit per hour does not count"
                if late_start(wait, top.get("row_time")) else "")
        return f"most fruit per hour: {b['name']} ({b['fruit_per_hour']:.0f} fruit/h{lead}){late}"


def compare_rows(problem: Problem, out_dir: str | Path, rules=tuple(StopRule), planner: PlannerKind | str | None = None,
                 progress=None, workers: int | None = None, gantry: GantryMode | str = GantryMode.AUTO,
                 profile: SpeedProfile | str | None = None) -> RowComparison:
    """Plan ``problem`` (a row) stop and go with each of ``rules`` and on the move; write each
    run and the comparison. ``gantry``: ``auto`` (default) both modes, ``stop-and-go`` the
    rules alone, ``continuous`` on the move alone (``rules`` and ``planner``, the cell planner
    at each stop, are then refused). ``workers``: each rule's stops' cells, and the speed
    search's levels on the move, in that many processes (:class:`coplan.row.plan.RowOptions`,
    :class:`coplan.row.continuous.MovingOptions`; the same plans for any number). ``profile``: what
    the speed search on the move varies (``density`` by default, ``constant``, or ``auto``: both,
    the better kept; refused with ``gantry="stop-and-go"``)."""
    from ..pipeline import solve
    from ..row.metrics import fruit_bounds_count

    # (a name or a path, as coplan.solve takes: it raised from inside)
    problem = as_problem(problem, lambda p: f"compare_rows: expected a Problem, a problem file's path or a shipped name, "
                                            f"found {type(p).__name__} {str(p)[:60]!r}")
    if problem.gantry is None:  # (before any work: it made the folder, then solve said "gantry: ...")
        raise ValueError(f"compare_rows: {problem.name!r} is a stationary cell (no gantry section): "
                         "coplan.report.comparison.compare compares a cell's planners")
    if isinstance(rules, str):  # one rule, not its letters ("found 'f'")
        rules = (rules,)
    rules = [StopRule(r) for r in rules]  # (a bad one refused before the folder is made)
    mode = GantryMode(gantry)
    profile = None if profile is None else SpeedProfile(profile)
    if profile is not None and mode == GantryMode.STOP_AND_GO:
        raise ValueError("profile: the speed search's profile applies on the move; gantry stop-and-go compares the stop rules alone")
    if mode == GantryMode.CONTINUOUS:
        if tuple(rules) != tuple(StopRule):
            raise ValueError("rules: on the move (gantry continuous) the carriage does not stop; a stop rule applies to stop and go")
        if planner is not None and PlannerKind(planner) != PlannerKind.COORDINATED:
            raise ValueError("planner: on the move the arms are planned by the row's own booking; the cell planners apply to stop and go")
        rules = []
    say, tick = speaker(progress), ticker(progress)
    check_folder(out_dir, "out_dir")  # (before any work)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cmp = RowComparison(problem.name, PlannerKind(planner).value if planner is not None else PlannerKind.COORDINATED.value,
                        gantry=mode.value)
    cmp.notes += keep_reports(out, ("compare.json", "compare.md"))  # (an earlier comparison's report, moved aside)
    runs: list[StopRule | None] = list(rules)
    if mode != GantryMode.STOP_AND_GO:
        runs.append(None)  # on the move, after the stop rules
    row_options = moving_options = None
    if workers is not None or profile is not None:
        from ..row.continuous import MovingOptions
        from ..row.plan import RowOptions

        row_options = RowOptions(workers=workers) if workers is not None else None
        moving_options = MovingOptions(**({"workers": workers} if workers is not None else {}),
                                       **({"profile": profile} if profile is not None else {}))
    for i, rule in enumerate(runs):
        name = rule.value if rule is not None else ON_THE_MOVE
        tick(Tick("compare", i, len(runs), "row plans", note=name))
        say(f"{problem.name}: " + (f"stops {rule.value}" if rule is not None else ON_THE_MOVE))
        what = f"stop rule {rule.value}" if rule is not None else ON_THE_MOVE
        try:
            if rule is not None:
                res = solve(problem, planner=planner, out_dir=out / rule.value, progress=nested(progress), stops=rule,
                            options=row_options, gantry=GantryMode.STOP_AND_GO)
            else:
                res = solve(problem, out_dir=out / GantryMode.CONTINUOUS.value, progress=nested(progress),
                            options=moving_options, gantry=GantryMode.CONTINUOUS)
        except KeyboardInterrupt:  # (before it had a plan to keep: the plans finished are still reported)
            cmp.notes.append(f"interrupted while planning {what}, before it had a plan: "
                             f"this report covers {i} of {len(runs)} plans")
            _write(cmp, out)
            raise
        m = res.plan.metrics.get("row") or {}
        cut = res.plan.status == PlanStatus.INTERRUPTED
        if res.error:  # (a stop's cell planner stopped on an internal error: its row is kept, and said not to be clean)
            cmp.notes.append(f"{name}: {res.error}")
        whole = (m.get("harvested") or 0) >= fruit_bounds_count(m)  # (no ratio to bounds that count fruit it left)
        label = name + (" (interrupted)" if cut else "")
        cmp.rows.append({"name": label, "mode": (GantryMode.STOP_AND_GO if rule is not None else GantryMode.CONTINUOUS).value,
                         "rule": label if rule is not None else None,
                         # (on the move the carriage follows no stop rule: a rest at either end, or a
                         # hold, is no stop -- it read "0" beside picks made with the carriage at rest)
                         "stops": m.get("stops") if rule is not None else None, "row_time": m.get("row_time"),
                         "fruit_per_hour": m.get("fruit_per_hour"), "share_harvested": m.get("share_harvested"),
                         "share_of_all_fruit": m.get("share_of_all_fruit"),
                         "ratio_any_plan_bound": m.get("ratio_any_plan_bound") if whole else None,
                         # (a plan on the move is no stop-by-stop plan: that bound does not hold for it)
                         "ratio_stop_and_go_bound": m.get("ratio_stop_and_go_bound") if whole and rule is not None else None,
                         "speed": m.get("mean_speed") if rule is None else None,
                         "profile": res.plan.solver.get("row", {}).get("profile") if rule is None else None,
                         "planning_time": m.get("planning_time"), "first_motion_seconds": m.get("first_motion_seconds"),
                         "kept_ahead": m.get("kept_ahead"), "verified": bool(res.verification.passed),
                         "status": res.plan.status.value, "error": res.error, "plan": str(res.files.get("json", ""))})
        if i == 0:
            cmp.notes += _beyond_every_plan(res.plan.metrics)
        if res.plan.status not in (PlanStatus.SUCCESS, PlanStatus.INTERRUPTED):  # (an empty row read "0.0 s, verified")
            cmp.notes.append(_status_note(name, res.plan, problem))
        if cut:  # Ctrl-C / SIGTERM: what finished is written, said, and the run stops
            cmp.notes.append(f"interrupted while planning {what}: its row is cut short (status interrupted); "
                             f"this report covers {i} of {len(runs)} plans whole")
            _write(cmp, out)
            raise KeyboardInterrupt
    cmp.notes += _earlier_runs(out, runs)
    _write(cmp, out)
    return cmp


def _beyond_every_plan(m: dict) -> list[str]:
    """A note of the row's fruit no plan can harvest (out of every arm's reach, or screened out),
    once: every row of the table read "harvested 100.0 %" of a row whose three fruit no arm
    reaches, and nothing said so -- what changes first between two designs."""
    ids = m.get("fruit_ids") or {}
    far, ruled = ids.get("unreachable") or [], ids.get("screened_out") or []
    if not (far or ruled):
        return []
    parts = ([f"{len(far)} out of every arm's reach from every carriage position"] if far else []) + (
        [f"{len(ruled)} screened out (reachable, but no carriage position lets a working arm harvest them)"] if ruled else [])
    return [f"{len(far) + len(ruled)} of the row's {m.get('fruit')} fruit no plan can harvest: {' and '.join(parts)} "
            f"(coplan check says why); 'harvested' is of the {m.get('harvestable')} harvestable"]


def _earlier_runs(out: Path, runs: list) -> list[str]:
    """Notes naming the plan folders an earlier comparison into ``out`` wrote that this one does
    not (``--gantry stop-and-go`` after both modes left ``continuous/`` there, in no report), as a
    cell's comparison names them: left as they were."""
    mine = {r.value if r is not None else GantryMode.CONTINUOUS.value for r in runs}
    known = {r.value for r in StopRule} | {GantryMode.CONTINUOUS.value}
    return [f"{out / name}: a plan of an earlier comparison (not in this one; left as it was)"
            for name in sorted(known - mine) if is_run_folder(out / name)]


def _status_note(name: str, plan, problem: Problem) -> str:
    """Why a rule's row is not a success, in one line (its status is in compare.json too)."""
    m = plan.metrics
    why = {PlanStatus.INFEASIBLE: "no fruit can be harvested from any carriage position"
                                  + (" (the problem lists no fruit)" if not problem.fruits else ""),
           PlanStatus.PARTIAL: f"{m.get('harvested', 0)} of {m.get('harvestable', m.get('reachable', 0))} harvestable fruit harvested",
           PlanStatus.UNSAFE: "the verifier failed its plan (verification.json says where)"}.get(plan.status, "")
    what = f"stop rule {name}" if name != ON_THE_MOVE else ON_THE_MOVE
    return f"{what}: status {plan.status.value}" + (f": {why}" if why else "")


def _write(cmp: RowComparison, out: Path) -> None:
    """compare.json and compare.md (each rule's share of the best fruit per hour among those written)."""
    best = max((r["fruit_per_hour"] or 0.0 for r in cmp.rows), default=0.0)
    for r in cmp.rows:
        r["fruit_per_hour_vs_best"] = (r["fruit_per_hour"] or 0.0) / best if best else None
    cmp.files = {"json": str(out / "compare.json"), "markdown": str(out / "compare.md")}
    atomic_text(out / "compare.json", json.dumps(jsonable(cmp.to_dict()), indent=1, allow_nan=False))
    atomic_text(out / "compare.md", to_markdown(cmp))


def columns(cmp: RowComparison) -> tuple[tuple[str, str], ...]:
    """The table's columns for ``cmp``: the speed only where a plan is on the move, the
    stop-by-stop bound's ratio only where one stops."""
    modes = {r["mode"] for r in cmp.rows}
    drop = ({"speed"} if GantryMode.CONTINUOUS.value not in modes else set()) \
        | ({"ratio_stop_and_go_bound"} if GantryMode.STOP_AND_GO.value not in modes else set())
    return tuple(c for c in ROW_COLUMNS if c[0] not in drop)


def cell_text(key: str, v) -> str:
    if v is None:
        return "-"
    if key == "share_harvested":
        return f"{100 * v:.1f} %"
    if key == "verified":
        return "yes" if v else "NO"
    if key == "speed":
        return f"{v:.3f}"
    if key == "fruit_per_hour":  # (whole fruit, as the summaries and the README give it)
        return f"{v:.0f}"
    if isinstance(v, float):
        return f"{v:.3f}" if key.startswith("ratio") else f"{v:.2f}" if key in ("planning_time", "first_motion_seconds") else f"{v:.1f}"
    return str(v)


def to_markdown(cmp: RowComparison) -> str:
    lines = [f"# {cmp.title}", "",
             "| " + " | ".join(h for _, h in columns(cmp)) + " |", "|" + "---|" * len(columns(cmp))]
    lines += ["| " + " | ".join(cell_text(k, r.get(k)) for k, _ in columns(cmp)) + " |" for r in cmp.rows]
    best = cmp.best_text()
    lines += ["", best[0].upper() + best[1:] + "."] if best else []
    lines += [""] + [f"Note: {n}" for n in cmp.notes] if cmp.notes else []
    return "\n".join(lines) + "\n"
