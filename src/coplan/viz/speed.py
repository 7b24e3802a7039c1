"""The speed curve of a row planned on the move: fruit per hour and the share of the harvestable
fruit harvested against the carriage's mean speed, one point per full plan the speed search
tried (each verified), the plan kept marked (``coplan plot PLAN --kind speed``).

Entry point: :func:`plot_speed_curve` (a plan) -> a matplotlib ``Figure``; :func:`speed_curve`
the points it draws (from ``plan.solver["row"]["speed_curve"]``).
"""

from __future__ import annotations

import math

from ..kinds import GantryMode
from ..plan import Plan

__all__ = ["speed_curve", "plot_speed_curve"]

_PROFILE_COLOURS = {"density": "C0", "constant": "C1"}


def speed_curve(plan: Plan) -> list[dict]:
    """The speed search's points of ``plan`` (a row planned on the move), each with ``mean_speed``
    (m/s), ``fruit_per_hour``, ``share_harvested``, ``verified`` and ``profile``, slowest first.
    ValueError for a plan with none: a cell, a row planned stop and go, or a file without it."""
    if not isinstance(plan, Plan):
        raise TypeError(f"speed_curve: expected a Plan (coplan.load_plan), found {type(plan).__name__}")
    row = (plan.solver or {}).get("row") or {}
    if not isinstance(row, dict):
        raise ValueError(f"speed curve: solver.row: expected an object (how the row was planned), found {type(row).__name__}")
    if plan.gantry_x is None:
        raise ValueError(f"speed curve: expected a row planned on the move, found a stationary cell's plan ({plan.problem!r})")
    if str(row.get("mode") or "").endswith("-live"):  # ("found a plan made continuous live")
        given = ("its carriage's speed was given" + (f" ({row['speed']:g} m/s)" if isinstance(row.get("speed"), (int, float))
                                                       and not isinstance(row.get("speed"), bool) else "") + ", not searched"
                 if str(row["mode"]).startswith(GantryMode.CONTINUOUS.value) else "it stopped for its picks: no speed search")
        raise ValueError("speed curve: expected a row planned on the move by coplan solve, found the executed plan of a "
                         f"live run (coplan run): {given}")
    if row.get("mode") != GantryMode.CONTINUOUS.value:
        raise ValueError(f"speed curve: expected a row planned on the move (coplan solve ROW --gantry continuous), found a "
                         f"plan made {str(row.get('mode') or 'stop-and-go').replace('-', ' ')}: its carriage has no speed search")
    points = row.get("speed_curve") or []
    if not isinstance(points, list):
        raise ValueError(f"speed curve: solver.row.speed_curve: expected an array of points, found {type(points).__name__}")
    if not points:
        raise ValueError("speed curve: the plan records no speed search (solver.row.speed_curve is empty)")
    if not any((p.get("harvestable") or 0) > 0 for p in points if isinstance(p, dict)):
        # (a row with no harvestable fruit drew a flat chart at 0 fruit/h with "exit 0")
        raise ValueError("speed curve: the row has no harvestable fruit, so no speed harvests more than another "
                         "(every plan the search tried harvested 0 of 0)")
    out = []
    for i, p in enumerate(points):
        if not isinstance(p, dict):
            raise ValueError(f"speed curve: solver.row.speed_curve[{i}]: expected an object, found {p!r}")
        for key in ("mean_speed", "fruit_per_hour"):  # (the two a point is drawn at; a bare TypeError before)
            v = p.get(key)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
                raise ValueError(f"speed curve: solver.row.speed_curve[{i}].{key}: expected a finite number, found {v!r}")
        got, of = p.get("harvested") or 0, p.get("harvestable") or 0
        out.append({"mean_speed": float(p["mean_speed"]), "fruit_per_hour": float(p["fruit_per_hour"]),
                    "share_harvested": got / of if of else 0.0,
                    "verified": bool(p.get("verified")), "profile": p.get("profile") or row.get("profile") or "density"})
    return sorted(out, key=lambda p: p["mean_speed"])


def plot_speed_curve(plan: Plan, *, title: str | None = None):
    """Fruit per hour (top) and the share harvested (bottom) against the mean speed, a point per
    plan the search tried -- hollow where some harvestable fruit were missed, a cross where the
    verifier refused it -- coloured by profile (``--profile auto`` searches both); the star is
    the plan kept (its own mean speed and fruit per hour)."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    pts = speed_curve(plan)
    row = plan.solver["row"]
    fig = Figure(figsize=(8.5, 5.0), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
    for p in pts:
        c = _PROFILE_COLOURS.get(p["profile"], "C2")
        whole = p["share_harvested"] >= 1.0 - 1e-9
        marker = "o" if p["verified"] else "x"
        face = c if whole else "none"
        top.plot(p["mean_speed"], p["fruit_per_hour"], marker, color=c, mfc=face, ms=7)
        bottom.plot(p["mean_speed"], 100.0 * p["share_harvested"], marker, color=c, mfc=face, ms=7)
    m = plan.metrics or {}
    span, got = float(m.get("makespan") or 0.0), int(m.get("harvested") or 0)
    if span > 0 and row.get("mean_speed") is not None:
        top.plot(float(row["mean_speed"]), got * 3600.0 / span, "*", color="C3", ms=16, zorder=5)
    profiles = sorted({p["profile"] for p in pts})
    handles = [Line2D([], [], marker="o", ls="", color=_PROFILE_COLOURS.get(pr, "C2"), label=f"{pr} profile") for pr in profiles]
    handles += [Line2D([], [], marker="o", ls="", color="0.4", mfc="none", label="fruit missed"),
                Line2D([], [], marker="*", ls="", color="C3", ms=12, label=f"kept ({row.get('profile')})")]
    # beside the axes, never over a point ("best" could cover the kept plan's star)
    top.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)
    top.set_ylabel("fruit / h")
    bottom.set_ylabel("harvested (%)")
    bottom.set_xlabel("carriage's mean speed while it moves (m/s)")
    top.set_title(title or f"{plan.problem}: the speed search on the move ({len(pts)} full plans, each checked by the verifier)", fontsize=10)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    return fig
