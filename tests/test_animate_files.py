"""`coplan animate` never leaves a partial file, never overwrites a file the user did not name,
and writes MP4 without a system ffmpeg (the imageio-ffmpeg wheel's binary)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from PIL import Image

from coplan.planners.heuristic import plan_heuristic
from coplan.viz import animate as anim_mod
from coplan.viz.animate import RenderError, animate_plan, ffmpeg_available


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if "partial" in p.name)


def test_ctrl_c_while_writing_leaves_no_partial_file_and_the_old_file_whole(tmp_path, single_arm, monkeypatch):
    target = tmp_path / "one.gif"
    target.write_bytes(b"the previous animation")

    def interrupted_save(self, fp, *args, **kwargs):
        Path(fp).write_bytes(b"GIF89a half written")  # the encoder had started
        raise KeyboardInterrupt

    monkeypatch.setattr(Image.Image, "save", interrupted_save)
    with pytest.raises(KeyboardInterrupt):
        animate_plan(single_arm, plan_heuristic(single_arm), target, fps=5, dpi=30, width=4)
    assert leftovers(tmp_path) == []
    assert target.read_bytes() == b"the previous animation"


def test_any_failure_leaves_no_partial_file(tmp_path, single_arm, monkeypatch):
    def broken_save(self, fp, *args, **kwargs):
        Path(fp).write_bytes(b"GIF89a")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Image.Image, "save", broken_save)
    # a full disk is an I/O error naming the file (it was a render failure, exit 1)
    with pytest.raises(OSError, match="No space left") as e:
        animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "one.gif", fps=5, dpi=30, width=4)
    assert e.value.errno == 28 and e.value.filename == str(tmp_path / "one.gif") and not isinstance(e.value, RenderError)
    assert list(tmp_path.iterdir()) == []

    def encoder_broke(self, fp, *args, **kwargs):
        raise ValueError("bad frame")

    monkeypatch.setattr(Image.Image, "save", encoder_broke)
    with pytest.raises(RenderError, match="bad frame"):
        animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "one.gif", fps=5, dpi=30, width=4)
    assert list(tmp_path.iterdir()) == []


def test_ffmpeg_stopped_by_the_groups_ctrl_c_is_an_interruption_not_a_render_failure(tmp_path, single_arm, monkeypatch):
    """(Ctrl-C on ``coplan animate --out a.mp4`` reached ffmpeg too, which exited 255: the command
    said it could not render the animation, exit 1, not 130.)"""
    import subprocess

    from matplotlib.animation import Animation

    def ffmpeg_interrupted(self, *args, **kwargs):
        # (a real ffmpeg is stopped after the first frames are drawn: say so, or matplotlib warns
        # "Animation was deleted without rendering anything" when this one is collected)
        self._draw_was_started = True
        raise subprocess.CalledProcessError(255, ["ffmpeg", "-f", "rawvideo"])

    monkeypatch.setattr(Animation, "save", ffmpeg_interrupted)
    with pytest.raises(KeyboardInterrupt):
        animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "a.gif", fps=5, dpi=30, width=4)
    assert list(tmp_path.iterdir()) == []


def test_mp4_fallback_never_overwrites_a_gif_the_user_did_not_name(tmp_path, single_arm, monkeypatch):
    monkeypatch.setattr(anim_mod, "ffmpeg_available", lambda: False)
    mine = tmp_path / "one.gif"
    mine.write_bytes(b"my own gif")
    with pytest.raises(RenderError, match="not overwritten"):
        animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "one.mp4", dpi=30, width=4, notify=lambda m: None)
    assert mine.read_bytes() == b"my own gif"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.gif"]


def test_mp4_without_a_system_ffmpeg_uses_the_wheels_binary(tmp_path, single_arm, monkeypatch):
    import imageio_ffmpeg
    import matplotlib

    monkeypatch.setenv("PATH", str(tmp_path / "empty-bin"))  # no system ffmpeg, whatever the machine has
    monkeypatch.setitem(matplotlib.rcParams, "animation.ffmpeg_path", "ffmpeg")
    assert shutil.which("ffmpeg") is None
    assert ffmpeg_available()
    assert matplotlib.rcParams["animation.ffmpeg_path"] == imageio_ffmpeg.get_ffmpeg_exe()
    said: list[str] = []
    out = animate_plan(single_arm, plan_heuristic(single_arm), tmp_path / "one.mp4", fps=5, dpi=30, width=4, notify=said.append)
    assert out == tmp_path / "one.mp4" and said == []
    head = out.read_bytes()[:12]
    assert head[4:8] == b"ftyp"  # an ISO media (MP4) file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.mp4"]


def test_cli_refuses_the_fallback_over_an_existing_gif_as_a_usage_error(tmp_path, single_arm, monkeypatch):
    from typer.testing import CliRunner

    from coplan.cli import app
    from coplan.kinds import ExitCode

    monkeypatch.setattr(anim_mod, "ffmpeg_available", lambda: False)
    plan = plan_heuristic(single_arm).save(tmp_path)["json"]
    (tmp_path / "movie.gif").write_bytes(b"mine")
    res = CliRunner().invoke(app, ["animate", str(plan), "--problem", str(single_arm.source), "--out",
                                   str(tmp_path / "movie.mp4"), "--dpi", "30"])
    assert res.exit_code == ExitCode.USAGE, res.output
    assert "not overwritten" in res.stderr and (tmp_path / "movie.gif").read_bytes() == b"mine"


def test_a_folder_that_takes_no_files_is_said_as_the_user_named_it_before_any_frame_is_drawn(tmp_path, single_arm, monkeypatch):
    """``-o /proc/x.gif``: the error names the path given, not the hidden staging file, and no
    animation is built (matplotlib's 'deleted without rendering' warning never shows)."""
    import tempfile
    import warnings

    def refuse(prefix="", suffix="", dir=None):
        raise FileNotFoundError(2, "No such file or directory", str(Path(dir) / f"{prefix}abc{suffix}"))

    built = []
    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    monkeypatch.setattr(anim_mod, "build_animation", lambda *a, **k: built.append(1))
    target = tmp_path / "x.gif"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(OSError) as err:
            animate_plan(single_arm, plan_heuristic(single_arm), target, fps=5, dpi=30, width=4)
    assert err.value.filename == str(target) and ".partial" not in str(err.value) and built == []


def test_animate_plan_names_a_bad_argument_before_any_work(tmp_path):
    """(From a trial: speed="2" and fps="10" raised comparisons between str and int, dpi=0 an
    overflow, max_frames=0 a ZeroDivisionError, swapped arguments an AttributeError.)"""
    import coplan
    from coplan.viz.animate import RenderError, animate_plan

    r = coplan.solve("single_arm", planner="heuristic")
    for kw, words in (({"speed": "2"}, "speed factor"), ({"fps": "10"}, "frames per second"), ({"dpi": 0}, "dpi from 10"),
                      ({"width": 0}, "width from 1"), ({"max_frames": 0}, "max_frames")):
        with pytest.raises(RenderError, match=words):
            animate_plan(r.problem, r.plan, tmp_path / "a.gif", **kw)
    with pytest.raises(TypeError, match=r"animate_plan: expected \(problem: Problem, plan: Plan, out_path\)"):
        animate_plan(r.plan, r.problem, tmp_path / "a.gif")
    assert not list(tmp_path.iterdir())
