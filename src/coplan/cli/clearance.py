"""``coplan compare PROBLEM --clearance-sweep``: the makespan against the clearance asked for
(run by :func:`coplan.report.clearance.clearance_cost`, printed here)."""

from __future__ import annotations

import json
from pathlib import Path

from ..kinds import ExitCode, PlannerKind
from . import failures
from .checks import budget_hint, check_time_limit, fail, solver_options
from .console import ProgressDisplay
from .summary import print_table, safe

__all__ = ["clearance_sweep", "run_clearance_sweep"]


def clearance_sweep(source: Path, planner, extra, out: Path, figures: bool, time_limit, options_file, as_json: bool,
                    out_console, err_console) -> ExitCode:
    """``coplan compare PROBLEM --clearance-sweep``: its inputs checked, then the sweep run."""
    if not source.exists():  # nothing there: bad input (3), as `coplan compare` without the sweep says
        from ..problem.load import load_problem

        load_problem(source)
    if not source.is_file():
        fail(ExitCode.USAGE, f"--clearance-sweep: expected one problem file, found the folder {safe(source)}")
    if planner and len(planner) > 1:
        fail(ExitCode.USAGE, f"--clearance-sweep: expected at most one --planner, found {len(planner)}")
    if extra and any(not (0 <= e <= 1000) for e in extra):
        fail(ExitCode.USAGE, f"--extra: expected extra clearances from 0 to 1000 mm, found {extra}")
    from .row import rows_in

    row = bool(rows_in(source))
    try:  # (a row's default is its cells' default, coordinated, as `coplan solve ROW`: the optimal cells took 10 min on sparse_row)
        kind = PlannerKind(planner[0].split(":")[0]) if planner else PlannerKind.COORDINATED if row else PlannerKind.OPTIMAL
    except ValueError:
        fail(ExitCode.USAGE, f"--planner: expected heuristic, coordinated or optimal, found {planner[0]!r}")
    check_time_limit(time_limit)
    failures.check_out_dir(out)
    options = solver_options(options_file, time_limit, kind != PlannerKind.HEURISTIC)
    hint = budget_hint(kind, time_limit) if kind == PlannerKind.OPTIMAL and not row else None  # (a row takes no --time-limit)
    return run_clearance_sweep(source, kind, extra, out, figures, options, hint, as_json, out_console, err_console)


def run_clearance_sweep(source: Path, kind, extra, out: Path, figures: bool, options, hint, as_json: bool,
                        out_console, err_console) -> ExitCode:
    """Run the sweep, print its table (or its JSON); 7 when some plan was not verified."""
    from rich.table import Table

    from ..report.clearance import COLUMNS, EXTRAS_MM, cell, clearance_cost

    with ProgressDisplay(err_console, quiet=as_json, hint=hint) as say:
        cost = clearance_cost(source, out, extra or EXTRAS_MM, kind, options, figures, say)
    failed = any(r.get("makespan") and not r.get("verified") for r in cost.rows)
    code = ExitCode.SOLVER_FAILED if failed else ExitCode.OK
    if as_json:  # (with the exit code, as every document of a command that ran)
        print(json.dumps(cost.to_dict() | failures.exit_fields(code), indent=1, allow_nan=False))
    else:
        table = Table(title=f"{safe(cost.problem)}: makespan against the clearance asked for ({cost.planner} planner)")
        for _, head in COLUMNS:
            table.add_column(head)
        for r in cost.rows:
            table.add_row(*[safe(cell(r, k)) for k, _ in COLUMNS])
        print_table(out_console, table)
        out_console.print(f"wrote {safe(cost.files['json'])}, {safe(cost.files['markdown'])}"
                          + (f", {safe(cost.files['figure'])}" if cost.files.get("figure") else "")
                          + " and each clearance's plan (plus_<mm>mm/) and problem (plus_<mm>mm.yaml) beside them")
    return code
