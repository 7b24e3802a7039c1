"""A run's files are written as a unit: staged beside the target and renamed into place; the
previous run is kept; a failure leaves neither a partial folder nor a mix of two runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from coplan.output import MARKER, RunFolder, is_run_folder
from coplan.pipeline import solve
from coplan.problem import default_problem_path


def _single():
    return default_problem_path().with_name("single_arm.yaml")


def test_a_second_run_keeps_the_first_as_previous(tmp_path):
    out = tmp_path / "run"
    first = solve(_single(), planner="heuristic", out_dir=out)
    assert first.previous is None and is_run_folder(out) and (out / MARKER).exists()
    stamp = json.loads((out / "plan.json").read_text())["planner"]
    second = solve(_single(), planner="coordinated", out_dir=out)
    assert second.previous == tmp_path / "run.previous"
    assert json.loads((second.previous / "plan.json").read_text())["planner"] == stamp == "heuristic"
    assert json.loads((out / "plan.json").read_text())["planner"] == "coordinated"
    assert all(p.parent == out and p.exists() for p in second.files.values())
    third = solve(_single(), planner="coordinated", out_dir=out)  # only one previous run is kept
    assert json.loads((third.previous / "plan.json").read_text())["planner"] == "coordinated"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "run.previous"]  # no partial folder left


def test_a_failed_write_leaves_the_previous_run_whole_and_no_partial_folder(tmp_path, monkeypatch):
    out = tmp_path / "run"
    solve(_single(), planner="heuristic", out_dir=out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    from coplan.verify import verdict

    def disk_full(self, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(verdict.Verification, "save", disk_full)
    with pytest.raises(OSError):
        solve(_single(), planner="coordinated", out_dir=out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # untouched: the old run, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_folder_with_the_users_own_files_is_not_moved(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    res = solve(_single(), planner="heuristic", out_dir=out)
    assert res.previous is None and (out / "notes.txt").read_text() == "keep me"
    assert (out / "plan.json").exists() and not is_run_folder(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]
    # a second run there: the first run's files go to mine.previous whole, none left beside the
    # new run's (the optimal planner's baseline.* after the heuristic's plan, a live run.json)
    (out / "run.json").write_text("{}")
    first = (out / "plan.json").read_bytes()
    res = solve(_single(), planner="optimal", out_dir=out)
    prev = tmp_path / "mine.previous"
    assert res.previous == prev and (prev / "plan.json").read_bytes() == first and (prev / "run.json").exists()
    assert (out / "notes.txt").read_text() == "keep me" and not (out / "run.json").exists()
    assert (out / "baseline.json").exists() and not (prev / "baseline.json").exists()


def test_staging_folders_are_unique_per_writer(tmp_path):
    a, b = RunFolder(tmp_path / "x"), RunFolder(tmp_path / "x")
    sa, sb = a.__enter__(), b.__enter__()
    assert sa != sb and sa.parent == sb.parent == tmp_path
    a.__exit__(None, None, None)
    b.__exit__(None, None, None)  # the second commit finds the first run and keeps it as previous
    assert is_run_folder(tmp_path / "x") and b.previous == tmp_path / "x.previous"


def test_a_full_disk_is_reported_with_the_path_and_its_own_exit_code(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from coplan.verify import verdict
    from coplan.cli import app

    def disk_full(self, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(verdict.Verification, "save", disk_full)
    r = CliRunner().invoke(app, ["solve", str(_single()), "--planner", "heuristic", "--out", str(tmp_path / "o")])
    assert r.exit_code == 8
    assert "No space left on device" in r.output and "verification.json" in r.output
    assert "Traceback" not in r.output and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("where", [".", ""])
def test_a_run_into_the_folder_coplan_runs_in_replaces_its_files_there(tmp_path, monkeypatch, where):
    """``-o .`` (or ``-o ''``): the current folder is never removed or renamed; a second run
    moves the first one's files to ``<folder>.previous`` and leaves the user's (it stopped with an
    internal error, "PosixPath('.') has an empty name")."""
    here = tmp_path / "here"
    here.mkdir()
    (here / "notes.txt").write_text("keep me")
    monkeypatch.chdir(here)
    first = solve(_single(), planner="coordinated", out_dir=Path(where))
    second = solve(_single(), planner="coordinated", out_dir=Path(where))
    assert first.previous is None and second.previous == tmp_path / "here.previous"
    assert (here / "notes.txt").read_text() == "keep me" and (here / "plan.json").exists()
    assert (tmp_path / "here.previous" / "plan.json").exists() and not (tmp_path / "here.previous" / "notes.txt").exists()


@pytest.mark.parametrize("args", [
    ["solve", "SINGLE", "--planner", "heuristic", "--out", ""],
    ["solve", "SINGLE", "--planner", "heuristic", "--out="],
    ["feed", "SINGLE", "-o", ""],
    ["compare", "SINGLE", "--planner", "heuristic", "-o", ""],
])
def test_an_empty_out_on_the_command_line_is_a_usage_error_not_the_current_folder(tmp_path, monkeypatch, args):
    """``--out "$DIR"`` with ``DIR`` unset: exit 2 before any work, nothing written -- not a run
    into the current folder with the previous one moved beside it (the library's
    ``out_dir=Path('')`` is still the current folder, above)."""
    from typer.testing import CliRunner

    from coplan.cli import app

    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(app, [str(_single()) if a == "SINGLE" else a for a in args])
    assert r.exit_code == 2, r.output
    assert "--out" in r.output and "empty" in r.output and "Traceback" not in r.output
    assert list(tmp_path.iterdir()) == [] and not (tmp_path.parent / (tmp_path.name + ".previous")).exists()


def test_a_folder_that_cannot_take_files_is_named_as_the_user_gave_it_not_the_staging_name(tmp_path, monkeypatch):
    """Where the staging folder cannot be made (``-o /proc/x``: no new files there), the error
    names the path the user gave, not ``.x.<random>.partial``."""
    import tempfile

    from typer.testing import CliRunner

    from coplan.cli import app

    def refuse(prefix="", suffix="", dir=None):
        raise FileNotFoundError(2, "No such file or directory", str(Path(dir) / f"{prefix}abc{suffix}"))

    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    out = tmp_path / "x"
    r = CliRunner().invoke(app, ["solve", str(_single()), "--planner", "heuristic", "--out", str(out)])
    assert r.exit_code == 8, r.output
    assert f"No such file or directory: {out}" in " ".join(r.output.split()) and ".partial" not in r.output


@pytest.mark.parametrize("args", [["solve", "SINGLE", "--planner", "heuristic", "--out", "OUT"],
                                  ["plot", "PLAN", "--out", "OUT.png"],
                                  ["feed", "SINGLE", "--out", "OUT.yaml"],
                                  ["verify", "SINGLE", "PLAN", "--out", "OUT.json"],
                                  # (beside the plan by default: "Read-only file system", exit 8, after the work)
                                  ["view", "WALLED_PLAN"], ["animate", "PLAN", "--out", "OUT.gif"]])
def test_a_folder_that_refuses_new_files_despite_its_permissions_is_a_usage_error_before_any_work(tmp_path, monkeypatch, args):
    """Permission bits do not tell all (root passes ``os.access``; ``/proc`` and read-only
    mounts refuse new files): each command makes and removes a hidden file where it will write,
    before any work, and says so as a usage error (exit 2) naming the path given."""
    import tempfile

    from typer.testing import CliRunner

    from coplan.cli import app
    from coplan.planners.heuristic import plan_heuristic
    from coplan.problem import load_problem

    plan = plan_heuristic(load_problem(_single()))
    plan.save(tmp_path / "p")
    real = tempfile.mkstemp
    walled = tmp_path / "walled"
    plan.save(walled)  # (a plan in a folder that takes no new files: its page goes beside it by default)
    there = sorted(walled.iterdir())

    def mkstemp(prefix="", suffix="", dir=None, **kw):
        if prefix.startswith(".coplan-probe-") and Path(dir) == walled:
            raise OSError(30, "Read-only file system")
        return real(prefix=prefix, suffix=suffix, dir=dir, **kw)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    out = walled / "x"
    sub = {"SINGLE": str(_single()), "PLAN": str(tmp_path / "p" / "plan.json"), "OUT": str(out),
           "OUT.png": f"{out}.png", "OUT.yaml": f"{out}.yaml", "OUT.json": f"{out}.json", "OUT.gif": f"{out}.gif",
           "WALLED_PLAN": str(walled / "plan.json")}
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, [sub.get(a, a) for a in args])
    assert r.exit_code == 2, r.output
    assert "takes no new files (Read-only file system)" in r.output and str(walled) in r.output
    assert sorted(walled.iterdir()) == there


def test_plan_json_verification_json_and_the_viewer_page_are_written_whole_or_not_at_all(tmp_path, monkeypatch):
    """Each goes through ``atomic_text``: a write that fails half-way leaves neither the file nor
    a temporary beside it (they each had their own ``<name>.tmp``, left behind on a failure)."""
    import os

    from coplan.planners.heuristic import plan_heuristic
    from coplan.problem import load_problem
    from coplan.verify import verify
    from coplan.viz.viewer import write_html

    prob = load_problem(_single())
    plan = plan_heuristic(prob)
    ver = verify(prob, plan)
    real = os.fdopen

    class Full:
        def __init__(self, f):
            self.f = f

        def __enter__(self):
            return self

        def __exit__(self, *a):
            self.f.close()

        def write(self, text):
            self.f.write(text[: len(text) // 2])
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fdopen", lambda fd, *a, **k: Full(real(fd, *a, **k)))
    for target, write in ((tmp_path / "a" / "plan.json", lambda: plan.save(tmp_path / "a")),
                          (tmp_path / "b" / "verification.json", lambda: ver.save(tmp_path / "b")),
                          (tmp_path / "c" / "plan.html", lambda: write_html(tmp_path / "c" / "plan.html", prob, plan))):
        with pytest.raises(OSError) as err:
            write()
        assert err.value.strerror == "No space left on device"
        assert list(target.parent.iterdir()) == []


@pytest.mark.parametrize("args", [
    ["solve", "SINGLE", "--planner", "heuristic", "--out", "-"],
    ["export", "PLAN", "--out", "-"],
])
def test_out_dash_is_not_a_file_named_dash(tmp_path, monkeypatch, args):
    """(``--out -`` wrote a file or a folder named '-'.) No command writes its files to stdout:
    exit 2, nothing written."""
    from typer.testing import CliRunner

    from coplan.cli import app

    plan = tmp_path / "p" / "plan.json"
    solve(_single(), planner="heuristic", out_dir=plan.parent)
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(app, [str(_single()) if a == "SINGLE" else str(plan) if a == "PLAN" else a for a in args])
    assert r.exit_code == 2 and "found '-'" in r.output, r.output
    assert not (tmp_path / "-").exists()


def test_a_users_plan_md_is_never_taken_for_a_run_file_and_a_stale_export_moves_with_its_run(tmp_path):
    """(Any name starting 'plan.' or 'baseline.' counted as coplan's: a folder holding only a
    user's plan.md and baseline.xlsx was moved to .previous, and removed by the next run.)"""
    from coplan.problem import load_problem, shipped_problems

    prob = load_problem(next(p for p in shipped_problems() if p.stem == "single_arm"))
    out = tmp_path / "notes"
    out.mkdir()
    (out / "plan.md").write_text("season notes")
    (out / "baseline.xlsx").write_text("x")
    assert not is_run_folder(out)
    for _ in range(2):
        solve(prob, planner="coordinated", out_dir=out)
    assert (out / "plan.md").read_text() == "season notes" and (out / "baseline.xlsx").read_text() == "x"
    (out / "plan_100hz.csv").write_text("t,arm_q1\n")  # what coplan export writes beside the plan
    (out / "plan_100hz.events.csv").write_text("arm,fruit,kind,t_start,t_end\n")  # (and its events: they stayed, stale)
    (out / "plan_1e-05hz.csv").write_text("t,arm_q1\n")  # (a rate Python writes with an exponent: it stayed)
    (out / "plan_gantt.png").write_bytes(b"png")
    (out / "plan_csv_gantt.png").write_bytes(b"png")  # (`coplan plot plan.csv`'s)
    (out / "plan_speed.png").write_bytes(b"png")  # (`plot --kind speed`'s: it stayed, stale)
    (out / "plan_100hz").mkdir()  # (its JSON/YAML folder)
    solve(prob, planner="coordinated", out_dir=out)
    ours = {"plan_100hz.csv", "plan_100hz.events.csv", "plan_1e-05hz.csv", "plan_gantt.png", "plan_csv_gantt.png",
            "plan_speed.png", "plan_100hz"}
    assert not ours & {p.name for p in out.iterdir()}
    prev = out.with_name("notes.previous")
    assert ours | {"plan.json"} <= {p.name for p in prev.iterdir()}
    assert not (prev / "plan.md").exists() and (out / "plan.md").exists()


@pytest.mark.parametrize("theirs", ["folder", "file"])
def test_a_users_file_or_folder_named_like_the_previous_run_is_never_replaced(tmp_path, theirs):
    """(A second run into a folder replaced <out>.previous whatever it held: a user's
    thesis.tex kept there was deleted, a file of that name too, exit 0.)"""
    from typer.testing import CliRunner

    from coplan.cli import app
    from coplan.output import OutputError, RunFolder

    out = tmp_path / "o"
    solve(_single(), planner="heuristic", out_dir=out)
    prev = tmp_path / "o.previous"
    if theirs == "folder":
        prev.mkdir()
        (prev / "thesis.tex").write_text("mine")
    else:
        prev.write_text("mine")
    with pytest.raises(OutputError, match=r"expected coplan's previous run or nothing at .*o\.previous, found"):
        solve(_single(), planner="heuristic", out_dir=out)
    r = CliRunner().invoke(app, ["solve", str(_single()), "--planner", "heuristic", "--out", str(out)])
    assert r.exit_code == 2 and ("thesis.tex" in r.output) == (theirs == "folder"), r.output
    assert (prev / "thesis.tex" if theirs == "folder" else prev).read_text() == "mine"
    # made after the check, before the run's files move: the previous run goes beside it, nothing is removed
    with RunFolder(out) as stage:
        (stage / "plan.json").write_text("{}")
    assert (prev / "thesis.tex" if theirs == "folder" else prev).read_text() == "mine"
    assert (tmp_path / "o.previous.1" / "plan.json").exists() and (out / "plan.json").read_text() == "{}"
    # coplan's own previous run is replaced as before
    (prev / "thesis.tex").unlink() if theirs == "folder" else prev.unlink()
    assert solve(_single(), planner="heuristic", out_dir=out).previous == prev


@pytest.mark.parametrize("users_file", [True, False])
def test_a_commit_that_fails_half_way_leaves_the_previous_run_whole_where_it_was(tmp_path, monkeypatch, users_file):
    """(With one file of the previous run immutable, a second run into a folder holding the
    user's notes moved part of the previous run to .previous and stopped: the folder held the
    user's notes and one old file, .previous the rest -- and the run before that was gone.)"""
    import os as os_mod

    import coplan.output as output

    out = tmp_path / "o"
    solve(_single(), planner="heuristic", out_dir=out)
    solve(_single(), planner="heuristic", out_dir=out)  # an older previous run in o.previous
    if users_file:
        (out / "notes.md").write_text("mine")

    def snapshot(folder):
        return {p.name: p.read_bytes() for p in folder.iterdir()}

    before, older = snapshot(out), snapshot(tmp_path / "o.previous")
    real = os_mod.replace

    def stuck(src, dst):
        if Path(src).name == "verification.json" and Path(src).parent == out:
            raise PermissionError(1, "Operation not permitted", str(src))
        return real(src, dst)

    monkeypatch.setattr(output.os, "replace", stuck)
    if not users_file:  # (the whole folder is renamed: make the new run's rename fail instead)
        real_rename = Path.rename

        def no_rename(self, target):
            if self.name.endswith(".partial"):
                raise PermissionError(1, "Operation not permitted", str(self))
            return real_rename(self, target)

        monkeypatch.setattr(Path, "rename", no_rename)
    with pytest.raises(OSError) as e:
        solve(_single(), planner="coordinated", out_dir=out)
    monkeypatch.undo()
    assert snapshot(out) == before and snapshot(tmp_path / "o.previous") == older
    if users_file:  # the new run, finished and verified, is kept whole beside the folder (it was thrown away)
        assert isinstance(e.value, output.RunKept) and "it is kept whole in" in str(e.value)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "o.previous", "o.unsaved"]
        assert json.loads((tmp_path / "o.unsaved" / "plan.json").read_text())["planner"] == "coordinated"
    else:  # (the stage cannot be renamed at all: nothing to keep it as)
        assert isinstance(e.value, PermissionError)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "o.previous"]  # no staging or set-aside folder left


def test_a_ctrl_c_while_a_run_is_written_is_answered_once_it_is_whole(tmp_path):
    """(Ctrl-C or SIGTERM while solve wrote its files threw the verified plan away -- exit 130,
    the previous run left, though 130 says the incumbent is saved.) Held while the files are
    written, then answered: here a KeyboardInterrupt after the block, the files whole."""
    import signal
    import subprocess
    import sys

    code = ("import os, signal\nfrom pathlib import Path\nfrom coplan.output import RunFolder, signals_deferred\n"
            f"out = Path({str(tmp_path / 'o')!r})\n"
            "try:\n    with signals_deferred(), RunFolder(out) as stage:\n        os.kill(os.getpid(), signal.SIGINT)\n"
            "        (stage / 'plan.json').write_text('{}')\n"
            "except KeyboardInterrupt:\n    print('interrupted after', sorted(p.name for p in out.iterdir()))\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                       preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # the run whole, then Ctrl-C answered (a KeyboardInterrupt)
    assert "interrupted after ['.coplan-run', 'plan.json']" in p.stdout, (p.stdout, p.stderr)
    assert p.returncode == 0 and "Traceback" not in p.stderr



def test_a_held_signals_note_of_the_run_written_goes_with_its_own_interrupt_only(tmp_path):
    """The run a held signal came during is named while the signal is answered, and the
    KeyboardInterrupt its answer raises carries it (``written_run``); nothing of it is left for a
    later, unrelated interrupt (it was: a Ctrl-C while planning, in the same process, was told of
    an earlier run's folder)."""
    import signal

    import coplan.output as o

    out = tmp_path / "o"
    seen = []
    old = signal.signal(signal.SIGINT, lambda s, f: seen.append(list(o.WRITTEN_BEFORE_SIGNAL)))  # answered, no raise
    try:
        folder = o.RunFolder(out)
        with o.signals_deferred(folder), folder as stage:
            signal.raise_signal(signal.SIGINT)
            (stage / "plan.json").write_text("{}")
    finally:
        signal.signal(signal.SIGINT, old)
    assert seen == [[folder]] and o.WRITTEN_BEFORE_SIGNAL == []

    def stop(s, f):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGINT, stop)
    try:
        folder = o.RunFolder(out)
        with pytest.raises(KeyboardInterrupt) as got:
            with o.signals_deferred(folder), folder as stage:
                signal.raise_signal(signal.SIGINT)
                (stage / "plan.json").write_text("{}")
        assert got.value.written_run is folder and (out / "plan.json").exists()
        assert o.WRITTEN_BEFORE_SIGNAL == []
        from coplan.cli.failures import failure_of

        assert failure_of(got.value)[1].endswith(f"it came as the run's files were written: they are whole, in {out} "
                                                 f"(the previous run kept in {folder.previous})")
        assert failure_of(KeyboardInterrupt())[1] == "interrupted by the user (Ctrl-C)"  # a later one: no note
    finally:
        signal.signal(signal.SIGINT, old)


def test_what_coplan_made_of_a_runs_baseline_moves_with_the_run(tmp_path):
    """(A second run left baseline_100hz.csv, baseline_gantt.png, baseline.html and baseline.gif
    of the first beside its own baseline.json: files of another problem, looking current.)"""
    out = tmp_path / "run"
    solve(_single(), planner="heuristic", out_dir=out)
    made = ["baseline_100hz.csv", "baseline_12.5hz.csv", "baseline_gantt.png", "baseline.html", "baseline.gif", "plan_0.5hz.csv"]
    for name in made:
        (out / name).write_text("made by coplan from the first run")
    (out / "baseline.xlsx").write_text("mine")  # (the user's: stays)
    second = solve(_single(), planner="coordinated", out_dir=out)
    assert all((second.previous / name).exists() and not (out / name).exists() for name in made)
    assert (out / "baseline.xlsx").read_text() == "mine"


def test_a_writable_folder_in_a_folder_that_is_not_takes_the_run_inside_it(tmp_path, monkeypatch):
    """(``--out p/run``, p/run writable and p not: the solve -- and a whole live run -- did its
    work, then failed with "Permission denied", exit 8, the result lost: the run is staged beside
    its folder, and the previous run kept there.) The run is staged inside the folder and written
    there; a folder that holds a previous run, which would then have nowhere to go, is refused
    before any work, exit 2."""
    import tempfile

    from typer.testing import CliRunner

    from coplan.cli import app

    walled = tmp_path / "walled"
    (walled / "run").mkdir(parents=True)
    real_stemp, real_dtemp = tempfile.mkstemp, tempfile.mkdtemp

    def refused(d):
        return d is not None and Path(d).resolve() == walled.resolve()

    def mkstemp(prefix="", suffix="", dir=None, **kw):
        if refused(dir):
            raise PermissionError(13, "Permission denied", str(dir))
        return real_stemp(prefix=prefix, suffix=suffix, dir=dir, **kw)

    def mkdtemp(prefix=None, suffix=None, dir=None):
        if refused(dir):
            raise PermissionError(13, "Permission denied", str(dir))
        return real_dtemp(prefix=prefix, suffix=suffix, dir=dir)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    monkeypatch.setattr(tempfile, "mkdtemp", mkdtemp)
    runner = CliRunner(env={"COLUMNS": "300"})
    out = walled / "run"
    r = runner.invoke(app, ["solve", str(_single()), "--planner", "coordinated", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert {"plan.json", "verification.json", MARKER} <= {p.name for p in out.iterdir()}
    assert sorted(p.name for p in walled.iterdir()) == ["run"] and not [p for p in out.iterdir() if p.name.endswith(".partial")]
    # a live run into a fresh folder there (its scratch folder is made elsewhere)
    feed = tmp_path / "feed.yaml"
    assert runner.invoke(app, ["feed", str(_single()), "--out", str(feed)]).exit_code == 0
    (walled / "live").mkdir()
    r = runner.invoke(app, ["run", str(_single()), "--feed", str(feed), "--out", str(walled / "live")])
    assert r.exit_code == 0, r.output
    assert {"plan.json", "run.json", "verification.json"} <= {p.name for p in (walled / "live").iterdir()}
    # again into the folder that now holds a run: nowhere to keep it, refused before any work
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    r = runner.invoke(app, ["solve", str(_single()), "--planner", "coordinated", "--out", str(out)])
    said = " ".join(r.output.split())
    assert r.exit_code == 2 and "it holds a previous run, which a run there keeps as" in said and "is not writable" in said, said
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert "lower bound" not in said  # (refused before any work)


def test_a_finished_run_that_cannot_be_moved_into_place_is_kept_whole_beside_it(tmp_path, monkeypatch):
    """(On Windows a folder with a file open in it cannot be renamed: the previous run could not
    be moved aside, and the finished solve was thrown away, exit 8.) The previous run stays where
    it was; the new one is kept whole as <out>.unsaved, and the message says so."""
    from typer.testing import CliRunner

    from coplan.cli import app

    out = tmp_path / "run"
    assert CliRunner().invoke(app, ["solve", str(_single()), "--planner", "heuristic", "--out", str(out)]).exit_code in (0, 6)
    before = (out / "plan.json").read_bytes()
    real = Path.rename

    def busy(self, target):
        if Path(self) == out:  # (the previous run's folder: a file in it is open elsewhere)
            raise PermissionError(13, "Access is denied", str(self))
        return real(self, target)

    monkeypatch.setattr(Path, "rename", busy)
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["solve", str(_single()), "--planner", "coordinated", "--out", str(out)])
    said = " ".join(r.output.split())
    assert r.exit_code == 8 and f"it is kept whole in {tmp_path / 'run.unsaved'}" in said, said
    assert (out / "plan.json").read_bytes() == before
    assert json.loads((tmp_path / "run.unsaved" / "plan.json").read_text())["planner"] == "coordinated"


def test_a_stage_that_will_not_go_once_the_run_is_in_place_is_no_failure(tmp_path, monkeypatch):
    """(Every file moved in, only the empty staging folder's removal refused: the run was said
    to be "kept whole in <out>.unsaved", an empty folder, exit 8.)"""
    from typer.testing import CliRunner

    from coplan.cli import app

    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("mine")  # (a folder with the user's file: committed file by file)
    real = Path.rmdir

    def stuck(self):
        if self.name.endswith(".partial"):
            raise PermissionError(13, "Access is denied", str(self))
        return real(self)

    monkeypatch.setattr(Path, "rmdir", stuck)
    r = CliRunner().invoke(app, ["solve", str(_single()), "--planner", "coordinated", "--out", str(out)])
    assert r.exit_code == 0 and (out / "plan.json").is_file() and not (tmp_path / "run.unsaved").exists(), r.output


@pytest.mark.parametrize("command, name", [("view", "page.html"), ("plot", "fig.png"), ("animate", "film.gif")])
def test_a_figure_command_never_overwrites_a_file_of_another_kind(tmp_path, command, name):
    """(view, animate and plot replaced any file given as --out: a user's notes in my.html were
    lost, where feed, verify and export refuse.) Exit 2, the file kept; an earlier figure of the
    same kind is replaced."""
    from typer.testing import CliRunner

    from coplan.cli import app

    plan = tmp_path / "p" / "plan.json"
    solve(_single(), planner="heuristic", out_dir=plan.parent)
    mine = tmp_path / name
    mine.write_text("my notes")
    args = [command, str(plan), "--out", str(mine)] + (["--fps", "2", "--dpi", "30"] if command == "animate" else [])
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, args)
    assert r.exit_code == 2 and "it would be overwritten" in r.output, r.output
    assert mine.read_text() == "my notes"
    mine.unlink()
    for _ in range(2):  # a new file, then the earlier one of its kind replaced
        r = CliRunner(env={"COLUMNS": "300"}).invoke(app, args)
        assert r.exit_code == 0, r.output


def test_view_out_a_folder_writes_the_page_in_it(tmp_path):
    """(view --out DIR was refused, where verify and export write into a folder.)"""
    from typer.testing import CliRunner

    from coplan.cli import app

    plan = tmp_path / "p" / "plan.json"
    solve(_single(), planner="heuristic", out_dir=plan.parent)
    (tmp_path / "pages").mkdir()
    r = CliRunner().invoke(app, ["view", str(plan), "--out", str(tmp_path / "pages")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "pages" / "plan.html").read_text().count('content="coplan viewer"') == 1


def test_a_run_into_a_symlinked_folder_goes_where_the_link_points_and_keeps_the_link(tmp_path):
    """(``--out link``, link -> an empty folder: all the work, then "Not a directory: the run could
    not be moved into link", exit 8, the run in link.unsaved; link -> a folder with a run: the
    user's link renamed link.previous and a real folder link/ made beside it.)"""
    import os

    real = tmp_path / "real"
    real.mkdir()
    link = tmp_path / "link"
    os.symlink(real, link)
    for run in ("first", "second"):
        with RunFolder(link) as stage:
            (stage / "plan.json").write_text(run)
        assert link.is_symlink() and os.readlink(link) == str(real)
        assert (real / "plan.json").read_text() == run
    assert (tmp_path / "real.previous" / "plan.json").read_text() == "first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real", "real.previous"]


def test_a_symlinked_out_is_checked_where_it_points_and_a_loop_refused_before_the_work(tmp_path):
    """(``--out loop`` with a link to itself: "internal error (RuntimeError): Symlink loop" after the
    work, the plan lost; and the checks before the work looked at the link, not where the run goes.)"""
    import os

    from typer.testing import CliRunner

    from coplan.cli import app
    from coplan.output import OutputError, check_folder

    loop = tmp_path / "loop"
    os.symlink(loop, loop)
    with pytest.raises(OutputError, match="symbolic link that does not resolve"):
        check_folder(loop)
    r = CliRunner().invoke(app, ["solve", "single_arm", "--planner", "coordinated", "--out", str(loop)])
    assert r.exit_code == 2 and "does not resolve" in r.output, r.output
    real = tmp_path / "real"
    with RunFolder(real) as stage:
        (stage / "plan.json").write_text("{}")
    (tmp_path / "real.previous").mkdir()
    (tmp_path / "real.previous" / "mine.txt").write_text("mine")
    link = tmp_path / "link"
    os.symlink(real, link)
    for out in (real, link):  # (the same refusal, whichever name the run is given)
        with pytest.raises(OutputError, match="which would replace what is there"):
            check_folder(out)


def test_atomic_texts_puts_nothing_in_place_when_its_check_refuses_and_names_a_rename_that_fails(tmp_path):
    from coplan.output import atomic_texts

    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old")

    def refuse():
        raise RuntimeError("changed")

    with pytest.raises(RuntimeError):
        atomic_texts([(a, "new"), (b, "new")], before=refuse)
    assert a.read_text() == "old" and not b.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]
    b.mkdir()  # (a folder where a file goes: the rename fails, named, with what went in before it)
    with pytest.raises(OSError) as e:
        atomic_texts([(a, "new"), (b, "new")])
    assert e.value.filename == str(b) and "put in place before it: a.txt" in str(e.value)
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".partial")]


def test_an_unreadable_problem_file_exits_with_the_io_code_as_an_unreadable_plan_does(tmp_path, monkeypatch):
    """(From a user's trial: a problem file the user may not read exited 3, "bad input" -- fix its
    contents -- where an unreadable plan exits 8, as the exit-code table says of permissions.)"""
    from typer.testing import CliRunner

    from coplan.cli import app
    from coplan.problem import yamlsafe

    path = tmp_path / "p.yaml"
    path.write_text(_single().read_text())

    def denied(file, mode="r", *args, **kwargs):
        if Path(file) == path:
            raise PermissionError(13, "Permission denied", str(file))
        return open(file, mode, *args, **kwargs)

    monkeypatch.setattr(yamlsafe, "open", denied, raising=False)
    for cmd in (["check", str(path)], ["solve", str(path), "--out", str(tmp_path / "o")]):
        r = CliRunner().invoke(app, cmd)
        assert r.exit_code == 8 and "expected a readable file, found an error: Permission denied" in r.output, r.output
    r = CliRunner().invoke(app, ["check", str(path), "--json"])
    assert r.exit_code == 8 and json.loads(r.stdout)["error"] == "io_error"


def test_an_out_ending_with_a_separator_is_a_folder_for_every_command(tmp_path):
    """(From a user's trial: ``plot -o new/`` wrote new.png, ``plot -o a/sub/`` a/sub.png, ``view
    -o new/`` was refused as no .html name, while export and verify wrote into the folder.)"""
    from typer.testing import CliRunner

    from coplan.cli import app

    run = CliRunner().invoke
    assert run(app, ["solve", str(_single()), "--planner", "coordinated", "--out", str(tmp_path / "o")]).exit_code == 0
    plan = str(tmp_path / "o" / "plan.json")
    for cmd, made in ((["plot", plan, "-o", f"{tmp_path}/new/"], "new/plan_gantt.png"),
                      (["plot", plan, "-o", f"{tmp_path}/a/sub/"], "a/sub/plan_gantt.png"),
                      (["view", plan, "-o", f"{tmp_path}/page/"], "page/plan.html"),
                      (["export", plan, "-o", f"{tmp_path}/ex/"], "ex/plan_100hz.csv"),
                      (["animate", plan, "-o", f"{tmp_path}/anim/"], "anim/plan.gif")):
        r = run(app, cmd)
        assert r.exit_code == 0 and (tmp_path / made).is_file(), (cmd, r.output)
    assert not (tmp_path / "new.png").exists() and not (tmp_path / "a" / "sub.png").exists()
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["export", plan, "-o", "-"])
    assert r.exit_code == 2 and "a command with --json prints its summary on stdout" in " ".join(r.output.split()), r.output
