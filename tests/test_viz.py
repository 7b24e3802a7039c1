"""Plots, animation and the ``plot`` / ``animate`` commands (coplan.viz).

Plans come from the heuristic planner (milliseconds); nothing here needs the optimiser.
Figures are inspected through their artists (axes, labels, legend entries), the GIF through
Pillow (frames, size, playback time).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from PIL import Image
from typer.testing import CliRunner

from coplan import parse_problem
from coplan.cli import app
from coplan.generate import row_problem, to_yaml
from coplan.planners.heuristic import plan_heuristic
from coplan.plan import EventKind
from coplan.viz import animate as anim_mod
from coplan.viz.animate import RenderError, animate_plan, frame_times, render_frame
from coplan.viz.plots import plot_clearance, plot_gantt, plot_joints, plot_workspace, save_comparison_figures
from coplan.viz.style import ALERT_COLOR, FRUIT_COLOR, arm_colors
from coplan.viz.timeline import ArmPhase, fruit_states, joint_derivatives, pair_clearance, schedule


def run(*args: str):
    return CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(app, list(args))


def legend_texts(fig: Figure) -> list[str]:
    out = []
    for leg in list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]:
        out += [t.get_text() for t in leg.get_texts()]
    return out


@pytest.fixture(scope="module")
def hplan(greenhouse):
    return plan_heuristic(greenhouse)


@pytest.fixture(scope="module")
def crowded():
    """Three arms 1.2 m apart: the uncoordinated heuristic collides."""
    p = parse_problem(to_yaml(row_problem(3, 12, spacing=1.2, seed=7, reachable_only=True)))
    return p, plan_heuristic(p)


@pytest.fixture(scope="module")
def saved(tmp_path_factory, greenhouse, single_arm):
    """plan.json files on disk, as the CLI reads them."""
    d = tmp_path_factory.mktemp("plans")
    plan_heuristic(greenhouse).save(d / "gh")
    plan_heuristic(single_arm).save(d / "one")
    return {"greenhouse": d / "gh" / "plan.json", "single": d / "one" / "plan.json"}


# --------------------------------------------------------------------------- no matplotlib at import
def test_import_coplan_and_viz_modules_do_not_import_matplotlib():
    code = (
        "import sys, coplan, coplan.viz, coplan.viz.plots, coplan.viz.animate, coplan.viz.timeline; "
        "print('matplotlib' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# --------------------------------------------------------------------------- palette and data
def test_arm_colours_are_stable_distinct_and_never_red(greenhouse, hplan):
    c = arm_colors(greenhouse)
    assert list(c) == [a.name for a in greenhouse.arms]
    assert c == arm_colors(hplan) == arm_colors([a.name for a in greenhouse.arms])
    assert len(set(c.values())) == len(c)
    for col in c.values():
        r, g, b = to_rgb(col)
        assert not (r > 0.7 and g < 0.3 and b < 0.3), col  # red means fruit / violation
    assert to_rgb(FRUIT_COLOR)[0] > 0.8 and to_rgb(ALERT_COLOR)[0] > 0.8


def test_schedule_covers_the_plan_and_labels_every_event(greenhouse, hplan):
    segs = schedule(hplan)
    for arm in greenhouse.arms:
        s = segs[arm.name]
        assert s[0].t0 == pytest.approx(0.0) and s[-1].t1 == pytest.approx(hplan.duration)
        assert all(a.t1 == pytest.approx(b.t0) for a, b in zip(s, s[1:]))
        assert all(isinstance(x.phase, ArmPhase) for x in s)
        picked = [x.fruit for x in s if x.phase == ArmPhase.PICKING]
        assert picked == [e.fruit for e in hplan.events_of(arm.name, EventKind.PICK)]
    # the centre arm finishes early in the course's allocation and then idles
    assert segs["center"][-1].phase == ArmPhase.IDLE
    # the words the viewer's JSON and the animation show are the phases' values, not enum names
    assert f"{ArmPhase.PICKING} f1" == "picking f1" and json.dumps({"p": ArmPhase.IDLE}) == '{"p": "idle"}'


def test_fruit_states_follow_pick_and_place(greenhouse, hplan):
    e = hplan.events_of("left", EventKind.PICK)[0]
    pl = next(x for x in hplan.events_of("left", EventKind.PLACE) if x.fruit == e.fruit)
    assert fruit_states(greenhouse, hplan, 0.0)[e.fruit] == ("ripe", None)
    assert fruit_states(greenhouse, hplan, (e.t_start + e.t_end) / 2)[e.fruit] == ("picking", "left")
    assert fruit_states(greenhouse, hplan, (e.t_end + pl.t_start) / 2)[e.fruit] == ("carried", "left")
    assert fruit_states(greenhouse, hplan, pl.t_end + 0.01)[e.fruit] == ("binned", "left")
    assert fruit_states(greenhouse, hplan, hplan.duration)["f01"] == ("ripe", None)  # unreachable


def test_clearance_dense_and_sampled_agree(greenhouse, hplan, crowded):
    t_d, dense = pair_clearance(greenhouse, hplan)
    t_s, samp = pair_clearance(greenhouse, hplan, dense=False)
    assert set(dense) == set(samp) == {("left", "center"), ("center", "right")}
    assert t_s.size == hplan.time.size and t_d.size >= t_s.size
    for k in dense:
        assert dense[k].min() <= samp[k].min() + 1e-9
        assert dense[k].min() == pytest.approx(samp[k].min(), abs=0.01)
    p, plan = crowded
    assert min(d.min() for d in pair_clearance(p, plan)[1].values()) < 0  # it collides


def test_joint_derivatives_are_finite_differences(hplan):
    d = joint_derivatives(hplan, "left")
    t, v = d["velocity"]
    q = hplan.q["left"]
    assert np.allclose(v[3 : 3 + q.shape[0] - 1], np.diff(q, axis=0) / hplan.dt)
    assert d["jerk"][1].shape[1] == 2 and np.all(np.isfinite(d["jerk"][1]))


# --------------------------------------------------------------------------- plots
def test_gantt_stacks_plans_with_arms_phases_and_fruit_ids(greenhouse, hplan):
    fig = plot_gantt(greenhouse, {"heuristic": hplan, "again": hplan})
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    for ax in fig.axes:
        assert [t.get_text() for t in ax.get_yticklabels()] == [a.name for a in greenhouse.arms]
        assert ax.get_title(loc="left").split(":")[0] in ("heuristic", "again")
        texts = {t.get_text() for t in ax.texts}
        assert {"f02", "f05", "f09"} <= texts and not ({"f01"} & texts)
    assert fig.axes[-1].get_xlabel() == "time (s)"
    labels = " ".join(legend_texts(fig))
    for phase in ("moving", "picking", "placing", "idle"):
        assert phase in labels
    colours = arm_colors(greenhouse)
    for tick in fig.axes[0].get_yticklabels():
        assert to_rgb(tick.get_color()) == to_rgb(colours[tick.get_text()])


def test_a_rows_gantt_labels_only_the_picks_whose_ids_do_not_run_into_each_other(greenhouse, hplan):
    """A row of hundreds of picks: on each arm's line no two fruit ids overlap as drawn (their
    rendered boxes), yet some are labelled; a cell's few picks are all labelled (above)."""
    from coplan.generate import gantry_row
    from coplan.row.plan import plan_row

    row = parse_problem(to_yaml(gantry_row(length=12.0, n_arms=3, density=10.0, seed=1)))
    fig = plot_gantt(row, plan_row(row).plan)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    ax = fig.axes[0]
    ids = [t for t in ax.texts if t.get_text().startswith("f")]
    picks = sum(1 for _ in row.fruits)
    assert 0 < len(ids) < picks
    by_line: dict = {}
    for t in ids:
        by_line.setdefault(round(t.get_position()[1], 3), []).append(t.get_window_extent(renderer))
    for boxes in by_line.values():
        boxes.sort(key=lambda b: b.x0)
        assert all(a.x1 <= b.x0 + 0.5 for a, b in zip(boxes, boxes[1:]))


def test_clearance_plot_draws_every_pair_and_the_requirement(greenhouse, hplan, crowded):
    fig = plot_clearance(greenhouse, hplan)
    (ax,) = fig.axes
    assert ax.get_ylabel() == "clearance (m)" and ax.get_xlabel() == "time (s)"
    labels = legend_texts(fig)
    assert "left – center" in labels and "center – right" in labels
    assert f"required clearance {greenhouse.task.clearance:g} m" in labels
    assert any(np.allclose(line.get_ydata(), greenhouse.task.clearance) for line in ax.get_lines())
    p, plan = crowded
    fig = plot_clearance(p, {"crowded": plan})
    assert any(c.__class__.__name__ in ("PolyCollection", "FillBetweenPolyCollection") for c in fig.axes[0].collections)


def test_the_clearance_figure_names_the_verifiers_instant_among_near_ties(greenhouse, hplan):
    """(The figure said "0.120 m at 5.57 s", verification.json 0.1200 m at 1.80 s: a near-tie,
    each its own sample.) Told another instant of (nearly) the same least clearance, the figure
    names it; told an instant of a clearly larger one, it keeps its own least."""
    import copy

    from coplan.viz.timeline import pair_clearance

    t, prof = pair_clearance(greenhouse, hplan)
    (a, b), d = next(iter(prof.items()))
    k = int(np.argmin(d))
    near = k + 2 if k + 2 < d.size else k - 2
    far = int(np.argmax(d))
    assert d[near] - d[k] <= 5e-4 < d[far] - d[k]

    def said(i):
        plan = copy.deepcopy(hplan)
        plan.verification = dict(plan.verification or {}, pairs={f"{a}-{b}": {"min_clearance": float(d[k]), "t": float(t[i])}})
        return " ".join(x.get_text() for x in plot_clearance(greenhouse, plan).axes[0].texts)

    assert f"{d[near]:.3f} m at {t[near]:.2f} s" in said(near)
    assert f"{d[k]:.3f} m at {t[k]:.2f} s" in said(far)


def test_joint_plot_has_four_quantities_two_joints_and_limits(greenhouse, hplan):
    fig = plot_joints(greenhouse, hplan)
    assert len(fig.axes) == 8
    ylabels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
    assert ylabels == ["position\n(rad)", "velocity\n(rad/s)", "acceleration\n(rad/s²)", "jerk\n(rad/s³)"]
    labels = legend_texts(fig)
    assert [a.name for a in greenhouse.arms] == labels[:3] and "limit (±)" in labels
    jerk_ax = fig.axes[6]
    assert any("OVER LIMIT" in t.get_text() for t in jerk_ax.texts)  # the cubic's jerk spikes
    one = plot_joints(greenhouse, hplan, arms=["right"])
    assert legend_texts(one)[:1] == ["right"]
    with pytest.raises(ValueError):
        plot_joints(greenhouse, hplan, arms=["nobody"])
    assert legend_texts(plot_joints(greenhouse, hplan, arms="right"))[:1] == ["right"]  # one name as a str
    for typo in (["left", "lft"], "leftright"):  # (a typo was dropped in silence; a str matched by substring: both arms)
        with pytest.raises(ValueError, match=r"plot_joints: arms: expected names of the plan's arms .*found \['(lft|leftright)'\]"):
            plot_joints(greenhouse, hplan, arms=typo)


def test_workspace_map_cell_and_single_arm(greenhouse):
    fig = plot_workspace(greenhouse, resolution=120)
    ax = fig.axes[0]
    assert len(ax.images) == 1 and ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    labels = legend_texts(fig)
    assert {"left", "center", "right", "90% safety ring", "overlap (≥ 2 arms reach)", "fruit no arm can reach"} <= set(labels)
    assert "3 fruit shared, 1 unreachable" in ax.get_title()
    assert "manipulability" in fig.axes[1].get_ylabel()  # the colour bar
    one = plot_workspace(greenhouse, "center", resolution=80)
    assert "arm center" in one.axes[0].get_title() and "overlap (≥ 2 arms reach)" not in legend_texts(one)
    for bad in (0, 1, 2.5, True, 10**6):  # (0: an IndexError from inside)
        with pytest.raises(ValueError, match=r"resolution: expected a whole number of grid points per axis from 2 to 2000, found"):
            plot_workspace(greenhouse, resolution=bad)


def test_save_comparison_figures_writes_pngs(tmp_path, greenhouse, hplan):
    paths = save_comparison_figures(greenhouse, {"heuristic": hplan, "optimal": hplan}, tmp_path / "figs")
    assert [p.name for p in paths] == ["schedule_gantt.png", "clearance.png", "joints_heuristic.png", "joints_optimal.png"]
    for p in paths:
        with Image.open(p) as im:
            assert im.format == "PNG" and im.size[0] > 600


# --------------------------------------------------------------------------- animation
def test_frame_times_play_in_real_time_times_speed():
    t = frame_times(2.0, speed=1.0, fps=10, hold_end=1.0)
    assert t[0] == 0 and np.allclose(np.diff(t[:21]), 0.1) and len(t) == 21 + 10 and t[-1] == 2.0
    assert len(frame_times(2.0, speed=2.0, fps=10, hold_end=0)) == 11
    assert frame_times(2.05, 1.0, 10, 0)[-1] == 2.05  # the final pose is always shown
    with pytest.raises(ValueError):
        frame_times(1.0, speed=0)


def test_animate_plan_writes_a_real_time_gif(tmp_path, single_arm):
    plan = plan_heuristic(single_arm)
    out = animate_plan(single_arm, plan, tmp_path / "a" / "one.gif", fps=10, dpi=50, width=6)
    assert out == tmp_path / "a" / "one.gif" and out.exists()
    assert not list(out.parent.glob("*.partial*"))
    with Image.open(out) as im:
        assert im.format == "GIF" and im.size == (300, pytest.approx(im.size[1]))
        n, total = im.n_frames, 0
        for k in range(n):
            im.seek(k)
            total += im.info["duration"]
    expected = len(frame_times(plan.duration, 1.0, 10, 1.0))
    assert 10 <= n <= expected  # identical frames (the hold at the end) are merged
    assert total == pytest.approx(expected * 100, abs=1)  # real time: 100 ms per frame


def test_mp4_without_ffmpeg_falls_back_to_gif_with_a_message(tmp_path, single_arm, monkeypatch):
    monkeypatch.setattr(anim_mod, "ffmpeg_available", lambda: False)
    said = []
    out = animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "one.mp4", dpi=40, width=5, notify=said.append)
    assert out == tmp_path / "one.gif" and out.exists()
    assert len(said) == 1 and "ffmpeg" in said[0] and "GIF" in said[0]


def test_rendering_errors_are_clear(tmp_path, greenhouse, single_arm):
    with pytest.raises(RenderError, match="no trajectory for arm"):
        animate_plan(greenhouse, plan_heuristic(single_arm), tmp_path / "x.gif")
    with pytest.raises(RenderError, match="speed"):
        animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "x.gif", speed=-1)
    with pytest.raises(RenderError, match=r"expected an output file ending \.gif or \.mp4, found 'x\.png'"):
        animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "x.png")  # (Pillow wrote an animated PNG)
    assert not (tmp_path / "x.png").exists()


def test_frame_shows_phases_counts_and_collisions(greenhouse, hplan, crowded):
    fig = render_frame(greenhouse, hplan, 1.0, dpi=50)
    texts = [t.get_text() for t in fig.texts]
    assert any(t.startswith("t =") for t in texts) and "all pairs clear" in texts
    assert any("picking f05" in t and "harvested 0/4" in t for t in texts)
    p, plan = crowded
    t, prof = pair_clearance(p, plan)
    worst = min(prof, key=lambda k: prof[k].min())
    fig = render_frame(p, plan, float(t[np.argmin(prof[worst])]), dpi=50)
    assert any(x.get_text().startswith("COLLISION") for x in fig.texts)
    reds = [ln for ln in fig.axes[0].get_lines() if ln.get_color() == ALERT_COLOR]
    assert len(reds) >= 2  # both arms of the pair


# --------------------------------------------------------------------------- CLI
@pytest.mark.parametrize("command, suffix", [(["plot", "--kind", "gantt"], ".png"), (["plot", "--kind", "clearance"], ".png"),
                                             (["view"], ".html"), (["animate"], ".gif")])
def test_a_plan_of_another_problem_is_refused_as_bad_input_by_every_figure_command(tmp_path, saved, command, suffix):
    """(From a new user's trial: ``coplan plot greenhouse's plan.json -p dense_overlap`` ended in
    "internal error (ValueError)", exit 1, while view and animate drew it: the arm names match,
    the fruit do not.) Each refuses it, exit 3, naming the file and what does not fit."""
    runner = CliRunner(env={"COLUMNS": "300", "COPLAN_DEBUG": None})
    out = tmp_path / f"x{suffix}"
    res = runner.invoke(app, [command[0], str(saved["greenhouse"]), "-p", "dense_overlap", *command[1:], "--out", str(out)])
    assert res.exit_code == 3 and "does not fit problem 'dense-overlap'" in res.output, res.output
    assert "fruit the problem does not have" in res.output and "internal error" not in res.output and not out.exists()


@pytest.mark.parametrize("kind", ["gantt", "clearance", "joints", "workspace"])
def test_cli_plot_each_kind(tmp_path, saved, kind):
    out = tmp_path / f"{kind}.png"
    r = run("plot", str(saved["greenhouse"]), "--kind", kind, "--out", str(out))
    assert r.exit_code == 0, r.output
    with Image.open(out) as im:
        assert im.format == "PNG"


def test_cli_plot_defaults_and_errors(tmp_path, saved, greenhouse):
    r = run("plot", str(saved["single"]))  # default kind gantt, default file next to the plan
    assert r.exit_code == 0, r.output
    assert (saved["single"].parent / "plan_gantt.png").exists()
    # (plot plan.csv's default name was plan_gantt.png too: it overwrote plan.json's figure)
    before = (saved["single"].parent / "plan_gantt.png").read_bytes()
    r = run("plot", str(saved["single"].with_suffix(".csv")), "--problem", "single_arm")
    assert r.exit_code == 0, r.output
    assert (saved["single"].parent / "plan_csv_gantt.png").exists()
    assert (saved["single"].parent / "plan_gantt.png").read_bytes() == before
    r = run("plot", str(greenhouse.source), "--kind", "workspace", "--arm", "left", "--out", str(tmp_path / "w.svg"))
    assert r.exit_code == 0 and (tmp_path / "w.svg").read_text().lstrip().startswith("<?xml")
    r = run("plot", "sparse_row.yaml", "--kind", "workspace", "--out", str(tmp_path / "row.png"))
    assert r.exit_code == 2 and "expected a stationary cell" in r.output and not (tmp_path / "row.png").exists()
    assert run("plot", str(tmp_path / "missing.json")).exit_code == 3
    assert run("plot", str(saved["greenhouse"]), "--kind", "joints", "--arm", "nobody").exit_code == 2
    assert run("plot", str(saved["greenhouse"]), "--out", str(tmp_path / "x.nope")).exit_code == 2
    assert run("plot", str(saved["greenhouse"]), "--kind", "pie").exit_code == 2
    # a name without an ending: the PNG matplotlib writes, named as written (it said "wrote notes" beside
    # the user's own file notes)
    (tmp_path / "notes").write_text("mine")
    r = run("plot", str(saved["greenhouse"]), "--out", str(tmp_path / "notes"))
    assert r.exit_code == 0 and r.output.strip().endswith("notes.png"), r.output
    assert (tmp_path / "notes").read_text() == "mine" and (tmp_path / "notes.png").exists()


def test_cli_animate_and_problem_lookup(tmp_path, saved, greenhouse):
    r = run("animate", str(saved["single"]), "--dpi", "40", "--fps", "5")
    assert r.exit_code == 0, r.output
    assert (saved["single"].parent / "plan.gif").exists()
    # a plan whose problem is not shipped: a clear message, then --problem makes it work
    doc = json.loads(saved["greenhouse"].read_text())
    doc["problem"] = "somewhere-else"
    odd = tmp_path / "odd.json"
    odd.write_text(json.dumps(doc))
    r = run("animate", str(odd))
    assert r.exit_code == 2 and "somewhere-else" in r.output and "--problem" in r.output
    r = run("animate", str(odd), "--problem", str(greenhouse.source), "--out", str(tmp_path / "odd.gif"), "--speed", "4", "--dpi", "40")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "odd.gif").exists()
    r = run("animate", str(odd), "--problem", str(Path(greenhouse.source).with_name("single_arm.yaml")))
    assert r.exit_code == 3 and "does not fit problem" in r.output and "missing ['arm']" in r.output
    assert "single_arm.yaml" in "".join(r.output.split())  # (the problem's file, as the plan's: which --problem)
    # a problem with fewer arms than the plan: refused too (its third arm was left out of the figure)
    for cmd in (["animate"], ["plot", "--kind", "clearance"]):
        r = run(*cmd, str(saved["greenhouse"]), "--problem", str(Path(greenhouse.source).with_name("crossing_paths.yaml")),
                "--out", str(tmp_path / ("x.gif" if cmd[0] == "animate" else "x.png")))
        assert r.exit_code == 3 and "unknown ['center']" in r.output, r.output
    assert run("animate", str(saved["single"]), "--speed", "0").exit_code == 2


def test_gif_frames_equal_full_renders(problems_dir):
    """The GIF writer redraws only what changed; its frames must equal full redraws."""
    from coplan import load_problem
    from coplan.viz.animate import _blit_gif_writer, build_animation

    p = load_problem(problems_dir / "crossing_paths.yaml")  # the heuristic collides: status colours change
    plan = plan_heuristic(p)
    fast = build_animation(p, plan, dpi=40, width=6)
    writer = _blit_gif_writer(10, fast.scene)
    writer.setup(fast.scene.fig, "unused.gif", 40)
    for t in fast.frame_times:
        fast.scene.update(t)
        writer.grab_frame()
    full = build_animation(p, plan, dpi=40, width=6)
    texts = set()
    for k, t in enumerate(full.frame_times):
        full.scene.update(t)
        texts.add(full.scene.status_text.get_text().split(":")[0])
        if k % 9:
            continue
        full.scene.fig.canvas.draw()
        rgb = np.asarray(full.scene.fig.canvas.buffer_rgba())[..., :3].copy()
        ref = Image.fromarray(rgb).quantize(palette=writer._pal, dither=Image.Dither.NONE)
        assert np.array_equal(np.asarray(writer._frames[k]), np.asarray(ref)), f"frame {k} at t = {t:.2f} s"
    assert any(x.startswith("COLLISION") for x in texts) and any(x.startswith("all pairs clear") for x in texts)


def test_gif_fps_is_rounded_to_whole_centiseconds_and_long_plans_speed_up(tmp_path, single_arm):
    plan = plan_heuristic(single_arm)
    said = []
    out = animate_plan(single_arm, plan, tmp_path / "a.gif", fps=12, dpi=30, width=4, notify=said.append)
    with Image.open(out) as im:
        assert im.info["duration"] == 80  # 12.5 fps
    assert any("12.5 fps" in m for m in said)
    said.clear()
    animate_plan(single_arm, plan, tmp_path / "b.gif", fps=10, dpi=30, width=4, max_frames=20, notify=said.append)
    assert len(said) == 1 and "instead of ×1" in said[0]


def test_a_gif_s_frames_fit_its_memory_budget(tmp_path, single_arm, monkeypatch):
    """(Pillow holds every GIF frame until the file is written: --dpi 300 --fps 30 ran out of
    memory.) The frames a GIF may hold are capped by MAX_GIF_BYTES at about 2 bytes per pixel;
    a plan needing more plays faster, and says so."""
    import coplan.viz.animate as anim

    plan = plan_heuristic(single_arm)
    px = (4 * 40) * (anim._extent(single_arm, plan, 4)[2] * 40)
    monkeypatch.setattr(anim, "MAX_GIF_BYTES", int(2.0 * px * 12) + 2)  # room for 12 frames
    said = []
    out = animate_plan(single_arm, plan, tmp_path / "m.gif", fps=10, dpi=40, width=4, notify=said.append)
    assert len(said) == 1 and "within 12 frames of 160 px wide at --dpi 40" in said[0] and "held in memory" in said[0]
    with Image.open(out) as im:
        assert im.n_frames <= 12


def test_the_plotting_api_names_a_plan_of_another_problem(single_arm, greenhouse):
    """(plot_clearance of another problem's plan raised KeyError: 'left'; plot_workspace(plan) an
    AttributeError.) Each plotting function says what it expected and what it found."""
    from coplan.viz import plot_clearance, plot_gantt, plot_joints, plot_workspace

    plan = plan_heuristic(single_arm)
    for fn in (plot_clearance, plot_gantt, plot_joints):
        with pytest.raises(ValueError, match=rf"{fn.__name__}: plan .* does not fit problem .*expected the problem's arms"):
            fn(greenhouse, plan)
        with pytest.raises(TypeError, match=rf"{fn.__name__}: expected a Problem .* found NoneType"):
            fn(None, plan)
    with pytest.raises(TypeError, match="plot_workspace: expected a Problem .* found Plan"):
        plot_workspace(plan)


def test_the_plotting_api_refuses_a_row_plan_over_a_cell_of_the_same_arm_names():
    """(plot_clearance(cell, row_plan) drew -0.08 m "collisions" under a title saying success: the
    arms' names matched.) A row's plan over a cell, a cell's over a row, or a plan picking fruit the
    problem does not have: each plotting function says the plan does not fit, and why."""
    import dataclasses

    from coplan.generate import gantry_row
    from coplan.row.plan import plan_row
    from coplan.viz import plot_clearance, plot_gantt, plot_joints

    row = parse_problem(to_yaml(gantry_row(length=3.0, n_arms=2, density=2.0, seed=1)))
    cell = dataclasses.replace(row, gantry=None)  # the same arms and fruit ids, no carriage
    row_plan = plan_row(row).plan
    cell_plan = plan_heuristic(cell)
    renamed = dataclasses.replace(cell, fruits=tuple(dataclasses.replace(f, id=f"g{i}") for i, f in enumerate(cell.fruits)))
    for fn in (plot_clearance, plot_gantt, plot_joints):
        with pytest.raises(ValueError, match=rf"{fn.__name__}: plan .* does not fit .*a row's \(its carriage moves\)"):
            fn(cell, row_plan)
        with pytest.raises(ValueError, match=rf"{fn.__name__}: plan .* does not fit .*a cell's \(no carriage\)"):
            fn(row, cell_plan)
        with pytest.raises(ValueError, match=rf"{fn.__name__}: plan .* does not fit .*picks fruit the problem does not have"):
            fn(renamed, cell_plan)
        fn(cell, cell_plan)  # its own problem: drawn


def test_coplan_plot_says_matplotlib_s_warnings_as_notes(tmp_path, problems_dir):
    """(A one-sample plan printed matplotlib's UserWarning with its source line, twice.)"""
    r = CliRunner().invoke(app, ["solve", str(problems_dir / "crossing_paths.yaml"), "--planner", "coordinated",
                                 "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    doc["time"] = doc["time"][:1]
    for a in doc["arms"].values():
        a["q"] = a["q"][:1]
    one = tmp_path / "one.json"
    one.write_text(json.dumps(doc))
    r = CliRunner().invoke(app, ["plot", str(one), "--problem", str(problems_dir / "crossing_paths.yaml"), "--kind", "gantt",
                                 "--out", str(tmp_path / "one.png")])
    assert r.exit_code == 0 and (tmp_path / "one.png").exists(), r.output
    assert "UserWarning" not in r.output and "savefig" not in r.output
    assert r.output.count("note: matplotlib: constrained_layout not applied") == 1, r.output


def test_cli_plot_into_a_folder_writes_in_it(tmp_path, saved):
    """(``--out d/`` wrote d.png beside the folder.)"""
    d = tmp_path / "figs"
    d.mkdir()
    r = run("plot", str(saved["greenhouse"]), "--out", str(d))
    assert r.exit_code == 0, r.output
    assert (d / "plan_gantt.png").is_file() and not (tmp_path / "figs.png").exists()
    r = run("plot", str(saved["greenhouse"]), "--kind", "gantt", "--arm", "left", "--out", str(d))  # (ignored, before)
    assert r.exit_code == 2 and "--arm: expected with --kind joints or workspace" in " ".join(r.output.split())


def test_a_rows_figure_titles_say_how_the_carriage_moved_and_the_row_time(tmp_path):
    """(`coplan plot ROW_PLAN --kind gantt` said "coordinated: makespan 77.18 s ..." for a stop
    and go and an on-the-move plan alike.)"""
    from typer.testing import CliRunner

    import coplan
    from coplan.cli import app
    from coplan.generate import gantry_row
    from coplan.viz.plots import plan_title

    d = gantry_row(length=6.0, n_arms=2, density=2.0, seed=3)
    (tmp_path / "row.yaml").write_text(to_yaml(d))
    res = coplan.solve(tmp_path / "row.yaml", out_dir=tmp_path / "run")
    r = res.plan.metrics["row"]
    title = plan_title(res.plan.label, res.plan)
    assert title.startswith(f"coordinated (stop and go, optimised stops): row time {r['row_time']:.2f} s, "
                            f"{r['fruit_per_hour']:.0f} fruit/h"), title
    out = CliRunner().invoke(app, ["plot", str(tmp_path / "run" / "plan.json"), "--kind", "gantt", "--out", str(tmp_path / "g.png")])
    assert out.exit_code == 0 and (tmp_path / "g.png").is_file(), out.output
