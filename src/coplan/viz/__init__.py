"""Pictures of problems and plans: analysis plots and animations (matplotlib, headless).

Import the submodules directly (``from coplan.viz.plots import plot_gantt``); ``import
coplan`` does not import this package, and this package imports matplotlib only inside the
functions that draw.

* :mod:`coplan.viz.plots` -- Gantt, clearance, joint and workspace figures; comparison files.
* :mod:`coplan.viz.animate` -- the plan animation (GIF, or MP4 with ffmpeg).
* :mod:`coplan.viz.speed` -- a row on the move: fruit per hour and share harvested against speed.
* :mod:`coplan.viz.timeline` -- the data behind them (phases, clearance, derivatives).
* :mod:`coplan.viz.style` -- the shared per-arm palette.
"""

from __future__ import annotations

from .style import arm_colors

__all__ = [
    "arm_colors",
    "plot_gantt",
    "plot_clearance",
    "plot_joints",
    "plot_workspace",
    "save_comparison_figures",
    "animate_plan",
    "build_animation",
]


def __getattr__(name):  # lazy re-exports: keep `import coplan.viz` cheap
    if name in ("plot_gantt", "plot_clearance", "plot_joints", "plot_workspace", "save_comparison_figures"):
        from . import plots

        return getattr(plots, name)
    if name in ("animate_plan", "build_animation"):
        from . import animate

        return getattr(animate, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
