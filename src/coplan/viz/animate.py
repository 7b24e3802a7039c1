"""The plan animation: every arm, its fruit and its bin, played back headless.

* :func:`animate_plan` -- render a plan to a GIF (Pillow, the default) or an MP4 (ffmpeg:
  the system's, else the ``imageio-ffmpeg`` wheel's; without either a clear message and a GIF). Used by ``coplan animate`` and
  ``coplan solve --animate``.
* :func:`build_animation` -- the ``matplotlib.animation.FuncAnimation`` itself (e.g. for
  ``anim.to_jshtml()`` in a notebook).
* :func:`render_frame` -- one still ``Figure`` at a given time (README images, checks).

What a frame shows: each arm's links as capsules (line width = link diameter) and joints in
the arm's colour, its end-effector trail, workspace annulus and bin; fruit ripe (red) on the
plant until picked, then carried at the tip and finally shown in the bin; the time, each
arm's phase (moving, picking, placing, idle) and harvested count. A pair of arms closer than
the required clearance at any sample since the previous frame turns red, with a status line.
Playback is real time times ``speed``; frames are subsampled to ``fps``.
"""

from __future__ import annotations

import errno
import math
import os
import shutil
import subprocess
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import CoplanError
from ..kinds import ExitCode
from ..plan import EventKind, Plan
from ..problem.model import Problem
from .style import ALERT_COLOR, FRUIT_COLOR, arm_colors, pair_label
from .timeline import ArmPhase, arm_points, fruit_states, harvested_count, pair_clearance, phase_at, schedule
from ..progress import Tick, ticker
from ..output import named_as, usual_mode

__all__ = ["RenderError", "OverwriteRefused", "RenderWarning", "animate_plan", "build_animation", "render_frame", "frame_times", "ffmpeg_available"]


class RenderError(CoplanError):
    """The animation could not be rendered (the plan itself is unaffected)."""


class OverwriteRefused(RenderError):
    """The animation would replace a file the user did not name (a usage error: exit code 2)."""

    exit_code = ExitCode.USAGE


class RenderWarning(UserWarning):
    """Something about the rendering the user should know (e.g. GIF instead of MP4)."""


def ffmpeg_available() -> bool:
    """Whether matplotlib can write MP4: an ``ffmpeg`` executable is found, the system's or else
    the one the ``imageio-ffmpeg`` wheel ships (then ``animation.ffmpeg_path`` is pointed at it)."""
    try:
        from matplotlib import animation

        _use_bundled_ffmpeg()
        return bool(animation.writers.is_available("ffmpeg")) and shutil.which(_ffmpeg_path()) is not None
    except (ImportError, OSError, RuntimeError, ValueError, KeyError):  # no writer, no binary, a bad rcParam: no MP4
        return False


def _use_bundled_ffmpeg() -> None:
    """Without an ``ffmpeg`` on the PATH (or where ``animation.ffmpeg_path`` says), use the
    binary of the ``imageio-ffmpeg`` wheel, a dependency of coplan."""
    import matplotlib

    if shutil.which(_ffmpeg_path()) is not None:
        return
    try:
        import imageio_ffmpeg
    except ImportError:
        return
    try:
        exe = imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError:  # the wheel has no binary for this platform
        return
    matplotlib.rcParams["animation.ffmpeg_path"] = exe


def _ffmpeg_path() -> str:
    import matplotlib

    return matplotlib.rcParams.get("animation.ffmpeg_path", "ffmpeg") or "ffmpeg"


_AXES = (0.98, 0.15, 0.74)  # the scene's axes: width, bottom and height, as shares of the figure


def _extent(problem: Problem, plan: Plan, width: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The world rectangle drawn (lower and upper corner, m) and the figure's height (inches)
    at ``width`` inches: the arms' reach, the bins, and the fruit (a row's: their heights, as the
    scene follows the carriage)."""
    arms = list(problem.arms)
    lo = np.min([np.subtract(a.base, a.reach) for a in arms], axis=0)
    hi = np.max([np.add(a.base, a.reach) for a in arms], axis=0)
    if problem.fruits and plan.gantry_x is None:
        lo = np.minimum(lo, problem.fruit_positions.min(axis=0))
        hi = np.maximum(hi, problem.fruit_positions.max(axis=0))
    elif problem.fruits:
        lo[1] = min(lo[1], problem.fruit_positions[:, 1].min())
        hi[1] = max(hi[1], problem.fruit_positions[:, 1].max())
    for a in arms:
        lo = np.minimum(lo, np.subtract(a.bin, 0.3))
        hi = np.maximum(hi, np.add(a.bin, 0.3))
    lo, hi = lo - 0.25, hi + 0.25
    ex, ey = hi - lo
    ax_w, _, ax_h = _AXES
    return lo, hi, width * ax_w * ey / ex / ax_h


#: The most memory a GIF's frames may take while it is written (Pillow holds every frame, one
#: byte per pixel, and about as much again while it encodes): about 2 bytes per pixel per frame
#: (measured: 474 frames of 1350 x 1000 px took 1.29 GB). More frames play the plan faster.
MAX_GIF_BYTES = 1_000_000_000
_GIF_BYTES_PER_PIXEL = 2.0


def frame_times(duration: float, speed: float = 1.0, fps: float = 10.0, hold_end: float = 1.0) -> np.ndarray:
    """Plan times shown by each frame: real time x ``speed`` at ``fps``, then ``hold_end``
    seconds (wall clock) on the final pose."""
    if not (speed > 0 and math.isfinite(speed)):
        raise ValueError(f"expected a speed factor > 0, found {speed!r}")
    if not (fps > 0 and math.isfinite(fps)):
        raise ValueError(f"expected fps > 0, found {fps!r}")
    step = speed / fps
    n = int(math.floor(duration / step + 1e-9)) + 1
    t = np.arange(n) * step
    if t[-1] < duration - 1e-9:
        t = np.append(t, duration)
    return np.concatenate([t, np.full(int(round(hold_end * fps)), duration)])


# --------------------------------------------------------------------------- rendering
def _offscreen_canvas_class(base):
    class _OffscreenCanvas(base):
        """An Agg canvas that never redraws on request: frames are rendered by the writer
        (a full draw per frame on ``draw_idle`` would double the cost of every frame)."""

        def draw_idle(self, *args, **kwargs):
            pass

    return _OffscreenCanvas


def _blit_gif_writer(fps: float, scene: "_Scene"):
    """A Pillow GIF writer for ``FuncAnimation.save`` that redraws only what changed.

    The static scene is rendered once and cached by screen region (the axes, the time slot,
    the status row, the arm panel). Each frame restores the axes and redraws the moving
    artists; a text region is restored and redrawn only when one of its texts changed (text
    is the slowest thing to draw). All frames share one palette, so colours do not flicker
    and Pillow stores only the changed rectangle of each frame.
    """
    from matplotlib.animation import AbstractMovieWriter
    from matplotlib.transforms import Bbox
    from PIL import Image

    def state(artist):
        if hasattr(artist, "get_text"):
            return (artist.get_text(), str(artist.get_color()), str(artist.get_fontweight()))
        return None

    class _BlitGifWriter(AbstractMovieWriter):
        def setup(self, fig, outfile, dpi=None):
            super().setup(fig, outfile, dpi)
            self._frames: list = []
            self._regions: dict | None = None
            self._last: dict = {}
            self._pal = None

        def _cache_background(self):
            canvas, fig = self.fig.canvas, self.fig
            for a in scene.artists:
                a.set_visible(False)
            canvas.draw()
            W, H = fig.bbox.width, fig.bbox.height
            ax = scene.ax.bbox
            boxes = {  # the axes on whole pixels: a fractional edge left a column never restored (fruit streaks)
                "axes": Bbox.from_extents(math.floor(ax.x0), math.floor(ax.y0), math.ceil(ax.x1), math.ceil(ax.y1)),
                "time": Bbox.from_extents(0, ax.y1 + 1, scene.split * W, H),
                "info": Bbox.from_extents(scene.split * W, ax.y1 + 1, W, H),
                "arms": Bbox.from_extents(0, 0, W, ax.y0 - 1),
            }
            self._regions = {k: canvas.copy_from_bbox(b) for k, b in boxes.items()}
            for a in scene.artists:
                a.set_visible(True)

        def grab_frame(self, **savefig_kwargs):
            canvas = self.fig.canvas
            first = self._regions is None
            if first:
                self._cache_background()
            for name, artists in scene.groups.items():
                key = None if name == "axes" else tuple(state(a) for a in artists)
                if not first and key is not None and key == self._last.get(name):
                    continue
                if not first:
                    canvas.restore_region(self._regions[name])
                for a in artists:
                    self.fig.draw_artist(a)
                self._last[name] = key
            im = Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())
            if self._pal is None:
                self._pal = _palette(im, scene.key_colors)
            self._frames.append(im.quantize(palette=self._pal, dither=Image.Dither.NONE))

        def finish(self):
            if self._frames:
                self._frames[0].save(
                    self.outfile, save_all=True, append_images=self._frames[1:],
                    duration=int(round(1000 / self.fps)), loop=0, optimize=True,
                )

    return _BlitGifWriter(fps=fps)


def _palette(im, key_colors):
    """A 256-colour palette from a frame plus swatches of every colour that may appear later."""
    from matplotlib.colors import to_rgb
    from PIL import Image

    sw = 8
    w, h = im.size
    canvas = Image.new("RGB", (w, h + sw * 3))
    canvas.paste(im, (0, 0))
    for i, c in enumerate(key_colors):
        rgb = tuple(int(round(255 * v)) for v in to_rgb(c))
        for j, f in enumerate((1.0, 0.6, 0.3)):  # the colour and lighter tints (alpha blends)
            tint = tuple(int(round(255 - (255 - v) * f)) for v in rgb)
            canvas.paste(tint, (i * sw * 2 % max(w - sw, 1), h + j * sw, i * sw * 2 % max(w - sw, 1) + sw * 2, h + (j + 1) * sw))
    return canvas.quantize(colors=255, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)


# --------------------------------------------------------------------------- the scene
class _Scene:
    """All artists of one animation and how to update them to a frame."""

    def __init__(self, problem: Problem, plan: Plan, *, width: float = 9.0, dpi: float = 80, trail: float = 2.5, title: str | None = None, speed: float = 1.0):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
        from matplotlib.patches import Annulus, Rectangle

        missing = [a.name for a in problem.arms if a.name not in plan.q]
        if missing:
            raise RenderError(f"the plan has no trajectory for arm(s) {', '.join(missing)} of problem {problem.name!r}; is it a plan of this problem?")
        self.problem, self.plan, self.trail, self.speed = problem, plan, trail, speed
        self.colors = arm_colors(problem)
        self.arms = list(problem.arms)
        self.sched = schedule(plan)
        self.pts = arm_points(problem, plan)  # every sample: (N, 3, 2)
        self.t_cl, self.clear = pair_clearance(problem, plan)
        self.req = problem.task.clearance
        self.first_violation: float | None = None
        self.n_alloc = {a.name: len(plan.allocation.get(a.name, [])) or len(plan.events_of(a.name, EventKind.PLACE)) for a in self.arms}
        self.prev_t = -1.0

        # a row is drawn from the carriage (the camera rides on it): the arms stay, the row passes by
        self.shift = None if plan.gantry_x is None else np.asarray(plan.gantry_x, float)
        lo, hi, height = _extent(problem, plan, width)
        ex, ey = hi - lo
        ax_w, ax_b, ax_h = _AXES
        self.fig = fig = Figure(figsize=(width, height), dpi=dpi)
        _offscreen_canvas_class(FigureCanvasAgg)(fig)
        ax = self.ax = fig.add_axes((0.01, ax_b, ax_w, ax_h))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        for sp in ax.spines.values():
            sp.set_color("#bbbbbb")
        px_per_m = ax_w * width * dpi / ex
        pt_per_m = px_per_m * 72.0 / dpi

        # static: annuli, bins, bases, fruit ids
        for a in self.arms:
            c = self.colors[a.name]
            ax.add_patch(Annulus(a.base, a.reach, a.reach - a.inner_radius, facecolor=c, alpha=0.07, edgecolor="none"))
            ax.add_patch(Annulus(a.base, a.reach, a.reach - a.inner_radius, facecolor="none", edgecolor=c, alpha=0.45, linestyle="--", linewidth=0.8))
            ax.add_patch(Rectangle((a.bin[0] - 0.15, a.bin[1] - 0.12), 0.3, 0.24, facecolor=c, alpha=0.25, edgecolor=c, linewidth=1.5, zorder=2))
            ax.plot(*a.base, marker="s", color="#444444", markersize=8, zorder=3)
        self.fruit_ids = [f.id for f in problem.fruits]
        self.fruit_pos = problem.fruit_positions
        if self.shift is not None:  # a row: what was harvestable is what the plan's screen left (its metrics)
            out = ((plan.metrics or {}).get("row") or {}).get("screened_out") or {}
            self.reachable = np.array([f not in out for f in self.fruit_ids], bool)
        else:
            reach = problem.reach_matrix() if problem.fruits else np.zeros((len(self.arms), 0), bool)
            self.reachable = reach.any(axis=0) if reach.size else np.zeros(len(self.fruit_ids), bool)
        for k, f in enumerate(problem.fruits if self.shift is None else ()):  # (a row's fruit move: no fixed labels)
            ax.annotate(f.id, f.position, xytext=(4, 4), textcoords="offset points", fontsize=6, color="#777777", zorder=2)
            if not self.reachable[k]:
                ax.plot(*f.position, "x", color="#777777", markersize=6, markeredgewidth=1.5, zorder=3)

        # dynamic
        self.links, self.joints, self.trails = {}, {}, {}
        for a in self.arms:
            c = self.colors[a.name]
            lw = max(2.0, 2 * a.link_radius * pt_per_m)
            (self.trails[a.name],) = ax.plot([], [], "-", color=c, linewidth=1.2, alpha=0.55, zorder=4)
            (self.links[a.name],) = ax.plot([], [], "-", color=c, linewidth=lw, solid_capstyle="round", alpha=0.9, zorder=5)
            (self.joints[a.name],) = ax.plot([], [], "o", color=c, markerfacecolor="white", markeredgewidth=1.6, markersize=max(3.0, lw * 0.55), zorder=6)
        self.fruit_art = ax.scatter(np.zeros(len(self.fruit_ids)), np.zeros(len(self.fruit_ids)), s=42, c=FRUIT_COLOR, edgecolors="#5a0000", linewidths=0.6, zorder=7)

        # text
        fig.text(0.01, 0.965, title or _title(problem, plan), fontsize=11, fontweight="bold", va="center")
        # the time has its own slot (redrawn every frame); the rest of the row changes rarely
        self.split = min(0.5, (0.01 * width + 2.4) / width)
        self.time_text = fig.text(0.01, 0.92, "", fontsize=10, va="center", family="monospace")
        self.info_text = fig.text(self.split + 0.01, 0.92, "", fontsize=9, va="center", color="#333333")
        self.status_text = fig.text(0.99, 0.92, "", fontsize=10, va="center", ha="right")
        n = len(self.arms)
        fs = 9 if n <= 4 else 8 if n <= 6 else 6.5
        self.arm_text = {}
        for i, a in enumerate(self.arms):
            x = (i + 0.5) / n
            fig.text(x, 0.105, a.name, color=self.colors[a.name], fontsize=fs + 1, fontweight="bold", ha="center", va="center")
            self.arm_text[a.name] = fig.text(x, 0.045, "", color="black", fontsize=fs, ha="center", va="center")
        handles = [
            Line2D([], [], marker="o", color="none", markerfacecolor=FRUIT_COLOR, markeredgecolor="#5a0000", label="ripe fruit"),
            Line2D([], [], marker="x", color="#777777", linestyle="none", label="unreachable"),
            Line2D([], [], color=ALERT_COLOR, linewidth=3, label=f"closer than {self.req:g} m"),
        ]
        ax.legend(handles=handles, loc="lower center", ncol=3, fontsize=7, frameon=False, handlelength=1.5)
        # the artists that change, by screen region (see _blit_gif_writer)
        self.groups = {
            "axes": list(self.trails.values()) + list(self.links.values()) + list(self.joints.values()) + [self.fruit_art],
            "time": [self.time_text],
            "info": [self.info_text, self.status_text],
            "arms": list(self.arm_text.values()),
        }
        self.artists = [a for group in self.groups.values() for a in group]
        self.key_colors = list(self.colors.values()) + [ALERT_COLOR, FRUIT_COLOR, "#5a0000", "#2a7a2a", "#b35900", "#ffffff", "#000000"]

    # ------------------------------------------------------------------ per frame
    def _index(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.plan.time, t, side="right") - 1, 0, self.plan.time.size - 1))

    def update(self, t: float):
        plan = self.plan
        t = float(min(max(t, 0.0), plan.duration))
        pose = plan.sample(np.array([t]))
        # clearance since the previous frame (so short violations between frames still show)
        lo_t = self.prev_t if 0 <= self.prev_t < t else t - 1e-9
        win = (self.t_cl > lo_t) & (self.t_cl <= t + 1e-9)
        if not win.any():
            win = np.zeros(self.t_cl.size, bool)
            win[self._index(t)] = True
        self.prev_t = t
        bad_arms: set[str] = set()
        worst = None
        for (a, b), d in self.clear.items():
            dmin = float(d[win].min())
            if dmin < self.req:
                bad_arms |= {a, b}
                if worst is None or dmin < worst[2]:
                    worst = (a, b, dmin)
        for arm in self.arms:
            p = self._fk(arm, pose[arm.name][0])
            self.links[arm.name].set_data(p[:, 0], p[:, 1])
            self.joints[arm.name].set_data(p[:, 0], p[:, 1])
            self.links[arm.name].set_color(ALERT_COLOR if arm.name in bad_arms else self.colors[arm.name])
            i = self._index(t)
            j0 = self._index(max(0.0, t - self.trail))
            tips = self.pts[arm.name][j0 : i + 1 : 2, 2]
            tips = np.vstack([tips, p[2:3]])
            self.trails[arm.name].set_data(tips[:, 0], tips[:, 1])
            seg = phase_at(self.sched[arm.name], t)
            phase = seg.phase.value + (f" {seg.fruit}" if seg.fruit and seg.phase in (ArmPhase.PICKING, ArmPhase.PLACING) else "")
            if seg.phase == ArmPhase.MOVING and seg.fruit:
                carrying = fruit_states(self.problem, plan, t).get(seg.fruit, ("", None))[0] == "carried"
                phase = f"moving {'with' if carrying else 'to'} {seg.fruit}"
            self.arm_text[arm.name].set_text(f"{phase} · harvested {harvested_count(plan, arm.name, t)}/{self.n_alloc[arm.name]}")
        self._update_fruit(t, pose)
        total = sum(harvested_count(plan, a.name, t) for a in self.arms)
        self.time_text.set_text(f"t = {t:6.2f} s / {plan.duration:.2f} s")
        carriage = "" if self.shift is None else f"   carriage at {float(np.interp(t, plan.time, self.shift)):.2f} m"
        self.info_text.set_text(f"×{self.speed:g}   in bins {total}/{int(self.reachable.sum())} reachable fruit{carriage}")
        if worst is not None:
            a, b, d = worst
            if self.first_violation is None:
                self.first_violation = t
            what = f"COLLISION {pair_label(a, b)}: overlap {-d:.3f} m" if d < 0 else f"TOO CLOSE {pair_label(a, b)}: {d:.3f} m < {self.req:g} m"
            self.status_text.set_text(what)
            self.status_text.set_color(ALERT_COLOR)
            self.status_text.set_fontweight("bold")
        else:
            since = f" (violated at {self.first_violation:.2f} s)" if self.first_violation is not None else ""
            self.status_text.set_text(f"all pairs clear{since}" if self.clear else "no two arms can meet")
            self.status_text.set_color("#2a7a2a" if self.first_violation is None else "#b35900")
            self.status_text.set_fontweight("normal")
        return self.artists

    def _fk(self, arm, q) -> np.ndarray:
        from ..kinematics import arm as kin

        return kin.fk_points(np.asarray(q, float), arm.links, arm.base)

    def _update_fruit(self, t: float, pose) -> None:
        if not self.fruit_ids:
            return
        states = fruit_states(self.problem, self.plan, t)
        pos = self.fruit_pos.copy()
        if self.shift is not None:  # seen from the carriage
            pos[:, 0] -= float(np.interp(t, self.plan.time, self.shift))
        sizes = np.full(len(self.fruit_ids), 42.0)
        alpha = np.ones(len(self.fruit_ids))
        in_bin: dict[str, int] = {}
        places = {e.fruit: e.t_end for e in self.plan.events if e.kind == EventKind.PLACE}
        order = sorted(range(len(self.fruit_ids)), key=lambda k: places.get(self.fruit_ids[k], math.inf))
        for k in order:
            fid = self.fruit_ids[k]
            state, arm = states[fid]
            if state == "carried" and arm is not None:
                a = self.problem.arm(arm)
                pos[k] = self._fk(a, pose[arm][0])[2]
                sizes[k] = 30
            elif state == "binned" and arm is not None:
                a = self.problem.arm(arm)
                n = in_bin.get(arm, 0)
                in_bin[arm] = n + 1
                pos[k] = (a.bin[0] - 0.105 + 0.07 * (n % 4), a.bin[1] - 0.07 + 0.07 * (n // 4 % 3))
                sizes[k] = 16
            elif not self.reachable[k]:
                alpha[k] = 0.35
        rgba = np.tile(np.array([0.839, 0.153, 0.157, 1.0]), (len(self.fruit_ids), 1))
        rgba[:, 3] = alpha
        self.fruit_art.set_offsets(pos)
        self.fruit_art.set_sizes(sizes)
        self.fruit_art.set_facecolors(rgba)


def _title(problem: Problem, plan: Plan) -> str:
    m = plan.metrics or {}
    ms = f", makespan {m['makespan']:.2f} s" if m.get("makespan") is not None else ""
    return f"{problem.name}: {plan.label} plan ({plan.status.value}{ms})"


# --------------------------------------------------------------------------- entry points
def build_animation(problem: Problem, plan: Plan, *, speed: float = 1.0, fps: float = 10.0, dpi: float = 80, width: float = 9.0, trail: float = 2.5, hold_end: float = 1.0, title: str | None = None):
    """A ``FuncAnimation`` of the plan (headless figure, not shown). Frame ``k`` shows plan
    time ``frame_times(...)[k]``; the interval is ``1000 / fps`` ms (real time x ``speed``)."""
    from matplotlib.animation import FuncAnimation

    times = frame_times(plan.duration, speed, fps, hold_end)
    scene = _Scene(problem, plan, width=width, dpi=dpi, trail=trail, title=title, speed=speed)

    def update(k):
        if k == 0:
            scene.prev_t = -1.0
            scene.first_violation = None
        return scene.update(times[k])

    anim = FuncAnimation(scene.fig, update, frames=len(times), interval=1000.0 / fps, blit=False, repeat=True)
    anim.scene = scene  # keep a handle (tests, custom drawing)
    anim.frame_times = times
    return anim


def render_frame(problem: Problem, plan: Plan, t: float, *, dpi: float = 100, width: float = 9.0, trail: float = 2.5, title: str | None = None):
    """One still of the animation at plan time ``t`` as a ``Figure`` (violations shown are
    those of the last 0.1 s)."""
    if isinstance(t, bool) or not isinstance(t, (int, float, np.number)) or not math.isfinite(t):  # ("1": '>' not supported)
        raise ValueError(f"render_frame: t: expected a plan time in s (a finite number), found {t!r:.60}")
    end = float(plan.time[-1]) if len(plan.time) else 0.0
    if not 0.0 <= t <= end + 1e-9:  # (a negative time drew the plan's first pose, as if it were t = 0)
        raise ValueError(f"render_frame: t: expected a plan time in [0, {end:g}] s, found {t:g}")
    scene = _Scene(problem, plan, width=width, dpi=dpi, trail=trail, title=title)
    scene.prev_t = max(0.0, t - 0.1) if t > 0 else -1.0
    scene.update(t)
    return scene.fig


#: errnos of the disk or the folder, not of the encoder: reported as I/O errors with the path
_DISK_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG)


def animate_plan(
    problem: Problem,
    plan: Plan,
    out_path: str | Path,
    *,
    speed: float = 1.0,
    fps: float = 10.0,
    dpi: float = 80,
    width: float = 9.0,
    max_frames: int = 1500,
    notify: Callable[[str], None] | None = None,
    progress=None,
) -> Path:
    """Render the plan to ``out_path`` and return the path actually written.

    ``.gif``: an animated GIF through Pillow (another suffix is a :class:`RenderError`, as
    ``coplan animate``'s usage error: Pillow took ``.png`` as an animated PNG), ``fps``
    rounded so that the frame delay is whole centiseconds (10, 20, 25, 50 fps are exact).
    ``.mp4``: through ffmpeg (the system's, else the ``imageio-ffmpeg`` wheel's); when there is
    none, ``notify`` gets a clear message and a GIF is written next to it (``.gif`` suffix)
    instead -- but never over an existing file (the user did not name it): then
    :class:`RenderError`. Plans longer than ``max_frames`` frames play faster (with a message)
    so rendering stays quick. Frames go to a uniquely named hidden ``*.partial*`` file beside the
    target, renamed into place when complete; any failure, Ctrl-C included, removes it. Any
    rendering failure raises :class:`RenderError` with the reason; nothing else is touched.
    The file gets the user's usual permissions (as any file they write, not ``mkstemp``'s 0600).
    ``progress``: a :class:`coplan.progress.Reporter` receives a :class:`coplan.progress.Tick`
    per frame written.
    """
    from matplotlib.animation import FFMpegWriter

    say = notify or (lambda msg: warnings.warn(msg, RenderWarning, stacklevel=3))
    if not isinstance(problem, Problem) or not isinstance(plan, Plan):  # (swapped: "'Problem' object has no attribute 'duration'")
        raise TypeError(f"animate_plan: expected (problem: Problem, plan: Plan, out_path), found "
                        f"({type(problem).__name__}, {type(plan).__name__}, ...)")
    out = Path(out_path)
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise RenderError(f"expected an output file ending .gif or .mp4, found {out.name!r}")

    def number(v) -> bool:  # ("2" as a speed: "'>' not supported between 'str' and 'int'")
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    if not (number(speed) and speed > 0):
        raise RenderError(f"expected a speed factor > 0, found {speed!r}")
    if not (number(fps) and 0 < fps <= 60):
        raise RenderError(f"expected frames per second in (0, 60], found {fps!r}")
    if not (number(dpi) and 10 <= dpi <= 1000) or not (number(width) and 1 <= width <= 100):  # (0: an overflow)
        raise RenderError(f"expected dpi from 10 to 1000 and a width from 1 to 100 inches, found dpi {dpi!r}, width {width!r}")
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 2:  # (0: ZeroDivisionError)
        raise RenderError(f"expected max_frames a whole number of 2 or more, found {max_frames!r}")
    mp4 = out.suffix.lower() == ".mp4"
    if mp4 and not ffmpeg_available():
        gif = out.with_suffix(".gif")
        if gif.exists():
            raise OverwriteRefused(f"no ffmpeg, so no MP4 can be written, and the GIF instead would replace {gif}, "
                              f"which you did not name: not overwritten (install ffmpeg, or give --out {gif} to replace it)")
        say(f"ffmpeg is not installed, so no MP4 can be written; writing a GIF instead: {gif} (install ffmpeg for MP4)")
        out, mp4 = gif, False
    if not mp4:  # GIF delays are whole centiseconds: keep playback exactly real time x speed
        gif_fps = 100.0 / max(1, round(100.0 / fps))
        if abs(gif_fps - fps) > 1e-9:
            say(f"GIF frame delays are whole centiseconds: using {gif_fps:g} fps instead of {fps:g}")
            fps = gif_fps
    n = len(frame_times(plan.duration, speed, fps, 1.0))
    cap, why = max_frames, f"to stay within {max_frames} frames"
    if not mp4:  # a GIF's frames are held in memory until it is written
        px = (width * dpi) * (_extent(problem, plan, width)[2] * dpi)
        fits = int(MAX_GIF_BYTES // (_GIF_BYTES_PER_PIXEL * px))
        if fits < cap:
            cap, why = max(fits, 2), (f"to stay within {fits} frames of {width * dpi:.0f} px wide at --dpi {dpi:g} "
                                      f"(a GIF's frames are held in memory: at most {MAX_GIF_BYTES / 1e9:g} GB)")
    if n > cap:
        new_speed = math.ceil(speed * n / cap * 10) / 10
        say(f"the plan lasts {plan.duration:.1f} s: playing it at ×{new_speed:g} instead of ×{speed:g} {why}")
        speed = new_speed
    with named_as(out):  # (a folder that takes no files: said before any frame is drawn, as the user named it)
        out.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=".partial" + out.suffix, dir=out.parent)
    os.close(fd)
    tmp: Path | None = Path(name)
    try:
        anim = build_animation(problem, plan, speed=speed, fps=fps, dpi=dpi, width=width)
        writer = FFMpegWriter(fps=fps, bitrate=1800) if mp4 else _blit_gif_writer(fps, anim.scene)
        tick = ticker(progress)
        anim.save(str(tmp), writer=writer, dpi=dpi,
                  progress_callback=lambda i, total: tick(Tick("frames", i + 1, total, "frames", note=out.name)))
        tmp.chmod(usual_mode())
        tmp.replace(out)
        tmp = None
    except RenderError:
        raise
    except subprocess.CalledProcessError as e:
        if e.returncode == 255 or e.returncode < 0:  # ffmpeg stopped by the Ctrl-C or SIGTERM its process group got
            raise KeyboardInterrupt from e  # (it was a render failure, exit 1)
        raise RenderError(f"could not render the animation to {out}: {type(e).__name__}: {e}") from e
    except OSError as e:
        if e.errno in _DISK_ERRNOS:  # a full disk, a folder that refuses the file: an I/O error (exit 8), named
            raise OSError(e.errno, e.strerror or str(e), str(out)) from e
        raise RenderError(f"could not render the animation to {out}: {type(e).__name__}: {e}") from e
    except Exception as e:  # noqa: BLE001 -- turn any backend/encoder failure into one clear message
        raise RenderError(f"could not render the animation to {out}: {type(e).__name__}: {e}") from e
    finally:  # a failure or Ctrl-C: no partial file is left behind
        if tmp is not None:
            tmp.unlink(missing_ok=True)
    return out
