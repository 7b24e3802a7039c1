"""The ``coplan feed`` and ``coplan run`` commands (registered in :mod:`coplan.cli`).

Imports only typer, rich and the enums at module level: ``import coplan.cli`` stays light;
NumPy, the planners and matplotlib are imported inside the commands.
"""

from __future__ import annotations

import contextlib
import json
import math
import re
from pathlib import Path
from typing import Annotated, Optional

import typer

from .checks import FolderOut, between, choice, choices, in_path, out_path, real, whole
from .console import ProgressDisplay, text_console
from .failures import check_out_dir, check_out_file, check_overwrite, exit_fields, resolve_problem, usage, work_done
from .summary import safe as _safe, tucked_text
from ..errors import plural
from ..kinds import GantryMode, LiveGantryMode, PlanStatus

__all__ = ["feed_cmd", "run_cmd"]

_out = text_console()
_err = text_console(stderr=True)


def feed_cmd(
    problem: Annotated[Path, typer.Argument(parser=in_path, metavar="PROBLEM", help="Problem file (YAML) with the true fruit, or a shipped problem's name.")],
    out: Annotated[Path, typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Feed file to write (YAML).")],
    known: Annotated[float, typer.Option(parser=real, metavar="<float>", callback=between(0.0, 1.0), help="Share of the fruit detected at t = 0.")] = 0.5,
    sigma: Annotated[float, typer.Option(parser=real, metavar="<float>", callback=between(1e-6, 1.0, "m"), help="Detection noise: standard deviation per coordinate, m.")] = 0.01,
    false_rate: Annotated[float, typer.Option("--false-rate", parser=real, metavar="<float>", callback=between(0.0, 1.0),
                                              help="Chance that a detection comes with a false one.")] = 0.0,
    duplicate_rate: Annotated[float, typer.Option("--duplicate-rate", parser=real, metavar="<float>", callback=between(0.0, 1.0),
                                                  help="Chance that a fruit is detected a second time.")] = 0.0,
    seed: Annotated[int, typer.Option(parser=whole, metavar="<int>", callback=between(0), help="Random seed (the same seed gives the same feed).")] = 0,
    reveal_by: Annotated[Optional[float], typer.Option("--reveal-by", parser=real, metavar="<float>", callback=between(0.001, unit="s"), help="Late fruit arrive by this time, s "
                                                       "(default: half the makespan lower bound).")] = None,
    after_pick: Annotated[float, typer.Option("--after-pick", parser=real, metavar="<float>", callback=between(0.0, 1.0),
                                              help="Share of the late fruit hidden behind a neighbour until it is picked.")] = 0.25,
    # (the ranges of coplan.live.feed.CLOSE_RANGE_BOUNDS, a feed file's; not imported: --help stays quick)
    close_sigma: Annotated[float, typer.Option("--close-sigma", parser=real, metavar="<float>", callback=between(1e-6, 0.1, "m"),
                                               help="Close-range (gripper camera) noise, m.")] = 0.001,
    close_distance: Annotated[float, typer.Option("--close-distance", parser=real, metavar="<float>", callback=between(0.005, 1.0, "m"),
                                                  help="The gripper camera measures when the tip is this close, m.")] = 0.1,
):
    """Generate a seeded vision feed for a problem: late fruit, noise, false and duplicate detections."""
    from ..problem.load import load_problem
    from ..live.feed import feed_yaml, make_feed
    from ..output import atomic_text

    if isinstance(out, FolderOut):  # (given as new/: it wrote a file named new)
        usage(f"--out {_safe(str(out))}/: expected a feed file name (YAML), found a folder name")
    check_out_file(out)
    check_overwrite(out, "a coplan.feed file", "an earlier feed")  # (a problem, a plan: never overwritten by a typo)
    prob = load_problem(resolve_problem(problem, lambda m: _err.print(f"[dim]{_safe(m)}[/]", highlight=False)))
    if prob.gantry is not None:
        usage(f"{prob.name} is a row (it has a gantry): a feed file is for a stationary cell; a live row simulates its "
              f"own camera -- 'coplan run {_safe(str(problem or 'ROW'))} --speed V' (on the move) or '--gantry stop-and-go' "
              "(--look-ahead, --sigma, --false-rate, --seed set it)")
    if reveal_by is not None:
        from ..problem.plausible import latest_report_time

        last, why = latest_report_time(prob)
        if reveal_by > last:
            usage(f"--reveal-by: expected a time of at most {math.floor(last * 10) / 10:g} s ({why}), found {reveal_by!r}")
    feed = make_feed(prob, known, sigma, false_rate, duplicate_rate, seed, reveal_by, after_pick, close_distance, close_sigma)
    made = not out.parent.exists()  # (it made /nonexistent/dir at the root without a word)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_text(out, feed_yaml(feed))
    if made:
        _err.print(f"note: made the folder {_safe(out.parent)} for it", highlight=False)
    n_false = sum(d.fruit is None for d in feed.detections)
    n_late = sum(d.t > 0 or d.after is not None for d in feed.detections)
    _out.print(f"wrote {_safe(out)}: {plural(len(feed.detections), 'detection')} of {len(prob.fruits)} fruit "
               f"({n_late} after t = 0, {n_false} false), sigma {sigma * 1000:g} mm, seed {seed}", highlight=False)


def _staged(stage: Path) -> list[str]:
    """The files a run staged (its hidden marker left out), by name: read before they move, so
    that the summary names these and not the other files of a folder it writes into."""
    return sorted(p.name for p in Path(stage).iterdir() if p.is_file() and not p.name.startswith("."))


def _written(folder, names: list[str]) -> str:
    """``names`` and where the previous run was kept, if it was moved (``folder``: the
    :class:`RunFolder`, after its exit)."""
    kept = f"; previous run kept in {folder.previous}" if folder.previous is not None else ""
    return _safe(", ".join(names) + kept)


def run_cmd(
    problem: Annotated[Path, typer.Argument(parser=in_path, metavar="PROBLEM", help="Problem file (YAML) with the true fruit positions, or a shipped problem's name.")],
    feed: Annotated[Optional[Path], typer.Option("--feed", "-f", help="Feed file (YAML): what the camera reports "
                                                 "(a cell; a row's camera is simulated from the options below).")] = None,
    out: Annotated[Path, typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Output folder.")] = Path("coplan-live"),
    speed: Annotated[Optional[str], typer.Option(metavar="<float>|auto", help="A row: the carriage's cruising speed, m/s "
                                                 "(picks on the move), or auto: the constant speed the offline speed "
                                                 "search chooses for the row (every harvestable fruit, the most fruit per hour).")] = None,
    gantry: Annotated[Optional[LiveGantryMode], typer.Option(
        parser=choice(LiveGantryMode), metavar=choices(LiveGantryMode), help="A row: continuous (picks on the move at --speed, a number or auto, which it needs; the default) or stop-and-go (stops "
             "chosen as fruit come into view).")] = None,
    look_ahead: Annotated[float, typer.Option("--look-ahead", parser=real, metavar="<float>", callback=between(0.0, 100.0, "m", above=True),
                                              help="A row: how far ahead of the front arm's base the camera sees, m.")] = 1.5,
    sigma: Annotated[float, typer.Option(parser=real, metavar="<float>", callback=between(0.0, 1.0, "m"), help="A row: detection noise per coordinate, m.")] = 0.01,
    false_rate: Annotated[float, typer.Option("--false-rate", parser=real, metavar="<float>", callback=between(0.0, 1.0),
                                              help="A row: false reports, as a share of the fruit.")] = 0.05,
    duplicate_rate: Annotated[float, typer.Option("--duplicate-rate", parser=real, metavar="<float>", callback=between(0.0, 1.0),
                                                  help="A row: share of fruit reported twice.")] = 0.02,
    arm_stop: Annotated[bool, typer.Option("--arm-stop", help="A row: one arm (drawn from --seed) reports a controller "
                                           "fault at a drawn time: it finishes its motion and stays, an obstacle.")] = False,
    camera_dark: Annotated[float, typer.Option("--camera-dark", parser=real, metavar="<float>", callback=between(0.0, 3600.0, "s"),
                                               help="A row: seconds the camera reports nothing, at a drawn time.")] = 0.0,
    false_burst: Annotated[int, typer.Option("--false-burst", parser=whole, metavar="<int>", callback=between(0, 1000),  # row.sensing.MAX_FALSE_BURST (numpy: not at import)
                                             help="A row: false reports at one drawn instant, within the camera's view.")] = 0,
    late_replan: Annotated[float, typer.Option("--late-replan", parser=real, metavar="<float>", callback=between(0.0, 3600.0, "s"),
                                               help="A row: seconds one decision (at a drawn time) runs late.")] = 0.0,
    animate: Annotated[bool, typer.Option("--animate", help="A cell: also write live.gif: fruit appearing, re-plans, misses.")] = False,
    seed: Annotated[int, typer.Option(parser=whole, metavar="<int>", callback=between(0), help="Seed of the simulation: a cell's close-range measurements; a row's "
                                      "camera reports, faults and close-range measurements.")] = 0,
    horizon: Annotated[float, typer.Option(parser=real, metavar="<float>", callback=between(0.0, 10.0, "s", above=True), help="A cell: commit horizon, s (at least the re-planning latency).")] = 0.1,
    all_candidates: Annotated[bool, typer.Option("--all-candidates", help="A cell: every re-plan tries every candidate plan, "
                                                 "not only those its work budget allows (100 conflict checks).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the metrics as JSON.")] = False,
):
    """Simulate a cell or a row live: re-plan as detections arrive, verify what was executed, compare with the omniscient plan."""
    from ..problem.load import load_problem

    check_out_dir(out, "--out")
    prob = load_problem(resolve_problem(problem, lambda m: _err.print(f"[dim]{_safe(m)}[/]", highlight=False)))
    if prob.gantry is not None:
        from ..row.live import RowFaults

        cell_only = [name for name, given in (("--animate", animate), ("--horizon", horizon != 0.1),
                                              ("--all-candidates", all_candidates)) if given]
        if cell_only:
            usage(f"{', '.join(cell_only)}: {prob.name} is a row (it has a gantry section); "
                  f"{'this applies' if len(cell_only) == 1 else 'these apply'} to a stationary cell's live run"
                  + (" (a row's executed plan is animated by coplan animate, or seen in coplan view, on the plan.json "
                     "it writes)" if animate else ""))

        faults = RowFaults(arm_stop, camera_dark, false_burst, late_replan)
        return _run_row(prob, out, feed, speed, gantry, look_ahead, sigma, false_rate, duplicate_rate, seed, as_json, faults)
    from ..row.sensing import LiveRowOptions

    d = LiveRowOptions()  # (the row options' defaults: what a cell run leaves as they are)
    row_only = [name for name, given in (("--speed", speed is not None), ("--gantry", gantry is not None),
                                         ("--look-ahead", look_ahead != d.look_ahead), ("--sigma", sigma != d.sigma),
                                         ("--false-rate", false_rate != d.false_rate),
                                         ("--duplicate-rate", duplicate_rate != d.duplicate_rate),
                                         ("--arm-stop", arm_stop), ("--camera-dark", camera_dark > 0),
                                         ("--false-burst", false_burst > 0), ("--late-replan", late_replan > 0)) if given]
    if row_only:
        usage(f"{', '.join(row_only)}: {prob.name} is a stationary cell (no gantry section); these apply to a row "
              "(a cell's camera is its --feed file: coplan feed makes one, with its own noise and false detections)")
    _run_cell(prob, feed, out, horizon, all_candidates, animate, seed, as_json)


def _run_cell(prob, feed: Path, out: Path, horizon: float, all_candidates: bool, animate: bool, seed: int,
              as_json: bool) -> None:
    """``coplan run`` on a stationary cell: simulate the feed, write the run's files whole, say what
    happened (exits with the run's code)."""
    from ..output import RunFolder, signals_deferred
    from ..plan import jsonable
    from ..problem.load import file_record
    from ..live.cell import LiveOptions
    from ..live.feed import load_feed
    from ..live.sim import simulate
    from ..pipeline import status_exit_code

    if feed is None:
        usage(f"{prob.name} is a stationary cell: give its camera's reports with --feed FEED (coplan feed makes one)")
    fd = load_feed(feed)
    if fd.detections and prob.reachable_ids() and all(d.fruit is None for d in fd.detections):
        # (a camera's own file has no truth: every detection then counts as false, and nothing is harvested)
        _err.print(f"[yellow]note[/]: no detection of {_safe(feed)} names its true fruit (detections[].fruit): the "
                   "simulation counts every one as a false detection, so no fruit can be harvested; give each its "
                   "fruit id, or null for a false one (coplan feed writes them)", highlight=False)
    if fd.problem is not None and fd.problem != prob.name:
        _err.print(f"[yellow]note[/]: the feed was made for problem {_safe(fd.problem)!r}, this is {_safe(prob.name)!r}",
                   highlight=False)
    # (a detection 5.8 m from the fruit it names, hundreds of its sigma, was taken without a word: a
    # mislabelled feed, whose fruit then reads "unreachable")
    truth = {f.id: f.position for f in prob.fruits}
    off_by = [(d, math.dist(d.position, truth[d.fruit])) for d in fd.detections if d.fruit in truth]
    far = [(d, off) for d, off in off_by if off > max(0.1, 10 * d.sigma)]
    if far:
        d, off = max(far, key=lambda x: x[1])
        _err.print(f"[yellow]note[/]: {plural(len(far), 'detection')} of {_safe(feed)} lie more than 10 sigma and 0.1 m "
                   f"from the fruit they name (the farthest, {_safe(d.id)}{f' at line {d.line}' if d.line else ''}, "
                   f"{off:.2f} m from {_safe(d.fruit)}): is the feed labelled for this problem?", highlight=False)
    opts = LiveOptions(horizon=horizon, work=None) if all_candidates else LiveOptions(horizon=horizon)
    with ProgressDisplay(_err, quiet=as_json) as bars, _nothing_written(out):
        result = simulate(prob, fd, opts, seed=seed, progress=bars)
    result.plan.problem_file = file_record(prob)
    import shutil
    import tempfile

    from ..output import writable_folder

    near = Path(out).resolve().parent
    beside = near if near.is_dir() and writable_folder(near) else None  # (it failed the run at its end where it may not write)
    with tempfile.TemporaryDirectory(dir=beside) as tmp:  # (beside the run: its disk)
        if animate:  # (drawn first, where a Ctrl-C stops it: the run then writes nothing, as at any other time)
            from ..live.animate import animate_live

            with _nothing_written(out):
                animate_live(prob, result, Path(tmp) / "live.gif")
        folder = RunFolder(out)
        with signals_deferred(folder), folder as stage:  # (whole: a Ctrl-C here is answered once they are written)
            result.plan.save(stage)
            result.verification.save(stage / "verification.json")  # (the full report, as coplan solve and verify write)
            (stage / "run.json").write_text(json.dumps(jsonable(result.run), indent=1, allow_nan=False))
            if animate:
                shutil.move(str(Path(tmp) / "live.gif"), str(stage / "live.gif"))
            names = _staged(stage)
    work_done()
    m = result.run["metrics"]
    status = result.plan.status
    code = status_exit_code(status)  # (as coplan solve and a row's run: nothing reachable is 4, not 6)
    if as_json:  # (with the status and exit code: a script read neither from the document)
        typer.echo(json.dumps(jsonable(dict(m, status=status.value, **exit_fields(code))),
                              allow_nan=False))
    else:
        _print_cell_run(prob, m, horizon, all_candidates, result, out, folder, names)
    raise typer.Exit(int(code))


def _print_cell_run(prob, m: dict, horizon: float, all_candidates: bool, result, out: Path, folder, names) -> None:
    """A live cell run's summary: harvest against the omniscient plan, re-plans and their latency,
    false detections, what was missed and why, the executed plan's verdict, the files written."""
    lat = m["latency_p95"]
    _out.print(
        f"{_safe(prob.name)} live: {m['harvested']} of {m['reachable']} reachable fruit harvested, makespan "
        f"{m['makespan']:.3f} s (omniscient {m['omniscient_makespan']:.3f} s, "
        + (f"throughput loss {100 * (m['throughput_loss'] or 0):.1f} %)\n"
           if m["harvested"] >= (m.get("omniscient_harvested") or 0) else  # (fewer fruit sooner read as a gain: -6.6 %)
           f"for {m['omniscient_harvested']} fruit: {m['omniscient_harvested'] - m['harvested']} fewer harvested here, "
           f"no throughput to compare)\n") +
        f"{m['replans']} re-plans, latency median {1000 * (m['latency_median'] or 0):.1f} ms, p95 "
        f"{1000 * (lat or 0):.1f} ms, max {1000 * (m['latency_max'] or 0):.1f} ms; false detections "
        f"{m.get('false_reports', m['false_detections'])}"
        + (f" ({m['false_reports_merged']} merged into a real fruit's track)" if m.get("false_reports_merged") else "")
        + f" in {m['false_detections']} false tracks: {m['false_picks_avoided']} dropped at close range, {m['false_unreachable']} out of "
        f"reach, {m['false_picks']} picked; unreachable detections "
        f"{len(m['unreachable_detections'])}\n"
        + (f"[yellow]{m['late_replans']} of {m['replans']} re-plans took longer than the commit horizon "
           f"({horizon:g} s)[/]: the arms would have run past their committed motion before the new plan "
           "was ready, so this run is optimistic; "
           + ("--all-candidates gives each re-plan all the work it needs, not a "
              "real-time run\n" if all_candidates else "give --horizon at least the latency\n")
           if m.get("late_replans") else "")
        + (f"after the last place the arms probed {m['probes_after_last_place']} more false "
           f"track{'' if m['probes_after_last_place'] == 1 else 's'} at close range, their motion ending at "
           f"{m['work_end']:.3f} s (the makespan counts to the last place)\n" if m.get("probes_after_last_place") else "")
        + _missed_line(result.run["fruit"])
        + f"executed plan {_status(result.plan)} ({'verified' if m['verified'] else 'verification FAILED'}"
        f"{_room(result.verification)}); "
        f"wrote {_safe(out)}/: {_written(folder, names)}", highlight=False)

def _missed_line(fruit: dict) -> str:
    """The reachable fruit a live cell did not harvest, each with why (the first three; run.json has all)."""
    missed = [(f, o.get("why") or "not harvested") for f, o in fruit.items() if o.get("reachable") and not o.get("harvested")]
    if not missed:
        return ""
    shown = "; ".join(f"{_safe(f)}: {_safe(why)}" for f, why in missed[:3])
    more = f"; ... and {len(missed) - 3} more (run.json: fruit)" if len(missed) > 3 else ""
    return f"missed {len(missed)}: {shown}{more}\n"


def _number(text: Optional[str]) -> Optional[float]:
    """``--speed`` as a number (None when not given); anything else but auto is refused."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        usage(f"--speed: expected a cruising speed in m/s or auto, found {text!r}")


def _auto_speed(prob, quiet: bool) -> float:
    """``--speed auto``: :func:`coplan.row.moving.live_speed`, said on stderr."""
    import time as _time

    from ..row.moving import live_speed

    t0 = _time.perf_counter()
    try:
        v, best = live_speed(prob)
    except ValueError as e:
        usage(f"--speed auto: {e} (give --speed V, or --gantry stop-and-go)")
    except KeyboardInterrupt:  # (its best plan so far would not be the speed the search chooses: no run on it)
        _err.print("interrupted in --speed auto's speed search, before the live run started: nothing of this run "
                   "is written", markup=False, highlight=False)
        raise
    if not quiet:
        # (it said the search's fruit count, then compared the run with the plan at the rounded speed,
        # which can harvest another number: "93 fruit" then "92 of the 92 the offline plan harvests")
        top = float(best.info.get("top_speed") or v)
        _err.print(f"--speed auto: {v:g} m/s, the constant speed the offline search chooses ({top:.4g} m/s, where its plan "
                   f"harvests {best.plan.metrics.get('harvested', 0)} fruit, rounded down to the mm/s; the run's offline "
                   f"reference is planned at {v:g} m/s; {_time.perf_counter() - t0:.1f} s)",
                   markup=False, highlight=False)
    return v


def _run_row(prob, out, feed, speed, gantry, look_ahead, sigma, false_rate, duplicate_rate, seed, as_json, faults):
    """``coplan run ROW``: the row live, on the move or stop and go (:mod:`coplan.row.live`)."""
    from ..output import RunFolder, signals_deferred
    from ..pipeline import status_exit_code
    from ..plan import jsonable
    from ..problem.load import file_record
    from ..live.sim import RUN_FORMAT
    from ..row.live import LiveRowOptions, run_live_row

    if feed is not None:
        usage(f"--feed: {prob.name} is a row: its camera is simulated (--look-ahead, --sigma, --false-rate, "
              "--duplicate-rate, --seed); feed files describe a stationary cell's camera")
    mode = GantryMode((gantry or LiveGantryMode.CONTINUOUS).value)
    from ..problem.plausible import live_rail_issue

    too_long = live_rail_issue(prob, mode == GantryMode.STOP_AND_GO, look_ahead)
    if too_long:  # (before --speed auto's search; --speed's range was empty: 'in [0.527, 0.5] m/s ... or --speed auto')
        usage(f"{prob.name}: {too_long}")
    if mode == GantryMode.STOP_AND_GO:
        if speed is not None:
            usage("--speed: applies on the move (--gantry continuous); stop and go, the carriage hops between stops at "
                  "the gantry's limits")
        speed = 0.1  # unused (run.json records none)
    else:
        from ..problem.plausible import live_speed_issue

        auto = speed is not None and speed.strip().lower() == "auto"
        speed = _auto_speed(prob, as_json) if auto else _number(speed)
        bad = live_speed_issue(prob, speed)  # (the range it quotes is the live one)
        if bad and speed is None:  # (it read "expected a cruising speed in [...], found nothing": a required option unsaid)
            usage(f"--speed: a live row on the move needs its cruising speed: give --speed V (m/s) or --speed auto (the "
                  f"constant speed the offline search chooses), or run it stop and go (--gantry stop-and-go); V: {bad.removesuffix(', found nothing')}")
        if bad:
            usage(f"--speed{' auto' if auto else ''}: {bad} (or --speed auto, or --gantry stop-and-go)")
    opts = LiveRowOptions(speed=speed, look_ahead=look_ahead, sigma=sigma, false_rate=false_rate,
                          duplicate_rate=duplicate_rate, seed=seed, faults=faults, mode=mode)
    if sigma > opts.close_distance:  # (--sigma 1, meant as cm or mm, harvested nothing, and said nothing of why)
        _err.print(f"note: --sigma {sigma:g} m is more than the {opts.close_distance:g} m within which the gripper camera "
                   "finds a reported fruit: most reports will find nothing (--sigma is in m: 0.01 is 10 mm)",
                   markup=False, highlight=False)
    from ..errors import OptionsError

    try:
        with _nothing_written(out):
            res = run_live_row(prob, opts)
    except OptionsError as e:  # faults too long for the run's plan file (known once the offline plan is)
        if not any(i.path == "faults" for i in e.issues):
            raise
        given = [o for o, on in (("--arm-stop", faults.arm_stop), ("--camera-dark", faults.camera_dark),
                                 ("--late-replan", faults.late_replan)) if on]  # (only those given: it named all three)
        usage(f"{'/'.join(given)}: {e.issues[0].message} ({prob.name!r})")
    doc = {"format": RUN_FORMAT, "problem": prob.name,
           "mode": "row on the move" if mode == GantryMode.CONTINUOUS else "row stop and go",
           "options": {k: (v.value if k == "mode" else v) for k, v in opts.__dict__.items() if k != "faults"}
           | {"faults": faults.__dict__} | ({"speed": None} if mode == GantryMode.STOP_AND_GO else {}),  # (no cruising speed)
           "detections": [{"id": d.id, "position": list(d.position), "t": d.t, "fruit": d.truth} for d in res.detections],
           "outcome": res.outcome, "metrics": res.metrics}
    res.plan.problem_file = file_record(prob)  # (coplan view / plot / animate find the row from the plan)
    folder = RunFolder(out)
    with signals_deferred(folder), folder as stage:  # (whole: a Ctrl-C here is answered once they are written)
        res.plan.save(stage)
        res.verification.save(stage / "verification.json")  # (the full report, as coplan solve and verify write)
        (stage / "run.json").write_text(json.dumps(jsonable(doc), indent=1, allow_nan=False))
        names = _staged(stage)
    work_done()
    m = res.metrics
    code = status_exit_code(res.plan.status)
    if as_json:  # (with the status and exit code: a script read neither from the document)
        typer.echo(json.dumps(jsonable(dict(m, status=res.plan.status.value, **exit_fields(code))),
                              allow_nan=False))
    else:
        idle = ("" if not m.get("stops_without_picks") else ", without a pick" if m["stops"] == 1 else
                f", {m['stops_without_picks']} of them without a pick")
        how = f"on the move at {speed:g} m/s," if mode == GantryMode.CONTINUOUS else f"stop and go, {plural(m['stops'], 'stop')}{idle},"
        share = ("nothing for the offline plan (full knowledge) to harvest" if m["of_offline"] is None else
                 f"{100 * m['of_offline']:.1f} % of the {m['offline_harvested']} the offline plan (full knowledge) harvests"
                 if not m.get("harvested_not_offline") else  # (counts: "99.3 % of the 146 ..., and 155 it does not" read badly)
                 f"{m['harvested'] - m['harvested_not_offline']} of the {m['offline_harvested']} the offline plan (full "
                 f"knowledge) harvests, and {m['harvested_not_offline']} more that it does not")
        ratio = ("" if m["row_time_ratio"] is None or not m["harvested"]  # (nothing harvested: no speed-up to read)
                 else f" = {m['row_time_ratio']:.3f} x the offline plan's")
        if m["row_time_ratio"] and m.get("harvested_not_offline") and m.get("offline_harvested") and m.get("offline_row_time"):
            # (4.5 x the offline plan's time read as a slow run where the offline plan left 73 % of the fruit)
            off_fph = 3600.0 * m["offline_harvested"] / m["offline_row_time"]
            ratio += (f", which harvests {m['harvested_not_offline']} fewer fruit: "
                      f"{3600.0 * m['harvested'] / m['row_time']:.0f} fruit per hour against its {off_fph:.0f}")
        if m["last_place"] is not None and m["row_time"] > m["last_place"] + 0.5:  # probes after the last fruit placed
            ratio += f" (the last fruit placed at {m['last_place']:.1f} s, then probes of false or repeated reports)"
        if m["plan_seconds"] > m["row_time"] + 60.0:  # an arm held long after the work (a late decision)
            late = ((m.get("faults") or {}).get("late_replan") or {})
            why = (f"a late decision held {late['arm']} until {late['waits_until']:.1f} s" if "waits_until" in late
                   and late["waits_until"] > m["row_time"] else "the carriage's way to the rail's end, the arms' way home")
            ratio += f"; the executed plan lasts {m['plan_seconds']:.1f} s ({why})"
        cycle = ("no cycle" if m["shortest_cycle_seconds"] is None else
                 f"a shortest cycle of {m['shortest_cycle_seconds']:.2f} s")
        cells = m.get("cell_decisions") or []
        if cells:  # (a stop's cell plan has until the stop's booked motion ends: its lead)
            slow = max(cells, key=lambda d: d["seconds"])
            cycle += (f", {plural(len(cells), 'stop cell')} slowest {slow['seconds']:.2f} s against its lead of "
                      f"{slow['lead_seconds']:.1f} s")
        reachable = len(m["missed_reachable_by_a_working_arm"])
        # (said with faults, and without them where the run passed fruit a working arm could still reach: the planner's loss)
        faults_line = (f"faults: {_safe(_faults_text(m['faults']))}; missed though a working arm could still reach them: "
                       f"{reachable}\n" if m["faults"] else
                       f"no fault; missed though an arm could still reach them: {reachable} (run.json: "
                       "missed_reachable_by_a_working_arm)\n" if reachable else "")
        tucked = (res.plan.solver.get("row") or {}).get("tucked") or []
        if tucked:  # (the last tries with the carriage at rest: slower cycles, said so)
            faults_line = tucked_text(tucked) + "\n" + faults_line
        if m.get("holds_for_fruit"):
            faults_line = (f"the carriage held {m['holds_for_fruit']} time{'s' if m['holds_for_fruit'] != 1 else ''} rather "
                           f"than pass a fruit no arm could still book ({m['hold_seconds']:.1f} s)\n") + faults_line
        missed = [why if re.search(rf"(?<![\w-]){re.escape(f)}(?![\w-])", why) else f"{f}: {why}"  # (named once)
                  for f, why in ((f, w.removeprefix("missed: ")) for f, w in res.outcome.items())  # ('missed N fruit: missed: ...')
                  if why != "harvested" and f in {x.id for x in prob.fruits}]
        if missed:  # each true fruit not harvested, and why (all of them: run.json outcome; "missed" read as the
            # planner's miss for a fruit out of every arm's reach, which coplan solve calls screened out)
            faults_line += f"not harvested, {len(missed)} fruit: " + "; ".join(_safe(w) for w in missed[:3]) + (
                f"; ... and {len(missed) - 3} more (run.json: outcome)" if len(missed) > 3 else "") + "\n"
        per_hour = "" if m.get("fruit_per_hour") is None else f" ({m['fruit_per_hour']:.0f} fruit per hour)"
        _out.print(
            f"{_safe(prob.name)} live {how} camera {look_ahead:g} m ahead, noise {sigma * 1000:g} mm, "
            f"{plural(m['false_reports'], 'false report')}: {m['harvested']} fruit harvested, {share}; row time "
            f"{m['row_time']:.1f} s{per_hour}{ratio}\n{plural(m['decisions'], 'decision')}, slowest {1000 * m['decision_max_seconds']:.1f} ms "
            f"against {cycle} ({'kept ahead' if m['kept_ahead'] else 'LATE'}); {plural(m['probes'], 'probe')} of false, repeated "
            f"or far-off reports\n{faults_line}executed plan {_status(res.plan)} "
            f"({'verified' if m['verified'] else 'verification FAILED'}{_room(res.verification)}); wrote {_safe(out)}/: "
            + _written(folder, names),
            highlight=False)
    raise typer.Exit(int(code))


@contextlib.contextmanager
def _nothing_written(out: Path):
    """Say, when a live run is interrupted (Ctrl-C, SIGTERM) before its files, that none of it is
    written and ``out`` holds what it held (a run is written whole, at its end, or not at all)."""
    try:
        yield
    except KeyboardInterrupt:
        held = "holds what it held before" if out.exists() else "was not made"
        _err.print(f"interrupted before the run's files were written: nothing of this run is kept; {_safe(out)} {held} "
                   "(a live run is written whole at its end, or not at all)", markup=False, highlight=False)
        raise


def _room(ver) -> str:
    """What an operator asks of a run's safety: the collisions the verifier found and the room the
    arms kept, certified between samples (``, 0 collisions, least clearance 0.1206 m certified,
    70.6 mm beyond the 0.05 m required``); nothing where no two arms can meet."""
    s = ver.summary()
    cert = s["certified_clearance"]
    # (its warnings too -- poses near a singularity: coplan verify said "warnings 14", the summary nothing)
    warned = f", {plural(len(ver.warnings), 'warning')} (verification.json)" if ver.warnings else ""
    if cert is None or not math.isfinite(cert):
        return warned
    side = "beyond" if s["margin"] >= 0 else "short of"
    return (f", {s['collision_count']} collision{'' if s['collision_count'] == 1 else 's'}, least clearance {cert:.4f} m "
            f"certified, {1000 * abs(s['margin']):.1f} mm {side} the {s['required_clearance']:g} m required{warned}")


def _status(plan) -> str:
    """The executed plan's status for the summary; where it is infeasible for want of fruit (none
    any arm reaches: exit 4, as coplan solve and verify say it), that said."""
    if plan.status == PlanStatus.INFEASIBLE and (plan.metrics or {}).get("reachable") == 0:
        return "infeasible: nothing to harvest, no fruit any arm reaches"
    return plan.status.value


def _faults_text(faults: dict) -> str:
    """A run's faults and what each did, one clause each: ``arm stop: arm3, t 85.35, ...`` (the
    arm by its name alone)."""
    def value(k: str, v) -> str:  # (a speed as 0.0667 m/s, not 0.066667; the rest as recorded)
        if k == "to_speed" and isinstance(v, (int, float)):
            return f"{v:.3g} m/s"
        return " ".join(map(str, v)) if isinstance(v, list) else str(v)  # (reports as d0015 d0021)

    return "; ".join(f"{kind.replace('_', ' ')}: " + ", ".join(str(v) if k == "arm" else f"{k.replace('_', ' ')} {value(k, v)}"
                                                               for k, v in what.items())
                     for kind, what in faults.items())
