"""The command line's row parts (a problem with a gantry): ``coplan check`` of a row. Light to
import: the row stage is imported inside each function."""

from __future__ import annotations

from pathlib import Path

from ..errors import plural
from ..kinds import ExitCode, GantryMode, PlannerKind, PlanStatus, SpeedProfile
from .checks import fail, strict_json
from .failures import exit_fields, usage
from .summary import safe

__all__ = ["check_row", "compare_row", "stop_window"]


def check_row(prob, path: Path, as_json: bool, out_console, resolution: float | None = None) -> ExitCode:
    """``coplan check`` of a row: which fruit some carriage position serves (and why not), the
    arms the screen locks, the carriage span, the stop rules' stop counts and the row's lower bounds."""
    from ..allocate.row_bound import row_bounds
    from ..row.plan import check_row_work
    from ..row.reach import DEFAULT_RESOLUTION, row_reach
    from ..row.stops import carriage_span, fewest_stops, fixed_stops

    g = prob.gantry
    check_row_work(prob)  # (a row no plan can hold: refused as coplan solve refuses it, exit 3)
    reach = row_reach(prob, resolution or DEFAULT_RESOLUTION)
    b = row_bounds(prob)
    doc = {"problem": prob.name, "file": str(path), "arms": len(prob.arms), "fruit": len(prob.fruits),
           "row": {"start": g.start, "end": g.end, "length": g.length},
           "harvestable": len(reach.cover), "not_harvestable": dict(reach.reasons), "locked": dict(reach.locked),
           # (the serving positions, each a resolution's width of rail, counted; at most the rail: a
           # 0.05 m rail's two positions read 0.10 m)
           "carriage_span": min(carriage_span(reach), g.length) if reach.cover else None,
           "stops": {"fewest": len(fewest_stops(reach, exact=True)), "fixed": len(fixed_stops(reach))},
           "lower_bound": b.to_dict()}
    # as solve would say: partial only if some fruit an arm reaches from the rail (the verifier's
    # count) cannot be harvested; a fruit out of every arm's reach is not counted (as in a cell)
    from ..verify.row import row_reachable_ids

    missed = sorted(set(row_reachable_ids(prob)) - set(reach.cover))
    code = ExitCode.INFEASIBLE if not reach.cover else ExitCode.PARTIAL if missed else ExitCode.OK
    doc["reachable_not_harvestable"] = missed  # (what makes the exit 5: the verifier counts them)
    doc.update(exit_fields(code))  # (a script read no status from the document)
    if as_json:
        out_console.print_json(strict_json(doc), ensure_ascii=True)  # (valid JSON whatever stdout encodes)
    else:
        p = out_console.print
        p(f"[bold]{safe(prob.name)}[/] ({safe(path)}): a row of {g.length:g} m ([{g.start:g}, {g.end:g}]), "
          f"{plural(len(prob.arms), 'arm')} on the carriage, {len(prob.fruits)} fruit: {len(reach.cover)} harvestable "
          f"from some carriage position, {len(reach.reasons)} not")
        xs = [f.position[0] for f in prob.fruits]
        if xs and g.length >= 1000.0 and max(xs) - g.start < 0.02 * g.length:  # (an end in mm read as 'a row of 8000 m')
            p(f"note: the fruit lie within x [{min(xs):g}, {max(xs):g}] m of a {g.length:g} m rail: gantry.end in mm? "
              f"(the row's figures per metre count the whole rail; a live run covers it all)", highlight=False)
        if reach.locked:  # (as a cell's check says it: the bins ride with the carriage, so all along the rail)
            p(f"screen: {len(reach.locked)} of {plural(len(prob.arms), 'arm')} locked ({', '.join(reach.locked)}): "
              f"they harvest nothing from any carriage position", highlight=False)
            for why in reach.locked.values():
                p(f"  - {safe(why)}", highlight=False)
        for why in list(reach.reasons.values())[:10]:
            p(f"  - {safe(why)}", highlight=False)
        if len(reach.reasons) > 10:
            p(f"  ... and {len(reach.reasons) - 10} more (--json lists them all)")
        if reach.cover:
            p(f"carriage span      {doc['carriage_span']:.2f} m (a fruit stays within the arms' reach over this much rail, "
              f"median); stops: {doc['stops']['fewest']} at the fewest, {doc['stops']['fixed']} at a fixed stride")
        if reach.cover:
            p(f"lower bound        {b.any_plan:.2f} s for any plan: the largest of the busiest arm's cycles {b.work:.2f} s, "
              f"the carriage's way to {b.reach_to:.2f} m and one fruit's dwells {b.travel:.2f} s, and the arrival "
              f"{b.arrival:.2f} s (from rest to where each fruit is reached, then the picks, ways back and places after "
              f"it, each arm from where it first reaches them)")
            p(f"                   {b.stop_and_go:.2f} s stop by stop with no arm working while the carriage moves (its "
              f"moves {b.moves:.2f} s, then the cells; with the stops and where each fruit is picked from priced together "
              f"{b.priced:.2f} s, its cheapest stopping {plural(b.priced_stops, 'time')}"
              # (a slow carriage: 'priced together 768.69 s, at 463 stops' read as a bound below the travel bound's 924.50 s)
              + (f", weaker here than the bounds before it, which set the {b.stop_and_go:.2f} s" if b.priced < b.stop_and_go - 1e-9
                 else "")
              + "): a bound for that model only -- coplan's plans let the arms place and come out during the moves, and "
                "may beat it")
        else:  # (as a cell's check says it)
            p("nothing to plan: no fruit can be harvested from any carriage position (solve would exit 4, infeasible)"
              + (" -- the problem lists no fruit" if not prob.fruits else ""))
        if code == ExitCode.PARTIAL:  # (it exited 5 and said nothing of why)
            shown = ", ".join(safe(f) for f in missed[:5]) + (f" and {len(missed) - 5} more" if len(missed) > 5 else "")
            p(f"partial            solve would exit 5: {plural(len(missed), 'fruit')} an arm reaches from some carriage "
              f"position on the rail, as the verifier counts, {'is' if len(missed) == 1 else 'are'} not harvestable from "
              f"the positions the screen tries every {reach.resolution:g} m ({shown}; why above): a finer --resolution "
              "serves a fruit reached only between them; one only a locked arm reaches stays out", highlight=False)
    return code


def compare_row(prob, planner, out: Path, as_json: bool, out_console, err_console, workers: int | None = None,
                gantry=None, profile=None) -> ExitCode:
    """``coplan compare ROW.yaml``: the stop rules and on the move side by side
    (:func:`coplan.report.rows.compare_rows`; ``gantry``: stop-and-go or continuous alone, default both)."""
    from rich.table import Table

    from ..kinds import PlannerKind
    from ..report.rows import cell_text, columns, compare_rows
    from .console import ProgressDisplay
    from .summary import print_table

    cell = None
    if planner:
        if len(planner) > 1 or planner[0] not in (PlannerKind.COORDINATED.value, PlannerKind.OPTIMAL.value):  # (it printed no error document with --json)
            usage(f"--planner: a row takes one cell planner: coordinated or optimal, found {', '.join(planner)}")
        cell = PlannerKind(planner[0])
        if gantry == GantryMode.CONTINUOUS and cell != PlannerKind.COORDINATED:
            usage(f"--planner {cell.value}: on the move the row books its own coordinated moves; the cell planners apply "
                  "to stop and go (--gantry stop-and-go, or auto: both)")
    if profile is not None and gantry == GantryMode.STOP_AND_GO:
        usage(f"--profile {profile.value}: the speed search's profile applies on the move; --gantry stop-and-go "
              "compares the stop rules alone")
    try:
        with ProgressDisplay(err_console, quiet=as_json) as say:
            cmp = compare_rows(prob, out, planner=cell, progress=say, workers=workers, gantry=gantry or GantryMode.AUTO,
                               profile=profile)
    except KeyboardInterrupt:  # (it exited 130 saying nothing of the report it had written)
        if (out / "compare.json").exists():
            err_console.print(f"interrupted: the report of what was planned so far is in {safe(str(out / 'compare.json'))} "
                              f"and compare.md (its notes say where it stopped)", highlight=False)
        raise
    # (a row with nothing to harvest, every plan infeasible, said "ok" where solve says 4; and where no
    # plan harvests every harvestable fruit, there is no best plan: solve's partial, 5)
    statuses = {r["status"] for r in cmp.rows}
    code = (ExitCode.UNSAFE if not all(r["verified"] for r in cmp.rows) else
            ExitCode.SOLVER_FAILED if any(r.get("error") for r in cmp.rows) else
            ExitCode.INFEASIBLE if statuses == {PlanStatus.INFEASIBLE.value} else
            ExitCode.PARTIAL if cmp.rows and cmp.best is None and PlanStatus.PARTIAL.value in statuses else ExitCode.OK)
    if as_json:  # (with the exit code, as every document of a command that ran)
        out_console.print(strict_json(cmp.to_dict() | exit_fields(code)), markup=False,
                          highlight=False)
    else:
        from rich import box

        table = Table(title=cmp.title,
                      title_justify="left", box=box.SIMPLE_HEAD,
                      padding=(0, 1), pad_edge=False)
        cols = columns(cmp)
        cells = [[cell_text(k, r.get(k)) for k, _ in cols] for r in cmp.rows]
        # every value and every heading's words whole at 80 columns (the headings wrap between words)
        heads = [_SHORT.get(k, head) for k, head in cols]
        for c, head in enumerate(heads):
            table.add_column(head, min_width=max([len(w) for w in head.split()] + [len(row[c]) for row in cells]))
        for row in cells:
            table.add_row(*row)
        print_table(out_console, table)
        if cmp.best_text():
            out_console.print(safe(cmp.best_text()), highlight=False)
        for note in cmp.notes:
            out_console.print(f"note: {safe(note)}", highlight=False)
        out_console.print(f"wrote {safe(cmp.files['json'])} and {safe(cmp.files['markdown'])}")
    return code


def rows_in(source: Path) -> list[Path]:
    """The problem files at ``source`` (a file, or a folder's ``*.yaml``) that are rows (a
    ``gantry`` section, a mapping), read as plain YAML: a file that does not read, or whose
    ``gantry`` is no mapping, is left to the command's own checks."""
    import yaml

    files = sorted([*source.glob("*.yaml"), *source.glob("*.yml")]) if source.is_dir() else [source]
    out = []
    for f in files:
        try:
            data = yaml.safe_load(f.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, yaml.YAMLError):
            continue
        if isinstance(data, dict) and isinstance(data.get("gantry"), dict):  # (``gantry: yes`` is a bad file, left to its checks)
            out.append(f)
    return out


def refuse_rows_in_compare(source: Path, time_limit, options_file) -> None:
    """``coplan compare``: a row's comparison takes no --time-limit or --options (its stops are
    planned without them), and a folder of problems compares cells, so holds no row."""
    rows = rows_in(source)
    if rows and (time_limit is not None or options_file is not None):
        given = "/".join(f for f, v in (("--time-limit", time_limit), ("--options", options_file)) if v is not None)
        fail(ExitCode.USAGE, f"{given}: {safe(rows[0].name)} is a row: its stops are planned by the cell "
                             "planner at each stop, without a wall-clock limit or solver options (they are for a stationary cell)")
    if rows and source.is_dir():
        fail(ExitCode.USAGE, f"{safe(source)}: comparing a folder compares the planners on stationary cells; "
                             f"{plural(len(rows), 'file is a row', 'files are rows')} ({', '.join(safe(r.name) for r in rows[:5])}"
                             f"{', ...' if len(rows) > 5 else ''}): compare a row's stop rules with 'coplan compare ROW.yaml'")


def refused_on_a_row(planner, allocation, options_file, time_limit, gantry=None) -> tuple[list[str], list[str]]:
    """What ``coplan solve`` on a row refuses of its options: ``(options, why)``, the options'
    names (a usage error's JSON ``path``) and each refusal with why (both empty: none);
    ``gantry``: the mode asked for (on the move no cell planner applies)."""
    cell_only = [o for o, given in (("--allocation", allocation is not None), ("--options", options_file is not None),
                                    ("--time-limit", time_limit is not None)) if given]
    heuristic = ("--planner heuristic: on the move the row books its own coordinated moves; the cell planners apply "
                 "to stop and go" if gantry == GantryMode.CONTINUOUS else
                 "--planner heuristic plans a cell, not a row's stops (coordinated or optimal do)")
    return cell_only + (["--planner"] if planner == PlannerKind.HEURISTIC else []), \
        ([f"{', '.join(cell_only)} {'is' if len(cell_only) == 1 else 'are'} for a stationary cell"] if cell_only else []) \
        + ([heuristic] if planner == PlannerKind.HEURISTIC else [])


_SHORT = {"ratio_stop_and_go_bound": "/ bound (stop by stop, no overlap)", "planning_time": "planning s", "speed": "speed m/s"}  # (the terminal's table)


def stop_window(stop_price, pace_price, gantry, moving, stops):
    """``coplan solve``'s ``--stop-price``/``--pace-price`` as the optimised rule's
    :class:`~coplan.row.stops.StopWindow`, None when neither is given; refused (usage) where no
    optimised rule chooses stops (``moving``: the options on the move, or with auto)."""
    from ..kinds import StopRule

    for flag, value, what in (("--stop-price", stop_price, "price of a stop"),
                              ("--pace-price", pace_price, "price of a stop ahead of the fixed stride's pace")):
        if value is not None and (moving is not None or stops not in (None, StopRule.OPTIMISED)):
            # (auto plans stop and go too, but "not on the move" read as a contradiction there:
            # auto compares the two modes each with its defaults)
            fail(ExitCode.USAGE, f"{flag}: the optimised stop rule's {what} applies to a row planned stop and go "
                                 f"(--gantry stop-and-go, the default, with --stops optimised), not "
                                 + ("--gantry auto, which compares the two modes each with its default options"
                                    if gantry == GantryMode.AUTO else "on the move" if moving is not None
                                    else f"--stops {stops.value}"))
    if stop_price is None and pace_price is None:
        return None
    from ..row.stops import MAX_STOP_PRICE, StopWindow

    if (stop_price or 0.0) + (pace_price or 0.0) > MAX_STOP_PRICE:  # (a segment ahead of pace charges both)
        fail(ExitCode.USAGE, f"--stop-price + --pace-price: expected at most {MAX_STOP_PRICE:g} s together (a stop "
                             f"ahead of the pace is charged both), found {stop_price or 0:g} + {pace_price or 0:g}")
    return StopWindow(stop_price=stop_price or 0.0, pace_price=pace_price or 0.0)


def moving_options(problem, gantry, speed, stops, planner, profile=None):
    """The row-on-the-move options of ``coplan solve``, or None for stop and go (usage checked);
    ``profile``: what the speed search varies (default its own, density)."""
    if gantry not in (GantryMode.CONTINUOUS, GantryMode.AUTO):
        for flag, what, given in (("--speed", "a cruising speed", speed), ("--profile", "the speed search's profile", profile)):
            if given is not None:
                fail(ExitCode.USAGE, f"{flag}: {what} applies on the move (--gantry continuous or auto)")
        return None
    if speed is not None and profile not in (None, SpeedProfile.CONSTANT):
        fail(ExitCode.USAGE, f"--profile {profile.value}: --speed gives one cruising speed for the whole row (a constant "
                             "profile); without --speed the search varies the speed per metre of rail (density), one speed "
                             "for the row (constant) or both (auto)")
    if stops is not None and gantry == GantryMode.CONTINUOUS:
        fail(ExitCode.USAGE, "--stops: on the move (--gantry continuous) the carriage does not stop")
    if planner is not None and planner != PlannerKind.COORDINATED and gantry == GantryMode.CONTINUOUS:
        fail(ExitCode.USAGE, "--planner: on the move the row books its own coordinated moves; the cell planners "
                              "apply to stop and go")
    from ..row.continuous import MovingOptions

    if speed is None:
        return MovingOptions() if profile is None else MovingOptions(profile=profile)
    from ..row.continuous import cruise_issue

    bad = cruise_issue(problem, speed)
    if bad:
        fail(ExitCode.USAGE, f"--speed: {bad} ({problem.name!r})")
    return MovingOptions(profile=SpeedProfile.CONSTANT, level=speed)


def refuse_mixed_modes(speed, profile, stops, stop_price, pace_price) -> None:
    """With no ``--gantry``: on-the-move flags (``--speed``, ``--profile``) beside stop-and-go ones
    (``--stops``, a stop price) are refused naming both (it blamed --gantry, never given)."""
    moving_flags = [f for f, v in (("--speed", speed), ("--profile", profile)) if v is not None]
    stop_flags = [f for f, v in (("--stops", stops), ("--stop-price", stop_price), ("--pace-price", pace_price)) if v is not None]
    if moving_flags and stop_flags:
        fail(ExitCode.USAGE, f"{'/'.join(moving_flags)} and {'/'.join(stop_flags)}: {'/'.join(moving_flags)} plans the row "
                             f"on the move, where the carriage never stops; {'/'.join(stop_flags)} plans it stop and go: "
                             "give one or the other")
