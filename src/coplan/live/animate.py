"""The live run as a GIF (``coplan run --animate``): :mod:`coplan.viz.animate`'s scene (arms,
true fruit, bins, clearance alarms) with the camera's view on top.

Drawn on top: each detection from the moment it arrives, as a ring with its 3-sigma uncertainty
circle (to scale: small at this zoom) in the colour of what became of it (picked: green, dropped
at close range: grey, unreachable: orange); the tip paths the latest re-plan planned for the next
4 s (dotted, per arm colour); true fruit that were never harvested, as black crosses.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..kinds import TrackState
from ..problem.model import Problem
from ..output import named_as, usual_mode

__all__ = ["animate_live"]

_STATE_COLOR = {TrackState.DROPPED: "#888888", TrackState.UNREACHABLE: "#d08000"}


def animate_live(problem: Problem, result, out_path: str | Path, *, speed: float = 2.0, fps: float = 10.0,
                 dpi: float = 70) -> Path:
    """Render ``result`` (a :class:`coplan.live.sim.LiveRun`) to a GIF at ``out_path``."""
    from matplotlib.animation import PillowWriter
    from matplotlib.patches import Circle

    from ..viz.animate import build_animation
    from ..viz.style import arm_colors

    plan = result.plan
    anim = build_animation(problem, plan, speed=speed, fps=fps, dpi=dpi,
                           title=f"{problem.name}: live run ({plan.status.value}, {len(result.cell.replans)} re-plans)")
    scene = anim.scene
    ax = scene.ax
    colors = arm_colors(problem)
    track_of = {d["id"]: d["track"] for d in result.run["detections"]}
    tracks = result.cell.tracks
    rings = []
    for d in result.run["detections"]:
        tr = tracks.get(track_of.get(d["id"]))
        c = _STATE_COLOR.get(tr.state, "#1a8f1a") if tr is not None else "#888888"
        t_seen = next((x["t"] for x in result.run["events"] if x["event"] == "detections" and d["id"] in x["detections"]), None)
        circle = Circle(d["position"], 3.0 * d["sigma"], fill=False, color=c, linewidth=0.8, zorder=8, visible=False)
        ax.add_patch(circle)
        (ring,) = ax.plot(*d["position"], "o", markerfacecolor="none", markeredgecolor=c, markersize=9, zorder=8, visible=False)
        rings.append((t_seen, circle, ring))
    lines = {n: ax.plot([], [], ":", color=colors[n], linewidth=1.2, zorder=4)[0] for n in result.cell.steps}
    missed = [problem.fruit(f).position for f, o in result.run["fruit"].items() if o["reachable"] and not o["harvested"]]
    if missed:
        ax.plot(*np.asarray(missed).T, "x", color="black", markersize=9, markeredgewidth=2, zorder=9)
    snaps = result.paths

    draw_scene = scene.update

    def update(t):  # the scene's frame, then the camera's view on top (the animation calls scene.update)
        out = draw_scene(t)
        for t_seen, circle, ring in rings:
            on = t_seen is not None and t_seen <= t
            circle.set_visible(on)
            ring.set_visible(on)
        i = int(np.searchsorted([s[0] for s in snaps], t, side="right")) - 1
        for n, ln in lines.items():
            if i >= 0:
                ln.set_data(*snaps[i][1][n].T)
        return out

    scene.update = update
    out = Path(out_path)
    with named_as(out):
        fd, name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=".partial.gif", dir=out.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        anim.save(str(tmp), writer=PillowWriter(fps=fps), dpi=dpi)
        os.chmod(tmp, usual_mode())
        tmp.replace(out)
    finally:
        tmp.unlink(missing_ok=True)
    return out
