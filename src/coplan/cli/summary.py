"""What the command line prints of a solve and of a verification (rich text, untrusted
strings escaped). Light to import: rich only, like :mod:`coplan.cli`."""

from __future__ import annotations

import math
from collections import Counter

from ..errors import plural, printable
from ..kinds import GantryMode, PlanStatus

__all__ = ["fmt", "fruit_line", "print_row_summary", "print_summary", "print_verification", "safe"]


def tucked_text(tucked: list[str]) -> str:
    """The fruit a tucked cycle picked (``solver.row.tucked``: the last tries with the carriage at
    rest), said for a summary: how many, and the first five."""
    return (f"{plural(len(tucked), 'fruit', 'fruit')} picked with the arm's ways tucked round a neighbour (the elbow "
            f"folded while the shoulder turns; its last try, the carriage at rest): " + ", ".join(map(safe, tucked[:5]))
            + (f" and {len(tucked) - 5} more" if len(tucked) > 5 else ""))


def safe(x) -> str:
    """An untrusted string (a name, id or message from a file) safe for the terminal: Rich markup
    escaped, control characters (escape sequences) shown as ``\\x..`` codes."""
    from rich.markup import escape

    return escape(printable(x))


def print_table(console, table) -> None:
    """Print a Rich table whole: on a terminal at its width, as Rich does; into a pipe or a file
    (80 columns for Rich) as wide as the table needs, at most 400 columns -- the clearance
    sweep's headers were cut to 'makesp...', numbers split across lines."""
    if console.is_terminal:
        console.print(table)
        return
    from rich.console import Console

    need = console.measure(table, options=console.options.update(width=400)).maximum
    wide = Console(file=console.file, width=max(console.width, min(int(need), 400)), no_color=console.no_color, emoji=False,
                   highlight=False)  # (Rich caps a print's width at its console's)
    wide.print(table)


def fmt(x, unit="", nd=2) -> str:
    """A number with ``nd`` decimals and its unit; ``-`` for none."""
    if x is None:
        return "-"
    return f"{x:.{nd}f}{unit}"


def _of_row(r: dict) -> str:
    """Planning time's share of the row time, in words (none for a row of no time: one
    interrupted before its first stop)."""
    x = r.get("planning_over_row_time")
    return "(the row has no time to set it against)" if x is None else f"= {100 * x:.2f} % of the row time"


def fruit_line(m: dict) -> str:
    """The fruit of a plan in coplan's one vocabulary: harvested of harvestable; of all fruit,
    the unreachable, screened-out and left-out ones by id."""
    ids = m.get("fruit_ids") or {}
    head = f"{m.get('harvested')} harvested of {m.get('harvestable', m.get('reachable'))} harvestable"
    over = (m.get("harvested") or 0) - (m.get("harvestable", m.get("reachable")) or 0)
    if over > 0:  # (the course's heuristic does not screen: a locked arm's picks, say, which its violations show)
        head += f" ({over} more than the screen allows: picks it finds no safe way to make)"
    parts = []
    for key, words in (("unreachable", "unreachable"), ("screened_out", "screened out"), ("left_out", "left out")):
        got = ids.get(key) or []
        if got:
            shown = ", ".join(safe(f) for f in got[:6]) + (f", ... {len(got) - 6} more" if len(got) > 6 else "")
            parts.append(f"{len(got)} {words} ({shown})")
    total = m.get("fruit")
    if total is None:
        return head
    return head + (f"; of {total} fruit " + ", ".join(parts) if parts else f" (all {total} fruit)")


def _say_if_no_fruit(p, problem) -> None:
    if not problem.fruits:
        p(f"  nothing to harvest: the problem lists no fruit ({safe(problem.source or 'fruits')}: fruits is empty)")


def print_row_summary(console, res) -> None:
    """The summary of a row (:class:`coplan.pipeline.SolveResult` with ``row``)."""
    m = res.plan.metrics
    r = m.get("row") or {}
    ver = res.plan.verification or {}
    solver = (res.plan.solver or {}).get("row", {})
    colour = "green" if res.success else "red"
    p = console.print
    moving = r.get("mode") == GantryMode.CONTINUOUS
    still = moving and not r.get("carriage_moving_share")  # every fruit served from where the carriage starts
    how = ("on the move (nothing to harvest: the carriage stays where it starts)" if still and not m.get("harvested") else
           "on the move (the carriage need not move: every fruit is in reach from where it starts)" if still else
           f"on the move ({safe(r.get('profile'))} speed profile, {fmt(r.get('mean_speed'), ' m/s', 3)} on average while it moves, "
           f"top {fmt(r.get('top_speed'), ' m/s', 3)})" if moving else
           f"stops {safe(solver.get('rule'))}"
           + (f" (each priced {fmt(solver['stop_price'], ' s', 2)} beyond its time)" if solver.get("stop_price") else "")
           + (f" (each ahead of the fixed stride's pace priced {fmt(solver['pace_price'], ' s', 2)} more)"
              if solver.get("pace_price") else "")
           + f", cell planner {safe(solver.get('cell_planner'))}"
           + (f" ({solver['retimed_cells']} of {r.get('stops')} cells retimed by CP-SAT)" if solver.get("retime") else ""))
    p(f"[bold]{safe(res.problem.name)}[/] -- row of {r.get('row_length', 0):g} m, {how}, "
      f"status [bold {colour}]{res.plan.status.value}[/]")
    _say_if_no_fruit(p, res.problem)
    _row_screen_and_choices(p, res, solver, r)
    _row_fruit(p, res, m, r, solver)
    _row_time(p, res, m, r, solver, moving, still)
    least = ver.get("min_clearance")
    if least is not None and math.isfinite(least):
        p(f"  collisions found  {ver.get('collision_count', '-')}   least clearance {fmt(least, ' m', 4)} "
          f"(certified {fmt(ver.get('certified_clearance'), ' m', 4)}, required {fmt(res.problem.task.clearance, ' m', 3)})")
        _margin_line(p, ver)  # (a row's summary had neither, which plan.json and the viewer give)
    if solver.get("margins_screened"):  # (a second Ctrl-C as the kept plan was certified: said in plan.json alone)
        p(f"  [yellow]margins screened[/]  {safe(solver['margins_screened'])}")
    _jerk_line(p, m, ver)
    if not ver.get("passed", False):
        p(f"  violations        {ver.get('violation_count', '?')} ({', '.join(ver.get('violation_kinds', [])) or 'see verification.json'})")
    _warnings(p, res.verification)
    _row_planning(p, r, solver, moving)
    for k, v in res.files.items():
        p(f"  wrote             {safe(v)}")
    if res.previous is not None:
        p(f"  previous run      kept in {safe(res.previous)}")


def _row_screen_and_choices(p, res, solver: dict, r: dict) -> None:
    """A row summary's arms the screen locks, and what ``--gantry auto`` / ``--profile auto`` kept."""
    locked = r.get("locked_arms") or {}
    if locked:  # (as a cell's summary and `coplan check` say it: the bins ride with the carriage, so all along the rail)
        p(f"  screen            {len(locked)} of {plural(len(res.problem.arms), 'arm')} locked ({', '.join(map(safe, locked))}): "
          f"{'it harvests' if len(locked) == 1 else 'they harvest'} nothing from any carriage position")
        for why in locked.values():
            p(f"    {safe(why)}")
    auto = solver.get("auto")
    if auto:
        other = GantryMode.CONTINUOUS.value if auto["chosen"] == GantryMode.STOP_AND_GO else GantryMode.STOP_AND_GO.value
        if auto.get(other) is None:  # (interrupted before the other mode was planned)
            p(f"  gantry auto       {safe(auto['chosen'])} kept, nothing compared: {safe(auto.get('interrupted'))}")
        else:
            cut = " [yellow]interrupted: a part of the row[/]" if auto[other].get("interrupted") else ""
            p(f"  gantry auto       {safe(auto['chosen'])} kept: {auto[auto['chosen']]['fruit_per_hour']:.0f} fruit/h against "
              f"{auto[other]['fruit_per_hour']:.0f} {safe(auto[other].get('label') or other)} ({auto[other]['harvested']} fruit, "
              f"{'verified' if auto[other]['verified'] else 'NOT verified'}){cut}")
    profs = solver.get("profiles")
    if profs:  # --profile auto: both speed searches, the better kept
        kept = profs["kept"]
        other = next((k for k in profs if k not in (kept, "kept")), None)
        p(f"  profile auto      {safe(kept)} kept: {profs[kept]['fruit_per_hour']:.0f} fruit/h against "
          + (f"{profs[other]['fruit_per_hour']:.0f} {safe(other)} ({profs[other]['harvested']} fruit, "
             f"{'verified' if profs[other]['verified'] else 'NOT verified'})" if other else
             f"nothing: {safe(solver.get('interrupted'))}"))


def _row_fruit(p, res, m: dict, r: dict, solver: dict) -> None:
    """A row summary's fruit: harvested, screened out, left out (with the reasons)."""
    out = r.get("screened_out") or {}  # (every fruit no carriage position serves: out of reach or ruled out)
    far = set((m.get("fruit_ids") or {}).get("unreachable") or []) & set(out)
    # in the one vocabulary of every command (fruit_line): unreachable -- out of every arm's reach
    # from every carriage position -- and screened out, reachable but ruled out (a row said "3
    # screened out" where its metrics said unreachable 3, screened_out 0)
    parts = ([f"{len(far)} unreachable (out of every arm's reach from every carriage position)"] if far else []) + (
        [f"{len(out) - len(far)} screened out (no carriage position the screen tries lets a working arm harvest "
         f"{'it' if len(out) - len(far) == 1 else 'them'})"] if len(out) > len(far) else [])
    p(f"  fruit             {r.get('harvested')} harvested of {r.get('harvestable')} harvestable "
      f"({fmt(None if r.get('share_harvested') is None else 100 * r['share_harvested'], ' %', 1)}); of {r.get('fruit')} fruit "
      + (" and ".join(parts) if parts else "none unreachable or screened out"))
    for fid, why in list(out.items())[:3]:
        p(f"    {safe(why)}")
    if len(out) > 3:
        p(f"    ... and {len(out) - 3} more (plan.json: metrics.row.screened_out)")
    beyond = (m.get("reachable") or 0) - (r.get("harvestable") or 0)
    if res.plan.status == PlanStatus.PARTIAL and beyond > 0 and r.get("harvested") == r.get("harvestable"):
        p(f"  why partial       {plural(beyond, 'screened-out fruit is', 'screened-out fruit are')} still reachable, as the "
          f"verifier counts: from between the candidate stops (a finer --resolution serves "
          f"{'it' if beyond == 1 else 'them'}), or only by an arm the screen locks")
    got = {e.fruit for e in res.plan.events}
    left = {f: why for f, why in (solver.get("left_out") or {}).items() if f not in out and f not in got}
    if left:  # harvestable but not harvested by this plan, and why (all of them: plan.json solver.row.left_out)
        p(f"  left out          {plural(len(left), 'harvestable fruit', 'harvestable fruit')}:")
        for fid, why in list(left.items())[:5]:  # (stop and go's reasons begin at the stop, not with the fruit)
            p(f"    {safe(why) if str(why).startswith(f'{fid}:') else f'{safe(fid)}: {safe(why)}'}")
        if len(left) > 5:
            p(f"    ... and {len(left) - 5} more (plan.json: solver.row.left_out)")


def _row_time(p, res, m: dict, r: dict, solver: dict, moving: bool, still: bool) -> None:
    """A row summary's fruit per hour, row time against the bounds, carriage or stops, each arm's idle shares."""
    from ..row.metrics import fruit_bounds_count

    p(f"  fruit per hour    {r.get('fruit_per_hour', 0):.0f} (per arm: "
      + ", ".join(f"{safe(a)} {v:.0f}" for a, v in (r.get("fruit_per_hour_per_arm") or {}).items()) + ")")
    lb = r.get("lower_bound") or {}
    if res.plan.status == PlanStatus.INTERRUPTED and (r.get("harvested") or 0) < (r.get("harvestable") or 0):
        # (a part of the row against the whole row's bounds read 0.271; a whole row whose speed search
        # alone was cut short has its ratios, and its status says it was interrupted)
        p(f"  row time          {fmt(r.get('row_time'), ' s')} for the part planned before the interruption (the "
          f"whole row's lower bound {fmt(lb.get('any_plan'), ' s')} for any plan; no ratio for a part)")
    elif not lb:  # (Ctrl-C while they were computed: the row is kept without them)
        p(f"  row time          {fmt(r.get('row_time'), ' s')}   ({fmt(r.get('time_per_metre'), ' s/m')}; no lower bounds: "
          f"{safe(solver.get('interrupted') or 'interrupted')})")
    elif (r.get("harvested") or 0) < (counted := fruit_bounds_count(r)):
        # (78 of 93 fruit at a speed given read "ratio 1.099" against a bound that counts all 93; a
        # sweep leaves a partial row's ratio out too)
        p(f"  row time          {fmt(r.get('row_time'), ' s')} for {r.get('harvested')} fruit (the lower bounds, "
          f"{fmt(lb.get('any_plan'), ' s')} for any plan and {fmt(lb.get('stop_and_go'), ' s')} stop by stop, count all "
          f"{counted} fruit an arm reaches from some carriage position: no ratio for a partial harvest)")
    else:
        p(f"  row time          {fmt(r.get('row_time'), ' s')}   ({fmt(r.get('time_per_metre'), ' s/m')}; lower bound "
          f"{fmt(lb.get('any_plan'), ' s')} for any plan, ratio {fmt(r.get('ratio_any_plan_bound'), '', 3)}; "
          + (f"{fmt(lb.get('stop_and_go'), ' s')} for a stop-and-go plan, which this one is not: it picks on the move)"
             if moving else  # (a ratio below 1 beside "lower bound" read as a broken bound)
             f"{fmt(lb.get('stop_and_go'), ' s')} stop by stop with no arm working while the carriage moves, ratio "
             f"{fmt(r.get('ratio_stop_and_go_bound'), '', 3)}"
             + (f": below 1, as this plan's arms work {fmt(r.get('overlap_seconds'), ' s')} while the carriage moves)"
                if (r.get("ratio_stop_and_go_bound") or 1.0) < 1.0 else ")")))
    shares = (f"carriage moving {fmt(100 * r.get('carriage_moving_share', 0), ' %', 1)} of the row time, some arm picking "
              f"{fmt(100 * r.get('picking_share', 0), ' %', 1)}")
    if moving:
        rest = r.get("picks_at_rest") or 0
        how = ("stands where it starts" if still else "never stops for a pick" if not rest else
               f"never stops for a pick, but {rest} of the {m.get('harvested')} picks {'comes' if rest == 1 else 'come'} with it at rest (where it "
               f"starts, or at its rest at the row's end)")
        p(f"  carriage          {how}; {shares}")
        if solver.get("tucked"):  # (the last tries with the carriage at rest: slower cycles, said so)
            p(f"  tucked            {tucked_text(solver['tucked'])}")
    else:
        again = solver.get("second_chance") or {}
        extra = (f" ({again['stops']} of them a second chance for {plural(again['fruit'], 'fruit', 'fruit')} a stop's cell "
                 f"left out: {again['harvested']} harvested there)" if again.get("stops") else "")
        if again.get("dropped"):  # (tried there, nothing picked: not driven to)
            extra += (f" ({plural(again['dropped'], 'second-chance stop', 'second-chance stops')} left out: "
                      f"{'its cell picks' if again['dropped'] == 1 else 'their cells pick'} nothing)")
        p(f"  stops             {r.get('stops')}{extra}, {fmt(r.get('mean_time_per_stop'), ' s')} each on average; {shares}")
    for a, causes in (r.get("idle_share") or {}).items():
        p(f"  idle {safe(a):12s} " + ", ".join(f"{k.replace('_', ' ')} {100 * v:.1f} %" for k, v in causes.items()))
    if r.get("idle_share") and moving:  # (the causes were explained only in a docstring; on the move, no stop's)
        p("    (share of the row time each arm is idle: carriage -- waiting for the carriage to bring its next fruit into "
          "reach, or at rest while it moves; others -- at rest while the carriage stands (where it starts, or at its rest "
          "at the row's end) and the other arms work; no fruit -- the same, for an arm with no fruit in the row; "
          "coordination -- holding still within its work for a neighbour; making way -- moving out of a neighbour's way)",
          highlight=False)
    elif r.get("idle_share"):
        p("    (share of the row time each arm is idle: carriage -- at rest while the carriage moves or settles; no fruit -- at a stop "
          "with nothing in its reach; others -- done at a stop, waiting for the other arms; coordination -- holding still "
          "within its work for a neighbour; making way -- moving out of a neighbour's way)", highlight=False)


def _row_planning(p, r: dict, solver: dict, moving: bool) -> None:
    """A row summary's planning time (and, stop and go, how far ahead of the carriage)."""
    from ..row.metrics import late_start

    first, known = r.get("first_motion_seconds"), r.get("first_stop_seconds", r.get("first_motion_seconds"))
    ahead = {True: "kept ahead of the carriage", False: "LATE", None: "no stop to plan"}[r.get("kept_ahead")]
    if r.get("kept_ahead") and late_start(first, r.get("row_time")):
        # ("kept ahead" read as no wait beside a first motion after 42 s of a 47 s row, --planner optimal)
        ahead = (f"kept ahead of the carriage once it moved; it stood {fmt(first, ' s')} first, "
                 f"{100 * first / r['row_time']:.0f} % of the row time, for its first stop's cell")
    later = "" if first == known else f" (first motion after {fmt(first, ' s')}: the carriage does not move before that stop's cell)"
    if moving:
        given = (solver.get("options") or {}).get("level") is not None  # (--speed: one speed, no search)
        p(f"  planning          {fmt(r.get('planning_time'), ' s')} {_of_row(r)} ({plural(r.get('plans_tried') or 0, 'full plan')} "
          f"{'at the speed given' if given else 'tried by the speed search'}, {'each ' if (r.get('plans_tried') or 0) > 1 else ''}verified"
          + ("; with the stop-and-go plan --gantry auto compared it with"
             if (solver.get("auto") or {}).get(GantryMode.STOP_AND_GO.value) else "") + ")")
    else:
        p(f"  planning          {fmt(r.get('planning_time'), ' s')} {_of_row(r)}; first stop known after {fmt(known, ' s')}{later}; the slowest stop took {fmt(r.get('slowest_stop_seconds'), ' s')} "
          f"to plan, least slack {fmt(r.get('least_slack_seconds'), ' s')} ({ahead})"
          + ("; the planning time counts the on-the-move plans --gantry auto compared it with" if solver.get("auto") else ""))


def _margin_line(p, ver: dict) -> None:
    """The certified margin beyond the required clearance, overall and per pair (a cell's and a row's summary)."""
    pairs = ver.get("pairs") or {}
    margin = ver.get("margin")
    if margin is not None and math.isfinite(margin):
        p(f"  margin            {1000 * margin:.1f} mm certified beyond the clearance (per pair: "
          + ", ".join(f"{safe(k)} {1000 * v['margin']:.1f} mm" for k, v in pairs.items() if v.get("margin") is not None) + ")")


def _jerk_line(p, m: dict, ver: dict) -> None:
    """Each arm's RMS and peak jerk, unbounded where its acceleration steps (a cell's and a row's summary)."""
    per = m.get("per_arm") or {}
    steps = ver.get("acceleration_steps") or {}  # (their sampled jerk is a grid's figure: 10 x at 10 x the rate)
    if any("rms_jerk" in v for v in per.values()):
        p("  jerk RMS / peak   " + ", ".join(f"{safe(a)} " + (f"unbounded (acceleration steps up to {steps[a]:.1f} rad/s^2)"
                                                         if a in steps else f"{_jerk(v['rms_jerk'])} / {_jerk(v['peak_jerk'])}")
                                     for a, v in per.items() if "rms_jerk" in v) + (" rad/s^3" if set(per) - set(steps) else ""))


def _warnings(p, verification) -> None:
    """The verifier's warnings in one line (counted by kind; verification.json lists each)."""
    warnings = getattr(verification, "warnings", None) or []
    if warnings:
        kinds = Counter(w.kind.value for w in warnings)
        p(f"  warnings          {len(warnings)}, which do not fail the plan: "
          + "; ".join(f"{n} {k} ({WARNING_WORDS.get(k, k)})" for k, n in sorted(kinds.items())))


def print_summary(console, res) -> None:
    """The summary ``coplan solve`` prints of a :class:`coplan.pipeline.SolveResult`."""
    if getattr(res, "row", None) is not None:
        return print_row_summary(console, res)
    m = res.plan.metrics
    ver = res.plan.verification or {}
    colour = "green" if res.success else "red"
    p = console.print
    p(f"[bold]{safe(res.problem.name)}[/] -- planner [bold]{safe(res.plan.planner_name)}[/], status [bold {colour}]{res.plan.status.value}[/]")
    _say_if_no_fruit(p, res.problem)
    p(f"  fruit             {fruit_line(m)}")
    partial = m.get("lower_bound") is not None and (m.get("harvested") or 0) < (m.get("harvestable") or 0)
    p(f"  makespan          {fmt(m.get('makespan'), ' s')}   (lower bound {fmt(m.get('lower_bound'), ' s')}"
      + (f" for all {m.get('harvestable')} harvestable fruit: no ratio for a plan that harvests fewer)" if partial
         else f", ratio {fmt(m.get('gap_to_lower_bound'), '', 3)})"))
    if m.get("optimality") == "proven":
        whole = m.get("harvestable", 0) >= m.get("reachable", 0)  # (unreachable fruit need no words here)
        p("  optimality        [bold green]proven[/]: the makespan meets the lower bound" +
          ("" if whole else f" (for the {m.get('harvestable')} harvestable fruit: no plan can harvest the others)"))
    # (the planner's clock runs through the course's baseline, made while it works: "solve time"
    # below leaves that out, so the clock says so -- a last improvement "after" the solve time)
    base_s = (res.plan.solver.get("timings") or {}).get("baseline")
    since = "since the planner started" + (f"; its clock also runs through the {base_s:.2f} s the course's baseline "
                                           f"takes, made right after the first plan" if base_s else "")
    if m.get("coordinated_makespan") is not None:
        gain = max(0.0, 100 * (m.get('improvement_over_coordinated') or 0.0))  # (a last digit's rounding said "-0.0 %")
        p(f"  coordinated plan  {fmt(m.get('coordinated_makespan'), ' s')}   (improved by {fmt(gain, ' %', 1)};"
          f" first verified plan at {fmt(m.get('time_to_first_verified'), ' s')}, last improvement at {fmt(m.get('time_of_last_improvement'), ' s')},"
          f" {since})")
        reached = [f"{r} x at {t:.2f} s" for r, t in (m.get("time_to_ratio") or {}).items() if t is not None]
        if reached:
            p("  bound reached     within " + ", ".join(reached) + f" (of the lower bound, {since})")
    if m.get("baseline_makespan") is not None:
        p(f"  heuristic plan    {fmt(m.get('baseline_makespan'), ' s')}   (the course's baseline, {m.get('baseline_status', '?')}; baseline.json)")
    p(f"  cycle time/fruit  {fmt(m.get('cycle_time'), ' s')} worst arm, {fmt(m.get('cycle_time_mean'), ' s')} mean")
    if ver:
        least = ver.get("min_clearance")
        if least is None or not math.isfinite(least):  # one arm, or arms too far apart ever to touch
            p(f"  collisions found  {ver.get('collision_count', '-')}   least clearance - (no two arms can touch)")
        else:
            p(f"  collisions found  {ver.get('collision_count', '-')}   least clearance {fmt(least, ' m', 4)}"
              f" (certified {fmt(ver.get('certified_clearance'), ' m', 4)}, required {fmt(res.problem.task.clearance, ' m', 3)})")
            _margin_line(p, ver)
            wid = (res.plan.solver or {}).get("widen") or {}
            if wid.get("accepted"):
                p(f"  widened           margin {1000 * wid['margin_before']:.1f} -> {1000 * wid['margin']:.1f} mm at the same makespan "
                  f"(the stage took {fmt(wid.get('wall_seconds'), ' s', 2)} of planning; option widen)")
            elif wid.get("reason"):
                p(f"  not widened       {safe(wid['reason'])}")
            rg = (res.plan.solver or {}).get("regroup") or {}
            if rg.get("accepted"):
                p(f"  regrouped         margin {1000 * rg['margin_before']:.1f} -> {1000 * rg['margin']:.1f} mm, "
                  f"{rg['makespan_before']:.3f} -> {rg['makespan']:.3f} s: other events, planned at a clearance of "
                  f"{1000 * rg['clearance']:.1f} mm (the stage took {fmt(rg.get('wall_seconds'), ' s', 2)}; option regroup)")
            elif rg.get("status") == "ran":
                p(f"  not regrouped     planned again at a clearance of {1000 * rg['clearance']:.1f} mm: {safe(rg.get('reason', ''))}")
        _jerk_line(p, m, ver)
        if not ver.get("passed", False):
            p(f"  violations        {ver.get('violation_count', '?')} ({', '.join(ver.get('violation_kinds', [])) or 'see verification.json'})")
        _warnings(p, res.verification)
    solver = res.plan.solver
    if solver.get("message"):
        p(f"  solver            {safe(solver.get('status', ''))}: {safe(solver['message'])}")
    if solver.get("planning_margin_dropped"):
        p(f"  planning buffer   none: with {1000 * solver['planning_margin_dropped']:g} mm beyond the clearance no candidate could be "
          "coordinated, so it was planned with the clearance alone (verified)")
    left = solver.get("left_out") or {}
    if left:  # fruit the planner could not fit in, and why (all of them in plan.json: solver.left_out)
        p(f"  left out          {plural(len(left), 'fruit', 'fruit')}:")
        for fid, why in list(left.items())[:5]:
            p(f"    {safe(fid):14s}{safe(why)}")
        if len(left) > 5:
            p(f"    ... and {len(left) - 5} more (plan.json: solver.left_out)")
    tm = res.plan.solver.get("timings", {})
    parts = [k for k in ("allocation", "coordinated", "retime", "search", "refine", "polish", "widen", "regroup", "plan", "verify") if k in tm]
    if parts:
        planned = sum(tm[k] for k in parts)
        split = ", ".join(f"{k} {tm[k]:.2f}" for k in parts)
        wrote = res.timings.get("write")
        p(f"  solve time        {planned:.2f} s ({split}; with the screen, bound and baseline {res.timings.get('total', planned):.2f} s"
          + (f"; the files written in {wrote:.2f} s)" if wrote is not None else ")"))
    for k, v in res.files.items():  # every file written: plan (JSON, CSV, NPZ), verification, baseline, animation
        p(f"  wrote             {safe(v)}")
    if res.previous is not None:
        p(f"  previous run      kept in {safe(res.previous)}")


#: What each verifier warning means, for the report (none of them fails a plan).
WARNING_WORDS = {
    "singular": "an arm passes near a singular pose: manipulability below task.singularity_threshold, "
                "where small joint errors move the tip a lot",
    "not_harvested": "a reachable fruit is not picked and placed: the plan is partial",
    "problem_name": "the plan names another problem",
    "events_inferred": "the plan declares no events; they were inferred from its motion",
    "not_home": "an arm ends away from its home pose",
    "stated_figures": "the plan file's own figures (metrics) are not its motion's",
}


_SHOWN = 10  # fruit ids a verdict line lists (the rest counted; verification.json has them all)


def print_verification(console, problem, ver, max_rows: int = 25, makespan: float | None = None,
                       label: str | None = None, against: str | None = None) -> None:
    """Verdict, clearances, peaks and a short table of the violations. ``makespan``: the plan's
    last place (s), told apart from its length (the plan goes on, e.g. with the arms' way home);
    ``label``: the plan's :attr:`coplan.plan.Plan.label` (a row's says how its carriage moved);
    ``against``: the problem file the plan was checked against, said on its own line."""
    from rich.table import Table

    from ..plancsv import CSV_PLANNER, EXPORT_PLANNER

    p = console.print
    s = ver.summary()
    verdict = "[bold green]passed[/]" if ver.passed else "[bold red]FAILED[/]"
    span = "" if makespan is None else f" (makespan {makespan:.2f} s: the last place)"
    what = ("a plan.csv replay (its planner not recorded)" if ver.planner == CSV_PLANNER else
            "a coplan export table (its planner not recorded)" if ver.planner == EXPORT_PLANNER else f"{safe(label or ver.planner)} plan")
    left = list(ver.unharvested)
    shown = ", ".join(left[:_SHOWN]) + (f" and {len(left) - _SHOWN} more" if len(left) > _SHOWN else "")
    # what fails the plan first (the violations, by kind), then what it leaves
    kinds = Counter(v.kind.value for v in ver.violations)
    why = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items(), key=lambda kv: (-kv[1], kv[0])))
    p(f"[bold]{safe(problem.name)}[/] -- {what} of {ver.duration:.2f} s{span}: {verdict}"
      + (f" [bold red]({plural(len(ver.violations), 'violation')}: {why})[/]" if ver.violations else "")
      + ("" if ver.complete else f" [yellow](not harvested: {plural(len(left), 'fruit', 'fruit')}: {safe(shown)})[/]"))
    from ..verify.verdict import WarningKind  # (here: this module stays light to import)

    for w in ver.warnings:
        if w.kind == WarningKind.PROBLEM_NAME:  # (a plan of another problem fails for that, not for its own faults: said first)
            p(f"  [yellow]another problem[/]   {safe(w.message)}: what it leaves or breaks here may be fine there")
    if against:  # (which limits and fruit the verdict holds it to: a plan alone was checked against what it records)
        p(f"  problem           {safe(against)}")
    for w in ver.warnings:
        if w.kind == WarningKind.EVENTS_INFERRED:  # harvesting judged from events the verifier inferred: say so
            p(f"  [yellow]events inferred[/]   {safe(w.message.removeprefix('the plan declares no events: '))}")
    for w in ver.warnings:
        if w.kind == WarningKind.STATED_FIGURES:  # (an edited plan.json stated 90 s and 200 fruit beside a 186 s motion)
            p(f"  [yellow]stated figures[/]    {safe(w.message)}")
    if not ver.pairs:
        p("  least clearance   - (no two arms can touch)")
    else:
        # ("sampled" read as the plan's samples: the figure is the closest the verifier found on its
        # fine grid between them, the certified one a bound over every instant)
        p(f"  least clearance   {fmt(s['min_clearance'], ' m', 4)} found (between samples too), "
          f"{fmt(s['certified_clearance'], ' m', 4)} certified"
          f" (required {fmt(ver.required_clearance, ' m', 3)}); {plural(s['collision_count'], 'collision interval')}")
    for pc in ver.pairs:
        p(f"    {safe(pc.key):18s} {fmt(pc.min_clearance, ' m', 4)} at {pc.t:.3f} s (links {pc.links[0]}/{pc.links[1]}), certified {fmt(pc.certified, ' m', 4)}")
    wp = ver.worst_pick
    if wp is not None:  # (a pick 4.5 mm off its fruit passed with no word of it)
        which = f"{safe(wp['fruit'])} by {safe(wp['arm'])} at {wp['t']:.2f} s; tolerance {1000 * ver.options.position_tolerance:g} mm"
        p(f"  picks             every tip within {1000 * wp['distance']:.2f} mm of its fruit at its closest (the farthest: {which})"
          if wp["distance"] <= ver.options.position_tolerance else
          f"  picks             the farthest tip from its fruit {1000 * wp['distance']:.2f} mm at its closest ({which})",
          highlight=False)
    steps = ver.acceleration_steps()
    for arm, pk in ver.peaks.items():
        over = max(pk.values()) > 1.005 and not any(arm in v.arms for v in ver.violations)
        # (an acceleration step's jerk read "13.14 of the limits" here beside violations saying it is unbounded)
        jerk = (" of the limits, jerk unbounded (its acceleration steps)" if arm in steps else
                f", jerk {pk['jerk']:.2f} of the limits")
        p(f"  peaks {safe(arm):12s} velocity {pk['velocity']:.2f}, acceleration {pk['acceleration']:.2f}{jerk}"
          + (" (over 1 only by the rounding of the plan file's positions, which the check allows)" if over else ""))
    if ver.fcl is not None:
        agree = "agrees" if ver.fcl.agree else "[bold red]DISAGREES[/]"
        p(f"  FCL cross-check   {agree} ({ver.fcl.samples} instants, {ver.fcl.queries} link pairs, max diff {ver.fcl.max_abs_diff:.1e} m)")
    _warnings(p, ver)
    if not ver.violations:
        return
    table = Table(title=plural(len(ver.violations), "violation") + " (by kind, the arms' contact first; then by time)",
                  title_justify="left")
    for col in ("kind", "arms", "t (s)", "value", "limit", "detail"):
        table.add_column(col, overflow="fold")
    order = {k: i for i, k in enumerate(type(ver.violations[0].kind))}  # (ViolationKind's order: collision, clearance, ...)
    for v in sorted(ver.violations, key=lambda v: (order[v.kind], v.t))[:max_rows]:
        span = f"{v.t:.3f}" if v.t_start is None or v.t_end is None or v.t_end - v.t_start < 1e-9 else f"{v.t_start:.3f}..{v.t_end:.3f}"
        detail = " ".join(x for x in (f"fruit {v.fruit}" if v.fruit else "", v.message) if x)
        table.add_row(v.kind.value, safe(",".join(v.arms)), span, fmt(v.value, "", 4), fmt(v.limit, "", 4), safe(detail))
    print_table(console, table)
    if len(ver.violations) > max_rows:
        p(f"  ... and {len(ver.violations) - max_rows} more (see verification.json: --out)")


def _jerk(v: float) -> str:
    """A jerk figure: whole rad/s^3, or three significant digits below 100 (slow joints at 0.05
    rad/s^3 were shown as 0)."""
    return f"{v:.0f}" if abs(v) >= 100 or v == 0 else f"{v:.3g}"
