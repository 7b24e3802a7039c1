"""``plan.csv``: the replay table coplan writes beside ``plan.json``, and reads back.

One header row, ``t,<arm>_q1,<arm>_q2,...`` (written with the :mod:`csv` module, so an arm
name with a comma, a quote or a line break is quoted and survives), then one row per sample:
the time (s) and each arm's two joint angles (rad), seven decimals. A row plan has a column
``gantry_x`` after ``t``: the carriage's position (m), on which the verifier puts the bases,
the bins and the fruit in the carriage frame (without it a row plan cannot be checked). The table holds the
motion only -- no events, allocation or metrics -- so a plan read from it has no events and
the verifier infers them from the motion (:mod:`coplan.verify.infer`).

The reader also takes a ``coplan export`` CSV (:mod:`coplan.report.export`: ``t``, per arm
``<arm>_q1, <arm>_q2, <arm>_qd1, <arm>_qd2, <arm>_qdd1, <arm>_qdd2``, a row's ``carriage_x,
carriage_v, carriage_a`` last): its positions and the carriage's are read, the rates left, so
that ``coplan verify`` checks the very table a controller is given.

This module reads and writes the table only; :func:`coplan.plan.load_plan` builds the plan.
Errors are :class:`~coplan.errors.PlanFileError` issues with the file's line.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable

import numpy as np

from .errors import Issue, PlanFileError

__all__ = ["csv_header", "read_csv_samples", "CSV_PLANNER"]

CSV_PLANNER = "unknown (plan.csv)"  # a CSV replay does not say which planner made it
EXPORT_PLANNER = "unknown (coplan export CSV)"  # nor does an export's table


def csv_planner(raw: bytes) -> str:
    """What a CSV table's plan is called: :data:`EXPORT_PLANNER` for a ``coplan export`` table's
    header, else :data:`CSV_PLANNER` (its first line only is read; a bad one says nothing here)."""
    try:
        header = next(csv.reader(io.StringIO(raw.split(b"\n", 1)[0].decode("utf-8-sig"))), [])
    except (UnicodeDecodeError, csv.Error):
        return CSV_PLANNER
    return EXPORT_PLANNER if _export_layout(header) is not None else CSV_PLANNER


def csv_header(arm_names: Iterable[str], carriage: bool = False) -> str:
    """The header row (no line end): ``t`` (then ``gantry_x`` for a row: ``carriage``) and
    ``<arm>_q1``, ``<arm>_q2`` per arm, CSV-quoted."""
    buf = io.StringIO()
    # (the line end is what makes the writer quote a name holding \r or \n: then dropped)
    csv.writer(buf, lineterminator="\r\n").writerow(["t"] + (["gantry_x"] if carriage else [])
                                                    + [f"{a}_q{k}" for a in arm_names for k in (1, 2)])
    return buf.getvalue().removesuffix("\r\n")


_EXPORT = ("q1", "q2", "qd1", "qd2", "qdd1", "qdd2")
_EXPORT_CARRIAGE = ["carriage_x", "carriage_v", "carriage_a"]


def _export_layout(header: list[str]) -> tuple[list[str], list[int], int | None] | None:
    """A ``coplan export`` CSV's header (``t``, per arm ``<arm>_q1 ... <arm>_qdd2``, each arm
    once, a row's ``carriage_x, carriage_v, carriage_a`` last): its arm names, each arm's first
    column and the carriage's; None if it is not one."""
    cols = [c.strip() for c in header]
    if not cols or cols[0] != "t":
        return None
    x = None
    if cols[-3:] == _EXPORT_CARRIAGE:
        x, cols = len(cols) - 3, cols[:-3]
    body = cols[1:]
    if not body or len(body) % 6:
        return None
    names = []
    for i in range(0, len(body), 6):
        stem = body[i][:-3] if body[i].endswith("_q1") else ""
        if not stem or body[i:i + 6] != [f"{stem}_{c}" for c in _EXPORT]:
            return None
        names.append(stem)
    if len(set(names)) != len(names):
        return None
    return names, [1 + i for i in range(0, len(body), 6)], x


def _export_mistake(cols: list[str]) -> str | None:
    """Why a header with an export's columns (an ``<arm>_qd1`` ... or a ``carriage_*``) is not an
    export's: the columns it lacks, those it has that none has, or their order; None for a header
    with none of them (a ``plan.csv``'s, said by its own rules: they blamed valid columns, "expected
    a pair '<arm>_q1,<arm>_q2', found 'arm1_qd1', 'arm1_qd2'", where an export lacked carriage_x)."""
    rates = tuple(f"_{c}" for c in _EXPORT[2:])
    if not any(c.endswith(rates) or c in _EXPORT_CARRIAGE for c in cols):
        return None
    stems = list(dict.fromkeys(c.rsplit("_", 1)[0] for c in cols if c.endswith(tuple(f"_{c}" for c in _EXPORT))
                               and c not in _EXPORT_CARRIAGE))
    expected = ["t"] + [f"{a}_{c}" for a in stems for c in _EXPORT] + (
        _EXPORT_CARRIAGE if any(c in _EXPORT_CARRIAGE for c in cols) else [])
    what = "an export's header row (t, per arm <arm>_q1 ... <arm>_qdd2, a row's carriage_x, carriage_v, carriage_a last)"
    missing = [c for c in expected if c not in cols]
    extra = [c for c in cols if c not in expected]
    if missing:
        return f"expected {what}, found it without {', '.join(map(repr, missing))}"
    if extra:
        return f"expected {what}, found {'columns' if len(extra) > 1 else 'a column'} no export has: {', '.join(map(repr, extra))}"
    return f"expected {what}, found its columns in another order: {', '.join(cols)}"


def _layout(header: list[str]) -> tuple[list[str], list[int], int | None, bool, str | None]:
    """A header row's arm names, the column of each arm's q1 (q2 follows it), the carriage's
    column (None: a cell), whether it is an export's, or the reason it is neither a
    ``plan.csv`` nor an export's header. Every row has a value per header column."""
    export = _export_layout(header)
    if export is not None:
        return (*export, True, None)
    cols = [c.strip() for c in header]
    if cols == ["arm", "fruit", "kind", "t_start", "t_end"]:  # (it said "found first column 'arm'")
        return [], [], None, False, ("expected a plan's samples, found an export's events (the picks and places beside a "
                                     "`coplan export` CSV, <name>.events.csv): give the export CSV itself, or its plan")
    twice = next((c for c in cols if cols.count(c) > 1), None)
    if twice is not None:  # (it blamed the valid columns after it: "expected a pair '<arm>_q1,<arm>_q2', found 'left_qd1', ...")
        at = [i + 1 for i, c in enumerate(cols) if c == twice]
        return [], [], None, False, (f"expected each column once in the header row, found {twice!r} in columns "
                                     f"{', '.join(map(str, at))}")
    why = _export_mistake(cols)
    if why is not None:
        return [], [], None, False, why
    names, why = _arm_names(header)
    x = 1 if not why and header[1].strip() == "gantry_x" else None
    return names, [1 + (x is not None) + 2 * i for i in range(len(names))], x, False, why


def _arm_names(header: list[str]) -> tuple[list[str], str | None]:
    """Arm names from a ``plan.csv`` header row, or the reason it is not one."""
    expect = "a header row 't,<arm>_q1,<arm>_q2,...'"
    if not header or header[0].strip() != "t":
        return [], f"expected {expect}, found first column {header[0] if header else ''!r}"
    cols = header[2:] if len(header) > 1 and header[1].strip() == "gantry_x" else header[1:]
    if not cols or len(cols) % 2:
        lone = [f"{c[:-1]}{'2' if c.endswith('_q1') else '1'}" for c in cols if c.endswith(("_q1", "_q2"))
                and f"{c[:-1]}{'2' if c.endswith('_q1') else '1'}" not in cols]
        if lone:  # (it said "found 5 columns after t", not which)
            return [], f"expected {expect} (two columns per arm), found it without {', '.join(map(repr, lone))}"
        return [], f"expected {expect} (two columns per arm), found {len(cols)} column{'s' if len(cols) != 1 else ''} after t"
    names = []
    for a, b in zip(cols[0::2], cols[1::2]):
        if not (a.endswith("_q1") and b.endswith("_q2") and a[:-3] == b[:-3] and a[:-3]):
            return [], f"expected a pair '<arm>_q1,<arm>_q2', found {a!r}, {b!r}"
        names.append(a[:-3])
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        return [], f"expected each arm once, found {dup[0]!r} more than once"
    return names, None


def read_csv_samples(raw: bytes, source: str | None = None) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, np.ndarray | None]:
    """Read a ``plan.csv`` (bytes of the file): ``(time, q, lines, gantry_x)`` -- the times (N,),
    each arm's joint angles (N, 2), the file line of each sample (N,), for errors about the time
    grid, which :func:`coplan.plan.load_plan` checks when it builds the :class:`~coplan.plan.Plan`,
    and a row plan's carriage positions (N,) (None: a cell's table)."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise PlanFileError([Issue("", f"expected UTF-8 CSV text, found the undecodable byte 0x{raw[e.start]:02x}", line)], source) from None
    buf = io.StringIO(text, newline="")
    reader = csv.reader(buf)  # it reads the stream line by line: after the header, ``buf`` holds the body
    try:
        header = next(reader, [])
    except csv.Error as e:
        raise PlanFileError([Issue("", f"expected a CSV header row, found a syntax error: {e}", 1)], source) from None
    names, at, x_col, export, why = _layout(header)
    if why:
        raise PlanFileError([Issue("header", why, 1)], source)  # (it read "<top>", a YAML word, of a CSV's first row)
    first = reader.line_num + 1  # the header may span lines (a quoted name with a line break)
    body = buf.read().splitlines()
    width = len(header)
    rows = np.empty((len(body), width))
    lines = np.zeros(len(body), dtype=int)  # the file line of each row
    issues: list[Issue] = []
    n = 0
    for k, line in enumerate(body):
        if not line.strip():
            continue
        cells = line.split(",")
        where = first + k
        if len(cells) != width:
            what = ("one per column of the export's header" if export else
                    f"t{', gantry_x' if x_col is not None else ''} and two angles for each of {len(names)} arm{'s' if len(names) != 1 else ''}")
            issues.append(Issue("", f"expected {width} values ({what}), found {len(cells)}", where))
        else:
            try:
                rows[n] = [float(c) for c in cells]
            except ValueError:
                j = next(j for j, c in enumerate(cells) if not _is_float(c))
                issues.append(Issue(_column(header, j), f"expected numbers, found {cells[j].strip()[:40]!r}", where))
            else:
                if not all(math.isfinite(x) for x in rows[n]):
                    j = next(j for j, x in enumerate(rows[n]) if not math.isfinite(x))
                    issues.append(Issue(_column(header, j), "expected finite numbers, found "
                                        + ", ".join(c.strip() for c in cells if not math.isfinite(float(c)))[:60], where))
                lines[n] = where
                n += 1
        if len(issues) >= 20:  # a file that is not a plan: the first problems say enough
            break
    if issues:
        raise PlanFileError(issues, source)
    rows = rows[:n]
    if export:  # the velocities and accelerations a controller follows: those of the positions the verifier checks
        axes = [(j, 2, j + 2, j + 4) for j in at] + ([(x_col, 1, x_col + 1, x_col + 2)] if x_col is not None else [])
        _check_rates(rows, axes, header, lines[:n], source)
    q = {a: rows[:, j: j + 2].copy() for a, j in zip(names, at)}
    return rows[:, 0], q, lines[:n], (rows[:, x_col].copy() if x_col is not None else None)


def _check_rates(rows: np.ndarray, axes: list[tuple[int, int, int, int]], header: list[str], lines: np.ndarray,
                 source: str | None) -> None:
    """An export's velocity and acceleration columns against the central differences of its
    positions (the verifier checks only the positions: a file whose qd columns were 5 x the
    limit passed): each within 2 % of the column's largest value (and 1e-3 rad/s, rad/s^2) and
    what the motion's jerk makes of the differences' own error (below). ``axes``:
    (first position column, how many, first velocity column, first acceleration column) of each
    arm (two joints) and the carriage (one axis)."""
    t = rows[:, 0]
    if t.size < 5:
        return
    dt = float(np.median(np.diff(t)))
    if dt > 0.0100001:  # (coarser than 100 Hz: the verifier refuses the grid itself, and says so)
        return
    issues: list[Issue] = []
    for j, w, jv, ja in axes:
        q = rows[:, j:j + w]
        est = {jv: (q[2:] - q[:-2]) / (2 * dt), ja: (q[2:] - 2 * q[1:-1] + q[:-2]) / dt**2}
        # the differences' own error on the export's smooth curve grows with its jerk: where the
        # jerk switches sign (a time-optimal move), the second difference departs from the exact
        # acceleration by up to the jerk's change x dt / 6 -- at 100 Hz 2.2 % of a 12 rad/s^2 peak
        # on locked_arms, which a flat 2 % refused in coplan's own export
        jerk = float(np.abs(np.diff(q, n=3, axis=0)).max()) / dt**3  # (five samples or more: above)
        slack = {jv: jerk * dt**2, ja: jerk * dt / 2}
        for c0, what in ((jv, "velocity"), (ja, "acceleration")):
            col = rows[1:-1, c0:c0 + w]
            tol = 0.02 * max(float(np.abs(est[c0]).max()), float(np.abs(col).max())) + 1e-3 + slack[c0]
            err = np.abs(col - est[c0])
            if err.max() > tol:
                k, jn = np.unravel_index(int(np.argmax(err)), err.shape)
                issues.append(Issue(_column(header, c0 + jn),
                                    f"expected the {what} of the positions (their central difference, {est[c0][k, jn]:.4g}), "
                                    f"found {col[k, jn]:.4g} at t = {t[k + 1]:.3f} s: a controller following this column "
                                    f"would not follow the positions coplan verify checks", int(lines[k + 1])))
    if issues:
        raise PlanFileError(issues, source)


def _column(header: list[str], j: int) -> str:
    """The name of column ``j`` (its header cell), the key path of a bad value in it."""
    return header[j].strip() if j < len(header) else f"column {j + 1}"


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
