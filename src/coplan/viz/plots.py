"""Analysis plots of plans and problems. Every function returns a ``matplotlib.figure.Figure``.

Nothing here uses pyplot or shows a window: figures are built with
``matplotlib.figure.Figure`` (headless, Agg when saved) and matplotlib is imported inside the
functions, so ``import coplan`` never pulls it in. Display a figure in a notebook with
``IPython.display.display(fig)``; save it with ``fig.savefig(path)``.

* :func:`plot_gantt` -- schedule per arm (moving, picking, placing, idle, fruit ids); several
  plans one above the other on one time axis.
* :func:`plot_clearance` -- clearance of every neighbouring pair over time vs the requirement.
* :func:`plot_joints` -- joint position, velocity, acceleration, jerk vs their limits.
* :func:`plot_workspace` -- the course's manipulability map, for one arm or the whole cell,
  with overlap zones and fruit marked by who can reach them.
* :func:`save_comparison_figures` -- the figures ``coplan compare`` writes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..output import folder_path
from ..plan import EventKind, Plan, fit_issue
from ..problem.model import Arm, Problem
from .style import ALERT_COLOR, FRUIT_COLOR, LIMIT_COLOR, arm_colors, pair_label
from .timeline import ArmPhase, joint_derivatives, limit_tolerance, pair_clearance, schedule

__all__ = [
    "plot_gantt",
    "plot_clearance_cost",
    "plot_clearance",
    "plot_joints",
    "plot_workspace",
    "workspace_maps",
    "save_comparison_figures",
    "plan_title",
]

_IDLE = "#dddddd"


def _figure(figsize, **kw):
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained", **kw)


def _check_problem(problem, what: str) -> None:
    if not isinstance(problem, Problem):
        raise TypeError(f"{what}: expected a Problem (coplan.problem.load_problem) as the first argument, "
                        f"found {type(problem).__name__}")


def _as_plans(problem: Problem, plans, what: str) -> dict[str, Plan]:
    """``{label: plan}`` of one plan or a mapping, each checked to be a plan of ``problem``'s
    arms (one of another problem raised a KeyError from inside the drawing)."""
    _check_problem(problem, what)
    if not isinstance(plans, (Plan, Mapping)) and isinstance(getattr(plans, "plan", None), Plan):  # a SolveResult
        plans = plans.plan
    if isinstance(plans, Plan):
        plans = {plans.planner_name: plans}
    elif isinstance(plans, Mapping):
        if not plans:
            raise ValueError(f"{what}: expected at least one plan, found none")
        plans = dict(plans)
    else:
        raise TypeError(f"{what}: expected a Plan, a SolveResult or a mapping label -> Plan, found {type(plans).__name__}")
    for label, plan in plans.items():
        if not isinstance(plan, Plan):
            raise TypeError(f"{what}: expected a Plan for {label!r}, found {type(plan).__name__}")
        bad = fit_issue(problem, plan)
        if bad:
            raise ValueError(f"{what}: plan {label!r} does not fit problem {problem.name!r}: {bad}")
    return plans


def _positive(what: str, name: str, v, optional: bool = False) -> None:
    if optional and v is None:
        return
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise ValueError(f"{what}: {name}: expected a positive number{' or None' if optional else ''}, found "
                         f"{type(v).__name__} {v!r}")


def plan_title(label: str, plan: Plan) -> str:
    """``"heuristic: makespan 21.66 s, 11/11 fruit, unsafe"`` from a plan's metrics; a row's:
    ``"coordinated (on the move): row time 78.51 s, 2751 fruit/h, 60/60 fruit, success"``."""
    m = plan.metrics or {}
    row = m.get("row") if plan.gantry_x is not None else None
    bits = []
    if m.get("makespan") is not None:
        bits.append(f"{'row time' if row else 'makespan'} {m['makespan']:.2f} s")
    if row and row.get("fruit_per_hour") is not None:
        bits.append(f"{row['fruit_per_hour']:.0f} fruit/h")
    if m.get("harvested") is not None and m.get("reachable") is not None:
        bits.append(f"{m['harvested']}/{m['reachable']} fruit")
    bits.append(plan.status.value)
    return f"{label}: " + ", ".join(bits)


def _makespan(plan: Plan) -> float:
    places = [e.t_end for e in plan.events if e.kind == EventKind.PLACE]
    return max(places) if places else plan.duration


# --------------------------------------------------------------------------- Gantt
_GANTT_AXES_IN = 9.6  # inches: the Gantt's time axis (an 11 in wide figure less its margins)
_LABEL_CHAR_IN = 0.058  # inches: one character of a 7 pt fruit id


def plot_gantt(problem: Problem, plans: Plan | Mapping[str, Plan], *, title: str | None = None):
    """Schedule Gantt chart: one row per arm, bars for moving / picking / placing / idle.

    ``plans`` is one plan or ``{label: plan}``; several plans are drawn one above the other
    (in the mapping's order, e.g. heuristic above optimal) on a shared time axis. Pick bars
    carry the fruit id; the makespan is marked on each chart.
    """
    from matplotlib.patches import Patch

    plans = _as_plans(problem, plans, "plot_gantt")
    colors = arm_colors(problem)
    names = [a.name for a in problem.arms]
    n_arms = len(names)
    fig = _figure((11, 0.6 + len(plans) * (0.55 * n_arms + 0.9)))
    axes = fig.subplots(len(plans), 1, sharex=True, squeeze=False)[:, 0]
    t_max = max(p.duration for p in plans.values())
    h = 0.56
    # a fruit id above its pick bar only where it does not run into the previous one (a row's
    # hundreds of picks would print one unreadable string): the id's width in seconds on this axis
    per_char = _LABEL_CHAR_IN * 1.02 * t_max / _GANTT_AXES_IN
    for ax, (label, plan) in zip(axes, plans.items()):
        segs = schedule(plan)
        for row, arm in enumerate(names):
            c = colors[arm]
            free_from = -math.inf  # (seconds: where the last id drawn on this row ends)
            for s in segs.get(arm, []):
                if s.duration <= 0:
                    continue
                if s.phase == ArmPhase.IDLE:
                    ax.barh(row, s.duration, left=s.t0, height=h * 0.45, color=_IDLE, linewidth=0)
                elif s.phase == ArmPhase.MOVING:
                    ax.barh(row, s.duration, left=s.t0, height=h, color=c, alpha=0.35, linewidth=0)
                elif s.phase == ArmPhase.PICKING:
                    ax.barh(row, s.duration, left=s.t0, height=h, color=c, edgecolor="black", linewidth=0.6)
                    mid, half = s.t0 + s.duration / 2, 0.5 * per_char * (len(s.fruit or "") + 1)
                    if mid - half >= free_from:
                        ax.text(mid, row - h / 2 - 0.04, s.fruit or "", ha="center", va="bottom",
                                fontsize=7, color="black", clip_on=True)
                        free_from = mid + half
                elif s.phase == ArmPhase.PLACING:
                    ax.barh(row, s.duration, left=s.t0, height=h, facecolor=c, edgecolor="black", hatch="////", linewidth=0.6)
        ms = _makespan(plan)
        ax.axvline(ms, color=LIMIT_COLOR, linestyle="--", linewidth=1)
        ax.text(ms, -0.6, f"makespan {ms:.2f} s ", fontsize=8, va="center", ha="right", color=LIMIT_COLOR)  # (clear of the frame)
        ax.set_yticks(range(n_arms), names)
        for tick, arm in zip(ax.get_yticklabels(), names):
            tick.set_color(colors[arm])
            tick.set_fontweight("bold")
        ax.set_ylim(n_arms - 0.5, -0.85)
        ax.set_title(plan_title(label, plan), fontsize=10, loc="left")
        ax.grid(axis="x", alpha=0.3)
        ax.set_axisbelow(True)
    axes[-1].set_xlabel("time (s)")
    axes[-1].set_xlim(0, t_max * 1.02 + 0.1)
    swatch = colors[names[0]]  # the bars' own colours (each arm's), not a grey that reads as idle
    handles = [
        Patch(facecolor=swatch, alpha=0.35, linewidth=0, label="moving (the arm's colour, light)"),
        Patch(facecolor=swatch, edgecolor="black", linewidth=0.6, label="picking (fruit id above, where there is room)"),
        Patch(facecolor=swatch, edgecolor="black", hatch="////", linewidth=0.6, label="placing in bin"),
        Patch(facecolor=_IDLE, label="idle (thin grey)"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(title or f"{problem.name}: schedule per arm (bar colour = arm)", fontsize=11)
    return fig


# --------------------------------------------------------------------------- clearance
_PAIR_STYLES = (
    ("#222222", "-"),
    ("#b8860b", "--"),
    ("#6a3d9a", "-."),
    ("#1b7837", ":"),
    ("#666666", "--"),
    ("#a6761d", "-"),
)


def plot_clearance(problem: Problem, plans: Plan | Mapping[str, Plan], *, title: str | None = None, y_max: float | None = None):
    """Clearance over time of every neighbouring pair, one chart per plan (shared axes).

    Clearance is the gap between the two arms' link capsules (m); below zero they overlap.
    The required clearance is the red dashed line, time spent below it is filled red and
    each pair's least clearance is marked and printed. The y axis stops at ``y_max``
    (default: the larger of 0.8 m and 6x the requirement, or the data's top when lower),
    because it is the low values that matter.
    """
    from matplotlib.lines import Line2D

    _positive("plot_clearance", "y_max", y_max, optional=True)  # ("1": a TypeError from inside; -1 was taken)
    plans = _as_plans(problem, plans, "plot_clearance")
    req = problem.task.clearance
    fig = _figure((11, 0.9 + 2.5 * len(plans)))
    axes = fig.subplots(len(plans), 1, sharex=True, sharey=True, squeeze=False)[:, 0]
    lows, highs = [0.0], [req * 2]
    handles: dict[str, object] = {}
    pair_index: dict[tuple[str, str], int] = {}
    for ax, (label, plan) in zip(axes, plans.items()):
        t, prof = pair_clearance(problem, plan)
        ax.axhline(req, color=ALERT_COLOR, linestyle="--", linewidth=1.2)
        ax.axhline(0.0, color="black", linewidth=0.8)
        ax.axhspan(-10, req, color=ALERT_COLOR, alpha=0.06, linewidth=0)
        if not prof:
            ax.text(0.5, 0.5, "one arm: no pair to keep apart" if len(problem.arms) == 1 else
                    "no neighbouring pairs: the arms can never meet", transform=ax.transAxes, ha="center")
        worst = []
        for (a, b), d in prof.items():
            k_style = pair_index.setdefault((a, b), len(pair_index))
            color, ls = _PAIR_STYLES[k_style % len(_PAIR_STYLES)]
            (line,) = ax.plot(t, d, color=color, linestyle=ls, linewidth=1.4)
            handles.setdefault(pair_label(a, b), line)
            low = d < req
            if low.any():
                ax.fill_between(t, d, req, where=low, color=ALERT_COLOR, alpha=0.45, linewidth=0, interpolate=True)
            k = int(np.argmin(d))
            said = ((plan.verification or {}).get("pairs") or {}).get(f"{a}-{b}") or {}
            if said.get("t") is not None and t.size:  # among near-ties, the verifier's instant (it named another)
                k2 = int(np.argmin(np.abs(t - said["t"])))
                k = k2 if d[k2] - d[k] <= 5e-4 else k
            ax.plot(t[k], d[k], "v", color=color, markersize=6, markeredgecolor="white")
            worst.append(f"{pair_label(a, b)} {d[k]:.3f} m at {t[k]:.2f} s")
            lows.append(float(d.min()))
            highs.append(float(d.max()))
        ax.set_title(plan_title(label, plan), fontsize=10, loc="left")
        if worst:
            bad = any(float(d.min()) < req for d in prof.values())
            ax.text(
                0.995, 0.97, "least: " + "; ".join(worst), transform=ax.transAxes, ha="right", va="top", fontsize=8,
                color=ALERT_COLOR if bad else "black", bbox=dict(facecolor="white", alpha=0.85, edgecolor="none", pad=1.5),
            )
        ax.set_ylabel("clearance (m)")
        ax.grid(alpha=0.3)
    lo = min(lows)
    hi = y_max if y_max is not None else min(max(highs) * 1.05, max(0.8, 6 * req))
    axes[0].set_ylim(min(-0.05, lo - 0.05 * (hi - lo)), hi)
    if max(highs) > hi:
        axes[0].text(0.002, 0.985, f"axis cut at {hi:.2f} m", transform=axes[0].transAxes, fontsize=7, va="top", color="#555555")
    axes[-1].set_xlabel("time (s)")
    axes[-1].set_xlim(0, max([p.duration for p in plans.values()] + [1e-3]))  # (a plan of one sample lasts 0 s: no singular axis)
    extra = [
        Line2D([], [], color=ALERT_COLOR, linestyle="--", label=f"required clearance {req:g} m"),
        Line2D([], [], color="black", linewidth=0.8, label="contact (capsules touch)"),
        Line2D([], [], color="#222222", marker="v", linestyle="none", markersize=6, label="least clearance of a pair"),
    ][:None if handles else 2]  # (no pair drawn: no pair's least clearance in the legend)
    fig.legend(
        handles=list(handles.values()) + extra, labels=list(handles) + [h.get_label() for h in extra],
        loc="outside lower center", ncol=min(6, len(handles) + 3), fontsize=8, frameon=False,
    )
    fig.suptitle(title or f"{problem.name}: clearance between neighbouring arms", fontsize=11)
    return fig


# --------------------------------------------------------------------------- joints
_QUANTS = (
    ("position", "rad"),
    ("velocity", "rad/s"),
    ("acceleration", "rad/s²"),
    ("jerk", "rad/s³"),
)


def _limits(arm, quantity: str, j: int) -> tuple[float, float]:
    if quantity == "position":
        lo, hi = arm.joint_limits[j]
        return float(lo), float(hi)
    v = {"velocity": arm.max_velocity, "acceleration": arm.max_acceleration, "jerk": arm.max_jerk}[quantity][j]
    return -float(v), float(v)


def plot_joints(problem: Problem, plan: Plan, *, arms: list[str] | None = None, label: str | None = None, clip: float = 3.0):
    """Joint position, velocity, acceleration and jerk over time against the limits.

    Rows: the four quantities (finite differences of the plan's samples, taken as the
    verifier takes them); columns: joint 1 (shoulder) and joint 2 (elbow); one line per arm
    in its colour. Limits are dashed (black when all arms share them). Each chart prints
    every arm's peak as a multiple of its limit, in red when over (beyond the verifier's
    tolerance). The y axis stops at ``clip`` times the limit so a spike does not flatten the
    rest of the chart. ``arms``: the arms to draw (names of the plan's arms; one as a str),
    default every arm.
    """
    from matplotlib.lines import Line2D

    _positive("plot_joints", "clip", clip)  # ("3": "can't multiply sequence by non-int"; -1 was taken)
    if isinstance(plan, Mapping):  # (one plan's chart: a mapping, which plot_gantt takes, failed deep inside)
        raise TypeError(f"plot_joints: plan: expected one Plan (a chart per plan: call it for each), found a mapping of "
                        f"{len(plan)} ({', '.join(map(str, list(plan)[:4]))})")
    _as_plans(problem, plan, "plot_joints")
    colors = arm_colors(problem)
    if arms is not None:  # (names were matched with ``in``: a typo was dropped in silence, a string matched by substring)
        asked = [arms] if isinstance(arms, str) else list(arms)
        unknown = [a for a in asked if a not in plan.q]
        if unknown:
            raise ValueError(f"plot_joints: arms: expected names of the plan's arms {list(plan.q)}, found {unknown}")
        arms = asked
    names = [a.name for a in problem.arms if a.name in plan.q and (arms is None or a.name in arms)]
    if not names:
        raise ValueError(f"no arm to plot: plan arms {list(plan.q)}, asked for {arms}")
    fig = _figure((11, 9.5))
    axes = fig.subplots(4, 2, sharex=True)
    data = {n: joint_derivatives(plan, n) for n in names}
    arm_objs = {n: problem.arm(n) for n in names}
    for r, (qname, unit) in enumerate(_QUANTS):
        for j in range(2):
            ax = axes[r, j]
            lims = {n: _limits(arm_objs[n], qname, j) for n in names}
            shared = len(set(lims.values())) == 1
            over = []
            ymax = 0.0
            for n in names:
                t, x = data[n][qname]
                if t.size == 0:
                    continue
                ax.plot(t, x[:, j], color=colors[n], linewidth=1.1)
                lo, hi = lims[n]
                peak = float(np.max(np.abs(x[:, j])))
                lim_abs = max(abs(lo), abs(hi))
                ymax = max(ymax, min(peak, clip * lim_abs))
                if qname == "position":
                    bad = (x[:, j] < lo - 1e-7) | (x[:, j] > hi + 1e-7)
                else:
                    order = ("velocity", "acceleration", "jerk").index(qname) + 1
                    bad = np.abs(x[:, j]) > hi + limit_tolerance(hi, order, plan.dt)
                over.append((n, peak / lim_abs, bool(bad.any())))
                if not shared:
                    ax.axhline(lo, color=colors[n], linestyle="--", linewidth=0.9)
                    ax.axhline(hi, color=colors[n], linestyle="--", linewidth=0.9)
            if shared:
                lo, hi = next(iter(lims.values()))
                ax.axhline(lo, color=LIMIT_COLOR, linestyle="--", linewidth=0.9)
                ax.axhline(hi, color=LIMIT_COLOR, linestyle="--", linewidth=0.9)
            lim_abs = max(max(abs(lo), abs(hi)) for lo, hi in lims.values())
            top = max(ymax, lim_abs) * 1.12
            ax.set_ylim(-top, top)
            if over and qname != "position":
                any_bad = any(b for _, _, b in over)
                head = "OVER LIMIT, peak / limit: " if any_bad else "peak / limit: "
                ax.text(
                    0.99, 0.97, head + ", ".join(f"{n} {r:.2f}×" for n, r, _ in over), transform=ax.transAxes, ha="right",
                    va="top", fontsize=7, color=ALERT_COLOR if any_bad else "#444444",
                    bbox=dict(facecolor="white", alpha=0.85, edgecolor="none", pad=1),
                )
            ax.grid(alpha=0.3)
            if r == 0:
                ax.set_title(("joint 1 (shoulder θ1)", "joint 2 (elbow θ2)")[j], fontsize=10)
            if j == 0:
                ax.set_ylabel(f"{qname}\n({unit})")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    handles = [Line2D([], [], color=colors[n], label=n) for n in names]
    handles.append(Line2D([], [], color=LIMIT_COLOR, linestyle="--", label="limit (±)"))
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=8, frameon=False)
    fig.suptitle(f"{problem.name}: joint motion vs limits ({plan_title(label or plan.planner_name, plan)})", fontsize=11)
    return fig


# --------------------------------------------------------------------------- workspace
def _workspace_grid(problem: Problem, arms, resolution: int):
    """A grid covering the arms' discs and every fruit, 0.2 m margin; ``resolution`` columns."""
    lows = [np.subtract(a.base, a.reach) for a in arms]
    highs = [np.add(a.base, a.reach) for a in arms]
    if problem.fruits:
        lows.append(problem.fruit_positions.min(axis=0))
        highs.append(problem.fruit_positions.max(axis=0))
    lo = np.min(lows, axis=0) - 0.2
    hi = np.max(highs, axis=0) + 0.2
    span = hi - lo
    nx = int(resolution)
    ny = max(20, int(round(resolution * span[1] / span[0])))
    xs = np.linspace(lo[0], hi[0], nx)
    ys = np.linspace(lo[1], hi[1], ny)
    X, Y = np.meshgrid(xs, ys)
    return xs, ys, np.stack([X, Y], axis=-1)


#: the finest workspace map (grid points per axis): 4 million points per arm
MAX_RESOLUTION = 2000


def workspace_maps(problem: Problem, arms=None, resolution: int = 300):
    """Grids for the workspace map: ``(xs, ys, manip (ny, nx) best |det J| over arms, NaN where
    unreachable, count (ny, nx) how many arms reach each point)``. Reach honours joint limits.
    ``arms``: the arms to map (:class:`Arm` objects or their names; default every arm)."""
    from ..kinematics import arm as kin

    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or not 2 <= resolution <= MAX_RESOLUTION:
        raise ValueError(f"workspace map: resolution: expected a whole number of grid points per axis from 2 to "
                         f"{MAX_RESOLUTION}, found {resolution!r}")
    # (names too, as plot_joints takes them: a name raised "'str' object has no attribute 'base'")
    asked = list(problem.arms) if arms is None else [arms] if isinstance(arms, (str, Arm)) else list(arms)
    known = {a.name: a for a in problem.arms}
    unknown = [a for a in asked if not isinstance(a, Arm) and a not in known]
    if unknown:
        raise ValueError(f"workspace_maps: arms: expected the problem's arms or their names {list(known)}, found {unknown}")
    arms = [a if isinstance(a, Arm) else known[a] for a in asked]
    xs, ys, P = _workspace_grid(problem, arms, resolution)
    best = np.full(P.shape[:2], np.nan)
    count = np.zeros(P.shape[:2], int)
    for a in arms:
        q, valid = a.ik(P)
        ok = valid.any(axis=-1)
        qq = np.where(valid[..., 0:1], q[..., 0, :], q[..., 1, :])
        m = np.where(ok, kin.manipulability(np.nan_to_num(qq), a.links), np.nan)
        best = np.fmax(best, m)
        count += ok
    return xs, ys, best, count


def plot_workspace(problem: Problem, arm: str | None = None, *, resolution: int = 300, show_fruit: bool = True):
    """The course's workspace map, improved.

    Heat map of the manipulability |det J| over the reachable annulus (joint limits
    honoured), the inner and outer boundaries and the 90% safety ring. With ``arm=None`` the
    whole cell: every arm's boundaries in its colour, zones reachable by two or more arms
    hatched, bins, and each fruit drawn as a disc split among the arms that can harvest it
    (a cross when none can). Arms the screen locks (they can never reach their bin) are drawn
    dashed and labelled, and the fruit only they could pick shown as screened out: what makes a
    plan partial. With ``arm="name"``: that arm alone.
    """
    _check_problem(problem, "plot_workspace")
    if arm is not None and not isinstance(arm, str):  # (a plan given here printed the whole plan in a KeyError)
        raise TypeError(f"plot_workspace: arm: expected an arm's name (str) or None, found {type(arm).__name__}; "
                        f"arms are {[a.name for a in problem.arms]}")
    if problem.gantry is not None:
        raise ValueError(f"plot_workspace: expected a stationary cell, found the row {problem.name!r} (its arms ride on the carriage)")
    from matplotlib.colors import LinearSegmentedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle, Wedge

    if arm is not None and arm not in [a.name for a in problem.arms]:  # (as a ValueError, like every other bad value here)
        raise ValueError(f"plot_workspace: arm: expected one of the problem's arms {[a.name for a in problem.arms]}, found {arm!r}")
    colors = arm_colors(problem)
    arms = list(problem.arms) if arm is None else [problem.arm(arm)]
    xs, ys, manip, count = workspace_maps(problem, arms, resolution)
    span = (xs[-1] - xs[0], ys[-1] - ys[0])
    w = 11.0 if arm is None else 8.0
    fig = _figure((w, (w - 2.3) * span[1] / span[0] + 1.9))
    ax = fig.add_subplot()
    ax.set_facecolor("white")
    # light grey (near singular) -> dark grey (dexterous); white = unreachable
    cmap = LinearSegmentedColormap.from_list("coplan_manip", ["#e4e4e4", "#5a5a5a"])
    vmax = float(np.nanmax(manip)) if np.isfinite(manip).any() else 1.0
    im = ax.imshow(manip, extent=(xs[0], xs[-1], ys[0], ys[-1]), origin="lower", cmap=cmap, vmin=0, vmax=vmax, interpolation="nearest")
    fig.colorbar(im, ax=ax, label="manipulability |det J| (m²)\n(white: unreachable)", shrink=0.9, pad=0.01, fraction=0.04)
    if len(arms) > 1 and (count >= 2).any():
        cs = ax.contourf(xs, ys, count, levels=[1.5, 99], colors="none", hatches=["//"])
        cs.set_edgecolor("#202020")
        cs.set_linewidth(0)
        ax.contour(xs, ys, count, levels=[1.5], colors="black", linewidths=0.6)
    thr = problem.task.singularity_threshold
    if np.isfinite(manip).any() and np.nanmin(manip) < thr:
        ax.contour(xs, ys, np.nan_to_num(manip, nan=np.inf), levels=[thr], colors=[ALERT_COLOR], linewidths=0.7, linestyles="-")
    th = np.linspace(0, 2 * np.pi, 361)
    from ..allocate.screen import screened

    scr = screened(problem)
    for a in arms:
        c = colors[a.name]
        bx, by = a.base
        locked = not scr.arm_ok[a.name]
        ax.plot(bx + a.reach * np.cos(th), by + a.reach * np.sin(th), color=c, linewidth=1.8,
                linestyle=(0, (6, 3)) if locked else "-")
        if a.inner_radius > 0.01:
            ax.plot(bx + a.inner_radius * np.cos(th), by + a.inner_radius * np.sin(th), color=c, linewidth=1.3, linestyle="--")
        ax.plot(bx + 0.9 * a.reach * np.cos(th), by + 0.9 * a.reach * np.sin(th), color=c, linewidth=1.2, linestyle=":")
        ax.plot(bx, by, "^", color=c, markeredgecolor="black", markersize=11, zorder=5)
        ax.add_patch(Rectangle((a.bin[0] - 0.12, a.bin[1] - 0.1), 0.24, 0.2, facecolor=c, alpha=0.6, edgecolor="black", linewidth=0.8, zorder=4))
        ax.annotate(
            a.name + (" (locked)" if locked else ""), (a.bin[0], a.bin[1] - 0.1), xytext=(0, -3),
            textcoords="offset points", ha="center", va="top",
            color=c, fontweight="bold", fontsize=9, zorder=6, bbox=dict(facecolor="white", alpha=0.8, edgecolor="none", pad=1),
        )
    n_shared = n_none = n_left = 0
    if show_fruit and problem.fruits:
        reach = problem.reach_matrix()
        idx = [problem.arms.index(a) for a in arms]
        rdisc = 0.075 * max(1.0, span[0] / 8)
        for k, f in enumerate(problem.fruits):
            who = [problem.arms[i].name for i in idx if scr.reach[i, k]]
            x, y = f.position
            if not who and any(reach[i, k] for i in idx):  # only locked arms (or blocked poses) reach it
                n_left += 1
                ax.add_patch(Wedge((x, y), rdisc, 0, 360, facecolor="white", edgecolor=ALERT_COLOR, linewidth=1.6, zorder=6))
            elif not who:
                n_none += 1
                ax.plot(x, y, "x", color=FRUIT_COLOR, markersize=8, markeredgewidth=2, zorder=6)
            else:
                n_shared += len(who) > 1
                step = 360.0 / len(who)
                for m, name in enumerate(who):
                    ax.add_patch(Wedge((x, y), rdisc, 90 + m * step, 90 + (m + 1) * step, facecolor=colors[name], edgecolor="black", linewidth=0.7, zorder=6))
            ax.annotate(f.id, (x, y), xytext=(5, 5), textcoords="offset points", fontsize=7, zorder=7)
    handles = [Patch(facecolor=colors[a.name], label=a.name) for a in arms]
    handles += [
        Line2D([], [], color="black", linewidth=1.6, label="outer boundary (l1 + l2)"),
        Line2D([], [], color="black", linewidth=1.2, linestyle="--", label="inner boundary |l1 − l2|"),
        Line2D([], [], color="black", linewidth=1.0, linestyle=":", label="90% safety ring"),
        Line2D([], [], color=ALERT_COLOR, linewidth=0.7, label=f"|det J| = {thr:g} (singularity threshold)"),
        Line2D([], [], marker="^", color="none", markerfacecolor="#999999", markeredgecolor="black", markersize=9, label="base"),
        Patch(facecolor="#999999", edgecolor="black", label="bin"),
    ]
    if len(arms) > 1:
        handles.append(Patch(facecolor="white", edgecolor="black", hatch="//", label="overlap (≥ 2 arms reach)"))
    if show_fruit and problem.fruits:
        handles.append(Line2D([], [], marker="o", color="none", markerfacecolor="#999999", markeredgecolor="black", label="fruit (split by arms that reach it)"))
        if n_left:
            handles.append(Line2D([], [], marker="o", color="none", markerfacecolor="white", markeredgecolor=ALERT_COLOR,
                                  markeredgewidth=1.6, label="fruit screened out (only locked arms or blocked poses reach it)"))
        if any(not scr.arm_ok[a.name] for a in arms):
            handles.append(Line2D([], [], color="black", linewidth=1.6, linestyle=(0, (6, 3)), label="locked arm (never reaches its bin): its reach"))
        if n_none:
            handles.append(
                Line2D([], [], marker="x", color=FRUIT_COLOR, linestyle="none", markeredgewidth=2,
                       label="fruit no arm can reach" if arm is None else f"fruit {arm} cannot reach")
            )
    fig.legend(handles=handles, loc="outside lower center", ncol=4 if arm is None else 3, fontsize=8, frameon=False)
    ax.set_xlim(xs[0], xs[-1])
    ax.set_ylim(ys[0], ys[-1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    who = "the whole cell" if arm is None else f"arm {arm}"
    extra = ""
    if show_fruit and problem.fruits:
        n = len(problem.fruits)
        extra = f"; {n_shared} fruit shared, {n_none} unreachable" if arm is None else f"; reaches {n - n_none} of {n} fruit"
    ax.set_title(f"{problem.name}: workspace of {who}{extra}", fontsize=11)
    return fig


# --------------------------------------------------------------------------- files
def plot_clearance_cost(rows: list[dict], *, title: str | None = None):
    """Makespan (s) against the clearance asked for (m), from :func:`coplan.report.clearance.clearance_cost`'s
    rows; an unverified plan is drawn hollow, a clearance the geometry cannot give is marked on the axis."""
    fig = _figure((6.4, 3.6))
    ax = fig.add_subplot()
    ok = [r for r in rows if r.get("makespan")]
    x = [r["clearance"] for r in ok]
    y = [r["makespan"] for r in ok]
    # (a thin dotted line: the makespan is measured at the levels only -- a solid one read as a trend
    # where the change is a step, an arm locked out past some clearance)
    ax.plot(x, y, ":", color="#1f77b4", lw=1.0)
    for r in ok:
        ax.plot(r["clearance"], r["makespan"], "o", color="#1f77b4", mfc="#1f77b4" if r.get("verified") else "white", ms=7)
        fewer = r.get("harvested") is not None and r.get("reachable") and r["harvested"] < r["reachable"]
        label = f"+{r['extra_mm']:g} mm" + (f"\n{r['harvested']}/{r['reachable']} fruit" if fewer else "")
        last = r["clearance"] >= max(x)  # (its label to the left, inside the axes)
        ax.annotate(label, (r["clearance"], r["makespan"]), textcoords="offset points", xytext=(-4 if last else 4, 6),
                    ha="right" if last else "left", fontsize=8)
    ax.margins(x=0.12, y=0.25)  # (room for each point's label inside the axes: the top one ran into the title)
    for r in rows:
        if r.get("error"):  # (after the margins: its label at the axis's bottom as drawn)
            ax.axvline(r["clearance"], color="#d62728", ls=":", lw=1)
            ax.annotate("impossible", (r["clearance"], ax.get_ylim()[0]), rotation=90, fontsize=8, color="#d62728",
                        xytext=(3, 4), textcoords="offset points")
    ax.set_xlabel("clearance asked for (m)")
    ax.set_ylabel("makespan (s)")
    ax.grid(alpha=0.3)
    ax.set_title(title or "makespan against the clearance asked for", fontsize=10)
    return fig


def save_comparison_figures(problem: Problem, plans: Mapping[str, Plan], out_dir: Path, *, dpi: int = 110) -> list[Path]:
    """Write the comparison figures of several plans of one problem as PNGs; return the paths.

    ``plans`` maps labels to plans in display order (e.g. ``{"heuristic": h, "optimal": o}``:
    heuristic drawn above optimal). Files: ``schedule_gantt.png``, ``clearance.png`` and one
    ``joints_<label>.png`` per plan.
    """
    plans = _as_plans(problem, plans, "save_comparison_figures")
    out = Path(out_dir)
    folder_path(out, "save_comparison_figures: out_dir")  # (a file in the way: said, not FileExistsError)
    out.mkdir(parents=True, exist_ok=True)
    figs = [("schedule_gantt.png", plot_gantt(problem, plans)), ("clearance.png", plot_clearance(problem, plans))]
    for label, plan in plans.items():
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in label)
        figs.append((f"joints_{safe}.png", plot_joints(problem, plan, label=label)))
    paths = []
    for name, fig in figs:
        p = out / name
        fig.savefig(p, dpi=dpi)
        paths.append(p)
    return paths
