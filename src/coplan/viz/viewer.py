"""The interactive plan viewer: one self-contained HTML page per plan (or per pair of plans).

Entry points: :func:`render_html` (the page as a string), :func:`write_html` (to a file),
:func:`view` (the same page inline in Jupyter: an object with ``_repr_html_``). Used by
``coplan view PLAN`` and ``coplan solve --html``.

The page needs nothing outside itself: the script, the style sheet and the data are inline
and a Content-Security-Policy forbids every network request, so it works offline and from an
e-mail attachment. What it embeds (JSON in a ``<script type="application/json">`` element,
numeric arrays as base64 little-endian binary; :func:`read_viewer_data` decodes it back):

* the cell: bases, links (capsule radius), joint limits, bins, fruit, required clearance,
  unreachable fruit with the screen's reason (:mod:`coplan.allocate.screen`), a manipulability grid
  (:func:`coplan.viz.plots.workspace_maps`);
* per plan: a display track of every arm's joint angles at ``display_rate`` (float32: what
  the picture and the tip trails are drawn from), the plan's own grid of joint angles at
  plan.json's resolution (1e-7 rad, as int32 steps) for the readouts (joint values and the
  replay velocities a hover shows: what :meth:`Plan.sample` gives for the stored plan), the events, the phases of :func:`coplan.viz.timeline.schedule`
  with what each wait is for, the clearance of every neighbouring pair
  (:func:`coplan.verify.clearance.clearance_profile`, 1 kHz, reduced to the least value per display
  sample so no dip is lost) and the verdict of :func:`coplan.verify.verify` with every
  violation.

The page reads ``#t=4.25`` from its address on load and writes it back as the slider moves.
"""

from __future__ import annotations

import base64
import html
import json
import re
import webbrowser
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import Issue, PlanFileError
from ..kinds import EventKind, GantryMode
from ..output import atomic_text
from ..plan import Plan, checked_status, jerk_figures, jsonable, load_plan
from ..problem.model import Problem
from ..verify.verdict import ViolationKind, WarningKind, measured_metrics
from .style import ALERT_COLOR, FRUIT_COLOR, arm_colors
from .timeline import ArmPhase, Segment, schedule

__all__ = [
    "DISPLAY_RATE",
    "VIEWER_FORMAT",
    "viewer_data",
    "render_html",
    "write_html",
    "write_view",
    "read_viewer_data",
    "decode_array",
    "problem_of",
    "PlanView",
    "view",
]

VIEWER_FORMAT = "coplan.viewer/1"
DISPLAY_RATE = 50.0  # Hz: the picture's frame grid (the readouts use the plan's own grid)
MAX_DISPLAY_SAMPLES = 20_000  # per plan: a longer plan is drawn at a lower rate
Q_RESOLUTION = 1e-7  # rad: plan.json stores joint angles rounded to this; the readouts' data keeps exactly that
MANIP_RESOLUTION = 160  # columns of the manipulability grid
_DATA_ID = "coplan-data"
_MARKER = re.compile(r"/\*@(CSS|JS)@\*/|@@(TITLE|DATA)@@")
_DATA_RE = re.compile(rf'<script type="application/json" id="{_DATA_ID}">(.*?)</script>', re.S)


# --------------------------------------------------------------------------- arrays
def _encode(a: np.ndarray, dtype: str) -> dict:
    """A numeric array as ``{dtype, shape, b64}`` (little-endian; JS typed arrays read it)."""
    arr = np.ascontiguousarray(np.asarray(a, dtype=np.dtype(dtype).newbyteorder("<")))
    return {"dtype": dtype.lstrip("<"), "shape": list(arr.shape), "b64": base64.b64encode(arr.tobytes()).decode("ascii")}


def decode_array(entry: dict) -> np.ndarray:
    """The array an embedded ``{dtype, shape, b64}`` entry holds."""
    raw = base64.b64decode(entry["b64"])
    return np.frombuffer(raw, dtype=np.dtype(entry["dtype"]).newbyteorder("<")).reshape(entry["shape"])


# --------------------------------------------------------------------------- the problem
def problem_of(plan: Plan) -> Problem:
    """The problem of a plan, as ``coplan view`` finds it
    (:func:`coplan.problem.recorded.recorded_problem`): the problem file the plan records
    (unchanged since: its digest), else the shipped problem or row the plan names, with a
    UserWarning that it is the shipped one (or that the recorded file bears a shipped problem's
    name but is another text). Raises :class:`PlanFileError` when there is none,
    when the recorded file has changed since, or when it is gone and the shipped problem of that
    name is another text (not shown in its place: it may be another)."""
    from ..problem.recorded import recorded_problem

    found = recorded_problem(plan.problem, plan.problem_file, "pass the problem itself (problem=, or view the "
                                                               "SolveResult, which carries its own)")
    if found.note:  # (as coplan view notes it; coplan.view said nothing)
        import warnings

        warnings.warn(found.note, UserWarning, stacklevel=3)
    return found.problem


def _check_fits(problem: Problem, plan: Plan, what: str) -> None:
    missing = [a.name for a in problem.arms if a.name not in plan.q]
    if missing:
        raise PlanFileError([Issue("arms", f"expected a trajectory for every arm of problem {problem.name!r} "
                                           f"({', '.join(a.name for a in problem.arms)}), found none for {', '.join(missing)}")], what)


def _view_box(problem: Problem, plans: list[Plan]) -> list[float]:
    """World rectangle drawn: bases, bins, fruit and wherever the plans' links go (capsules).
    A row's is in the carriage's frame (the page moves it with the carriage): the arms' reach
    and the fruit's heights."""
    from ..kinematics import arm as kin

    pts = [np.asarray(a.base, float) for a in problem.arms] + [np.asarray(a.bin, float) for a in problem.arms]
    if problem.gantry is not None:
        pts += [np.asarray([a.base[0] - a.reach, a.base[1]], float) for a in problem.arms]
        pts += [np.asarray([a.base[0] + a.reach, a.base[1]], float) for a in problem.arms]
        if problem.fruits:
            ys = problem.fruit_positions[:, 1]
            pts += [np.asarray([problem.arms[0].base[0], ys.min()]), np.asarray([problem.arms[0].base[0], ys.max()])]
    elif problem.fruits:
        pts += list(problem.fruit_positions)
    pad = max((a.link_radius for a in problem.arms), default=0.0)
    for p in plans:
        times = np.linspace(0.0, p.duration, max(2, min(2000, p.time.size)))
        q = p.sample(times)
        for a in problem.arms:
            xy = kin.fk_points(q[a.name], a.links, a.base).reshape(-1, 2)
            pts += [xy.min(axis=0) - pad, xy.max(axis=0) + pad]
    lo, hi = np.min(pts, axis=0) - 0.2, np.max(pts, axis=0) + 0.2
    return [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])]


def _problem_data(problem: Problem, plans: list[Plan]) -> dict:
    from ..allocate.screen import screened
    from .plots import workspace_maps

    colors = arm_colors(problem)
    scr = screened(problem if problem.gantry is None else _carriage_cell(problem))
    fruits = []
    if problem.gantry is None:
        reach = problem.reach_matrix()
        for k, f in enumerate(problem.fruits):
            entry = {"id": f.id, "pos": list(f.position), "reach": [a.name for i, a in enumerate(problem.arms) if scr.reach[i, k]]}
            if f.id in scr.unharvestable:
                default = "out of every arm's reach" if not reach[:, k].any() else "no arm can pick it (screen)"
                entry["unreachable"] = scr.reasons.get(f.id, default)
            fruits.append(entry)
    else:  # a row: who may take a fruit depends on where the carriage stands; the plans say who did
        out = {}
        for p in plans:
            out.update(((p.metrics or {}).get("row") or {}).get("screened_out") or {})
        for f in problem.fruits:
            entry = {"id": f.id, "pos": list(f.position), "reach": sorted({e.arm for p in plans for e in p.events if e.fruit == f.id})}
            if f.id in out:
                entry["unreachable"] = out[f.id]
            fruits.append(entry)
    xs, ys, best, _ = workspace_maps(problem if problem.gantry is None else _carriage_cell(problem), resolution=MANIP_RESOLUTION)
    top = float(np.nanmax(best)) if np.isfinite(best).any() else 1.0
    grid = np.where(np.isfinite(best), 1 + np.round(254 * np.nan_to_num(best) / max(top, 1e-12)), 0).astype(np.uint8)
    return {
        "name": problem.name,
        "description": problem.description,
        "arms": [
            {"name": a.name, "base": list(a.base), "bin": list(a.bin), "links": list(a.links), "radius": a.link_radius,
             "limits": [list(r) for r in a.joint_limits], "max_velocity": list(a.max_velocity), "home": list(a.home),
             "color": colors[a.name], "locked": a.name in scr.locked, "locked_reason": scr.reasons.get(a.name)}
            for a in problem.arms
        ],
        "fruits": fruits,
        "task": {"clearance": problem.task.clearance, "pick_dwell": problem.task.pick_dwell, "place_dwell": problem.task.place_dwell},
        "pairs": [[problem.arms[i].name, problem.arms[j].name] for i, j in problem.neighbour_pairs()],
        "view": _view_box(problem, plans),
        "manip": {"grid": _encode(grid, "u1"), "x": [float(xs[0]), float(xs[-1])], "y": [float(ys[0]), float(ys[-1])], "max": top},
        "colors": {"fruit": FRUIT_COLOR, "alert": ALERT_COLOR},
    } | ({"row": _row_data(problem, plans)} if problem.gantry is not None else {})


def _carriage_cell(problem: Problem) -> Problem:
    """A row's arms on the carriage at its origin, no fruit: the frame the page draws them in."""
    from ..problem.gantry import cell_at

    return cell_at(problem, 0.0, ())


def _row_data(problem: Problem, plans: list[Plan]) -> dict:
    """What the row strip draws: the rail, the arms' reach along it, each plan's stops (where
    the carriage stood still for a pick; a pick on the move is no stop) and whether it picks on
    the move (``moving``: its picks at rest -- where the carriage starts, or at its rest at the
    row's end -- are rests of a plan with no stops)."""
    g = problem.gantry
    lo = min(a.base[0] - a.reach for a in problem.arms)
    hi = max(a.base[0] + a.reach for a in problem.arms)
    stops, moving = [], []
    for p in plans:
        row = (p.solver or {}).get("row") or (p.metrics or {}).get("row") or {}
        # (its picks at rest are rests, not stops: the summary says 0 stops; a live run's on the move,
        # "continuous-live", too: its picks at rest are holds)
        moving.append(str(row.get("mode") or "").startswith(GantryMode.CONTINUOUS.value))
        x = np.asarray(p.gantry_x, float)
        mine = []
        for e in sorted(p.events, key=lambda e: e.t_start):
            if e.kind == EventKind.PICK:
                k = min(int(round(e.t_start / p.dt)), x.size - 1)
                k1 = min(int(round(e.t_end / p.dt)), x.size - 1)
                if np.ptp(x[k:k1 + 1]) > 1e-9:
                    continue  # picked on the move
                if mine and abs(mine[-1]["x"] - x[k]) <= 1e-6:
                    mine[-1]["fruit"].append(e.fruit)
                else:
                    mine.append({"x": float(x[k]), "fruit": [e.fruit]})
        stops.append(sorted(mine, key=lambda s: s["x"]))
    return {"start": g.start, "end": g.end, "reach": [lo, hi], "stops": stops, "moving": moving}


# --------------------------------------------------------------------------- one plan
def _waits(plan: Plan, segs: dict[str, list[Segment]], pairs: list[tuple[str, str]]) -> dict[str, list[dict]]:
    """For every idle stretch: what the arm does next (the plan's events say this) and, when a
    neighbour's own phase changes as the wait ends, that neighbour and its phase (a reading
    of the timeline: the plan does not store why the planner made the arm wait)."""
    held: dict[str, list[tuple[float, float, str]]] = {}
    for e in plan.events:
        if e.kind == EventKind.PICK:
            place = next((p for p in plan.events if p.kind == EventKind.PLACE and p.fruit == e.fruit and p.arm == e.arm), None)
            held.setdefault(e.arm, []).append((e.t_end, place.t_start if place else plan.duration, e.fruit))
    neighbours = {a: [b for p in pairs for b in p if a in p and b != a] for a in segs}
    out: dict[str, list[dict]] = {}
    for arm, ss in segs.items():
        notes = []
        for k, s in enumerate(ss):
            if s.phase != ArmPhase.IDLE:
                continue
            nxt = next((x for x in ss[k + 1:] if x.phase != ArmPhase.IDLE), None)
            carrying = next((f for t0, t1, f in held.get(arm, []) if t0 <= s.t0 + 1e-9 and s.t1 <= t1 + 1e-9), None)
            if nxt is None:
                purpose = "done: every task finished"
            elif carrying is not None:
                purpose = f"holding {carrying}, before carrying it to the bin"
            elif nxt.phase == ArmPhase.MOVING and nxt.fruit is not None:
                purpose = f"before going to pick {nxt.fruit}"
            elif nxt.phase == ArmPhase.MOVING:
                purpose = "before going home"
            else:
                purpose = f"before {nxt.phase} {nxt.fruit or ''}".strip()
            note = {"t0": s.t0, "t1": s.t1, "for": purpose}
            if nxt is not None:
                best = None
                for b in neighbours.get(arm, []):
                    for o in segs[b]:
                        if abs(o.t1 - s.t1) <= 0.05 + 1e-9 and o.phase != ArmPhase.IDLE and o.t0 < s.t1:
                            if best is None or abs(o.t1 - s.t1) < abs(best[1].t1 - s.t1):
                                best = (b, o)
                if best is not None:
                    b, o = best
                    what = f"{o.phase} {o.fruit}" if o.fruit else o.phase
                    note["until"] = {"arm": b, "phase": o.phase.value, "fruit": o.fruit, "t": o.t1,
                                     "text": f"ends as {b} finishes {what} (at {o.t1:.2f} s)"}
            notes.append(note)
        out[arm] = notes
    return out


def _display_times(plan: Plan, rate: float) -> tuple[np.ndarray, float]:
    rate = min(rate, MAX_DISPLAY_SAMPLES / max(plan.duration, 1e-9))
    n = int(np.floor(plan.duration * rate + 1e-9)) + 1
    return np.arange(n) / rate, rate


def _clearance(problem: Problem, plan: Plan, times: np.ndarray, rate: float) -> list[dict]:
    """Per neighbouring pair: the least clearance within half a display step of each display time."""
    from ..verify.clearance import clearance_chunks

    pairs = problem.neighbour_pairs()
    if not pairs:
        return []
    low = {p: np.full(times.size, np.inf) for p in pairs}
    # (in pieces: a 2 h plan's whole 1 kHz profile took 2.2 GB)
    for t, prof in clearance_chunks(problem, plan, pairs=pairs):
        idx = np.clip(np.round(t * rate).astype(int), 0, times.size - 1)
        for p, d in prof.items():
            np.minimum.at(low[p], idx, d)
    out = []
    for (i, j), lo in low.items():
        gap = ~np.isfinite(lo)
        if gap.any():  # a display instant with no dense instant within half a step: the profile there
            from ..verify.clearance import clearance_profile

            t, prof = clearance_profile(problem, plan, pairs=[(i, j)])
            lo[gap] = np.interp(times, t, prof[(i, j)])[gap]
        out.append({"arms": [problem.arms[i].name, problem.arms[j].name], "d": _encode(lo, "<f4")})
    return out


def _violations(ver) -> list[dict]:
    """The verdict's violations for the page's table; ``step``: an acceleration step (its value and
    limit are accelerations, rad/s^2: the table said rad/s^3 beside them)."""
    keys = ("t", "t_start", "t_end", "value", "limit", "amount", "joint", "fruit", "message")
    return [{"kind": v.kind.value, "arms": list(v.arms), "step": bool(v.step)} | {k: getattr(v, k) for k in keys}
            for v in ver.violations]


def _row_headline(plan: Plan, m: dict) -> dict | None:
    """A row's headline figures (mode, fruit per hour, share harvested, row time, stops): a
    planned row's ``metrics.row``; a live row's from its run's metrics (``solver.live``: its
    headline said only the makespan); None for a cell."""
    keys = ("mode", "fruit_per_hour", "share_harvested", "row_time", "stops")
    if m.get("row"):
        return {k: m["row"].get(k) for k in keys}
    live = (plan.solver or {}).get("live")
    if plan.gantry_x is None or not isinstance(live, dict):
        return None
    reach = m.get("reachable")
    return {"mode": live.get("mode"), "fruit_per_hour": live.get("fruit_per_hour"), "row_time": live.get("row_time"),
            "share_harvested": live.get("harvested", 0) / reach if reach else None, "stops": live.get("stops")}


def _harvested(metrics: dict, ver) -> int | None:
    """The fruit harvested as the verdict counts them: the file's count, less the reachable fruit
    the verifier finds unharvested where the file claims more (a pick cut short), and less the
    fruit whose pick missed it (the tip never on it: "4/4" was said beside a missed pick)."""
    got, reach = metrics.get("harvested"), metrics.get("reachable")
    if got is None or reach is None:
        return ver.measured.get("harvested")
    missed = {v.fruit for v in ver.violations if v.kind == ViolationKind.PICK_MISSED and v.fruit} - set(ver.unharvested)
    return max(0, min(int(got), int(reach) - len(ver.unharvested)) - len(missed))


def _own_bound(problem: Problem, plan: Plan) -> float | None:
    """``plan``'s recorded lower bound where it was planned from ``problem``'s own text (its
    ``problem_file`` digest is the problem's); else None: the bound is the problem's."""
    rec = plan.problem_file or {}
    if problem.digest is None or rec.get("sha256") != problem.digest:
        return None
    return (plan.metrics or {}).get("lower_bound")


def _plan_data(problem: Problem, plan: Plan, ver, rate: float, lower_bound: float | None,
               own_bound: float | None = None) -> dict:
    names = [a.name for a in problem.arms]
    times, rate = _display_times(plan, rate)
    samples = plan.sample(times)
    track = np.stack([samples[a] for a in names], axis=0)  # (A, K, 2)
    exact = np.stack([np.asarray(plan.q[a], float) for a in names], axis=0)  # (A, N, 2)
    steps = np.round(exact / Q_RESOLUTION)
    if np.abs(steps).max(initial=0.0) < 2**31 - 1:  # plan.json's own resolution, as int32 steps
        exact_entry = {"scale": Q_RESOLUTION, "q": _encode(steps, "<i4")}
    else:
        exact_entry = {"scale": 1.0, "q": _encode(exact, "<f8")}
    segs = schedule(plan)
    pairs = [tuple(p) for p in ([problem.arms[i].name, problem.arms[j].name] for i, j in problem.neighbour_pairs())]
    m = measured_metrics(plan.metrics, ver.stated_figures)  # (as the note on the page says: the measured figures)
    steps = ver.acceleration_steps()
    pair_stats = [{"arms": list(p.arms), "min": p.min_clearance, "t": p.t, "certified": p.certified,
                   "margin": p.certified - ver.required_clearance} for p in ver.pairs]
    return {
        "planner": plan.planner_name,
        "label": plan.label,  # (a row's: how its carriage moved too)
        "status": checked_status(plan.status, ver).value,  # (the verdict shown beside it, not the file's word)
        "duration": plan.duration,
        # (the motion's, as the verifier measures it: an edited file's "5 s" read x0.388 of the lower bound)
        "makespan": ver.measured.get("makespan", max((e.t_end for e in plan.events if e.kind == EventKind.PLACE), default=0.0)),
        "lower_bound": own_bound if own_bound is not None else lower_bound,
        "harvested": _harvested(m, ver),  # (the motion's count where the file states none: a plan.csv said "-/4")
        # (the problem's where the plan is drawn over another text of it, a cell's; a row's is its screen's, as recorded)
        "reachable": m.get("reachable") if own_bound is not None or problem.gantry is not None else len(problem.reachable_ids()),
        "display": {"rate": rate, "n": int(times.size), "q": _encode(track, "<f4")},
        "gantry": None if plan.gantry_x is None else _encode(np.interp(times, plan.time, plan.gantry_x), "<f4"),
        "exact": {"dt": plan.dt, "n": int(plan.time.size)} | exact_entry,
        "events": [e.to_dict() for e in sorted(plan.events, key=lambda e: (e.t_start, e.arm))],
        "allocation": plan.allocation,
        "unreachable": list(plan.unreachable),
        # why a harvestable fruit was left (a row's planner says it: "passed arm1's reach at t = ...")
        "left_out": {k: str(v) for k, v in ((plan.solver or {}).get("row", {}).get("left_out") or {}).items()},
        # a row's headline figures, as the summary gives them (fruit per hour, share harvested, row time, stops)
        "row": _row_headline(plan, m),
        "segments": {a: [{"phase": s.phase.value, "t0": s.t0, "t1": s.t1, "fruit": s.fruit} for s in segs.get(a, [])] for a in names},
        "waits": _waits(plan, segs, pairs),
        "clearance": _clearance(problem, plan, times, rate),
        "verdict": {
            "passed": ver.passed,
            "complete": ver.complete,
            "unharvested": list(ver.unharvested),
            "violation_count": len(ver.violations),
            "violation_kinds": sorted({v.kind.value for v in ver.violations}),
            "min_clearance": ver.min_clearance,
            "certified_clearance": ver.certified_clearance,
            "required_clearance": ver.required_clearance,
            "margin": ver.margin,
            "pairs": pair_stats,
            # (an arm whose acceleration steps has no finite jerk: the page said "62 / 1051" where the
            # summary, compare and coplan verify say unbounded)
            # (from the motion, as the margin beside it: a plan.csv has no per-arm figures -- the page
            # said "RMS / peak jerk rad/s^3" and no number -- and an edited plan.json's were shown unchecked)
            "jerk": {a: {"rms": v["rms_jerk"], "peak": v["peak_jerk"], "unbounded": a in steps}
                     for a, v in jerk_figures(plan).items()},
            "warnings": len(ver.warnings),
            # (a file whose stated makespan or harvest is not its motion's: said on the page, as in the terminal)
            "notes": [w.message for w in ver.warnings if w.kind == WarningKind.STATED_FIGURES],
        },
        "violations": _violations(ver),
    }


def viewer_data(problem: Problem, plans: list[Plan], verifications: list | None = None, *,
                display_rate: float = DISPLAY_RATE) -> dict:
    """Everything the page shows, JSON-able (see the module docstring). ``verifications``
    (one per plan, or None to run :func:`coplan.verify.verify`) are the verdicts shown."""
    from ..verify.verifier import verify

    if not plans:
        raise ValueError("viewer_data needs at least one plan")
    if not display_rate > 0:
        raise ValueError(f"display_rate: expected a positive rate in Hz, found {display_rate}")
    for k, p in enumerate(plans):
        _check_fits(problem, p, f"plan {k + 1} ({p.planner_name})")
    vers = list(verifications) if verifications is not None else [None] * len(plans)
    vers = [v if v is not None else verify(problem, p) for p, v in zip(plans, vers)]
    # a plan's own bound where it was planned from this very problem text; else the problem's
    # (a plan drawn over an edited problem showed the bound its file recorded: 12.883 s where the
    # problem's, slower joints, is 14.061 s)
    own = [_own_bound(problem, p) for p in plans]
    plans_bound = [b for b in own if b is not None]
    bound = plans_bound[0] if plans_bound else None
    if bound is None and problem.gantry is not None:  # a row plan from elsewhere (a live run's): the row's bound
        from ..allocate.row_bound import row_bounds

        bound = row_bounds(problem, priced=False).any_plan
    elif bound is None and problem.reachable_ids():
        from ..allocate.allocation import bound_details

        bound = bound_details(problem).value
    return {
        "format": VIEWER_FORMAT,
        "problem": _problem_data(problem, plans),
        "plans": [_plan_data(problem, p, v, display_rate, bound, b) for p, v, b in zip(plans, vers, own)],
        "lower_bound": bound,
    }


# --------------------------------------------------------------------------- the page
def _asset(name: str) -> str:
    return (resources.files("coplan.viz") / "viewer_assets" / name).read_text(encoding="utf-8")


def _script_json(doc: Any) -> str:
    """JSON safe inside a ``<script>`` element: no ``<``, ``>`` or ``&`` can end or open a tag."""
    text = json.dumps(jsonable(doc), separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def render_html(problem: Problem, plan: Plan, compare: Plan | None = None, *, verification=None,
                compare_verification=None, display_rate: float = DISPLAY_RATE, title: str | None = None) -> str:
    """The viewer page of ``plan`` (and, side by side on one clock, ``compare``) as one
    self-contained HTML document. Verdicts are computed unless given."""
    if compare is not None and compare.problem and plan.problem and compare.problem != plan.problem:  # (a plan.csv names none)
        raise PlanFileError([Issue("problem", f"expected a plan of the same problem {plan.problem!r} to compare with, "
                                              f"found a plan of {compare.problem!r}")], "compare")
    plans = [plan] if compare is None else [plan, compare]
    vers = [verification] if compare is None else [verification, compare_verification]
    data = viewer_data(problem, plans, vers, display_rate=display_rate)
    heading = title or f"{problem.name}: " + " vs ".join(p.label for p in plans)
    parts = {"CSS": _asset("viewer.css"), "JS": _asset("viewer.js"), "TITLE": html.escape(heading), "DATA": _script_json(data)}
    return _MARKER.sub(lambda m: parts[m.group(1) or m.group(2)], _asset("viewer.html"))


def write_html(path: str | Path, problem: Problem, plan: Plan, compare: Plan | None = None, **kwargs) -> Path:
    """Write the page of :func:`render_html` to ``path`` (via a temporary name, so a crash
    never leaves half a page); returns the path."""
    p = Path(path)
    page = render_html(problem, plan, compare, **kwargs)
    p.parent.mkdir(parents=True, exist_ok=True)
    atomic_text(p, page)
    return p


def write_view(problem: Problem, plan: Plan, compare: Plan | None, out: str | Path, open_browser: bool = False,
               notify=None, **verdicts) -> Path:
    """``coplan view``: write the page to ``out`` (an ``.html`` file) and optionally open it
    (``notify(message)`` when no browser could be opened); ``verdicts``:
    ``verification`` / ``compare_verification`` when computed already."""
    p = Path(out)
    if p.is_dir():
        raise PlanFileError([Issue("--out", f"expected an .html file to write, found the folder {p}")], str(p))
    if p.suffix.lower() not in (".html", ".htm"):
        raise PlanFileError([Issue("--out", f"expected a file name ending in .html, found {p.name!r}")], str(p))
    written = write_html(p, problem, plan, compare, **verdicts)
    if open_browser and not webbrowser.open(written.resolve().as_uri()) and notify is not None:
        notify(f"no web browser could be opened here; open {written.resolve().as_uri()} in one")
    return written


def read_viewer_data(page: str) -> dict:
    """The data embedded in a viewer page (arrays still encoded: see :func:`decode_array`)."""
    m = _DATA_RE.search(page)
    if m is None:
        raise ValueError("not a coplan viewer page: no embedded data element")
    return json.loads(m.group(1))


# --------------------------------------------------------------------------- notebooks
@dataclass
class PlanView:
    """A viewer page for notebooks: displays inline (an iframe holding the whole page)."""

    page: str
    height: int = 900

    def __repr__(self) -> str:  # (a plain REPL printed the whole page: 147,000 characters)
        title = re.search(r"<title>(.*?)</title>", self.page, re.S)
        return (f"PlanView({html.unescape(title.group(1)).strip()!r}, {len(self.page):,} characters; "
                "shown inline in a notebook, .save(path) or .open(path) for a browser)" if title else
                f"PlanView({len(self.page):,} characters; shown inline in a notebook, .save(path) or .open(path))")

    def _repr_html_(self) -> str:
        return (f'<iframe srcdoc="{html.escape(self.page, quote=True)}" style="width:100%;height:{int(self.height)}px;'
                'border:1px solid #ddd" sandbox="allow-scripts" title="coplan plan viewer"></iframe>')

    def save(self, path: str | Path) -> Path:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(self.page, encoding="utf-8")
        return p

    def open(self, path: str | Path) -> Path:
        """Save the page and open it in the default browser."""
        p = self.save(path).resolve()
        webbrowser.open(p.as_uri())
        return p


def _as_plan(obj, what: str):
    """(plan, problem or None, verification or None) from a Plan, a SolveResult or a plan.json path."""
    if isinstance(obj, Plan):
        return obj, None, None
    if isinstance(obj, (str, Path)):
        return load_plan(obj), None, None
    if hasattr(obj, "plan") and isinstance(obj.plan, Plan):  # a SolveResult
        return obj.plan, getattr(obj, "problem", None), getattr(obj, "verification", None)
    raise TypeError(f"{what}: expected a Plan, a SolveResult or a path to a plan.json, found {type(obj).__name__}")


def view(plan, problem: Problem | str | Path | None = None, compare=None, *, height: int = 900,
         display_rate: float = DISPLAY_RATE) -> PlanView:
    """The interactive viewer of a plan, for a notebook cell (``coplan.view(result)``).

    ``plan`` and ``compare`` may be a :class:`Plan`, a :class:`~coplan.pipeline.SolveResult`
    or a path to a ``plan.json``; ``problem`` defaults to the result's own problem, else the
    problem file the plan records, else the shipped problem or row it names (:func:`problem_of`).
    """
    from ..problem.load import load_problem

    # (from a trial: height="big" failed only when shown, display_rate="30" and problem=3 from inside)
    if isinstance(height, bool) or not isinstance(height, int) or not 100 <= height <= 10_000:
        raise ValueError(f"height: expected a whole number of pixels from 100 to 10000, found {type(height).__name__} {height!r}")
    if isinstance(display_rate, bool) or not isinstance(display_rate, (int, float)) or not 1 <= display_rate <= 1000:
        raise ValueError(f"display_rate: expected frames per second from 1 to 1000, found {type(display_rate).__name__} "
                         f"{display_rate!r}")
    if isinstance(plan, Problem) and problem is not None and not isinstance(problem, Problem):  # (as verify says it)
        raise TypeError(f"view(plan, problem): the plan comes first, then its problem (optional); found a Problem, then "
                        f"a {type(problem).__name__} (swapped?)")
    if problem is not None and not isinstance(problem, (str, Path, Problem)):
        raise TypeError(f"problem: expected a Problem, a problem file's path or a shipped name, found "
                        f"{type(problem).__name__} {problem!r}")
    pl, prob, ver = _as_plan(plan, "plan")
    if isinstance(problem, (str, Path)):
        problem = load_problem(problem)
    prob = problem or prob or problem_of(pl)
    other, cver = (None, None) if compare is None else _as_plan(compare, "compare")[::2]
    page = render_html(prob, pl, other, verification=ver if problem is None else None,
                       compare_verification=cver, display_rate=display_rate)
    return PlanView(page, height)
