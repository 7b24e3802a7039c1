"""``coplan compare PROBLEM --clearance-sweep``: the makespan against the clearance asked for
(run by :func:`coplan.report.clearance.clearance_cost`, printed here)."""

from __future__ import annotations

import json
from pathlib import Path

from ..kinds import ExitCode
from .console import ProgressDisplay
from .summary import safe

__all__ = ["run_clearance_sweep"]


def run_clearance_sweep(source: Path, kind, extra, out: Path, figures: bool, options, hint, as_json: bool,
                        out_console, err_console) -> ExitCode:
    """Run the sweep, print its table (or its JSON); 7 when some plan was not verified."""
    from rich.table import Table

    from ..report.clearance import COLUMNS, EXTRAS_MM, cell, clearance_cost

    with ProgressDisplay(err_console, quiet=as_json, hint=hint) as say:
        cost = clearance_cost(source, out, extra or EXTRAS_MM, kind, options, figures, say)
    if as_json:
        print(json.dumps(cost.to_dict(), indent=1, allow_nan=False))
    else:
        table = Table(title=f"{safe(cost.problem)}: makespan against the clearance asked for ({cost.planner} planner)")
        for _, head in COLUMNS:
            table.add_column(head)
        for r in cost.rows:
            table.add_row(*[safe(cell(r, k)) for k, _ in COLUMNS])
        out_console.print(table)
        out_console.print(f"wrote {safe(cost.files['json'])} and {safe(cost.files['markdown'])}")
    failed = any(r.get("makespan") and not r.get("verified") for r in cost.rows)
    return ExitCode.SOLVER_FAILED if failed else ExitCode.OK
