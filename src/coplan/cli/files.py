"""The ``coplan export`` and ``coplan schema`` commands (registered in :mod:`coplan.cli`; light to
import: the heavy work is imported inside each command)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.markup import escape

from .errors import printable
from .kinds import ExportFormat, SchemaKind

__all__ = ["export_cmd", "schema_cmd"]

_out = Console(soft_wrap=True)


def export_cmd(
    plan: Annotated[Path, typer.Argument(help="plan.json to export.")],
    rate: Annotated[float, typer.Option(help="Points per second, Hz.")] = 100.0,
    fmt: Annotated[ExportFormat, typer.Option("--format", "-f", help="csv: one file, every arm; json, yaml: a ROS 2 "
                                              "trajectory_msgs/JointTrajectory per arm, in a folder.")] = ExportFormat.CSV,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="CSV file, or folder (default: beside the plan).")] = None,
):
    """Export a plan for a joint controller: positions, velocities and accelerations per joint at a chosen rate."""
    from .export import export_command

    for path in export_command(plan, rate, fmt, out):
        _out.print(f"wrote {escape(printable(path))}")


def schema_cmd(kind: Annotated[SchemaKind, typer.Argument(help="Which file format.")]):
    """Print the JSON Schema of problem files or plan files (shipped as coplan/schemas/*.schema.json)."""
    typer.echo((Path(__file__).with_name("schemas") / f"{kind.value}.schema.json").read_text(), nl=False)
