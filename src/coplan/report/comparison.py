"""Side-by-side comparison of planners (``coplan compare PROBLEM|FOLDER``).

Entry point: :func:`compare`. For every problem (one file, or every ``*.yaml`` in a folder)
and every planner spec (``heuristic``, ``optimal``, or ``planner:allocation`` such as
``heuristic:makespan``), it solves with :func:`coplan.pipeline.solve` (which verifies the
plan with :func:`coplan.verify.verify`), collects the figures below, and writes
``compare.json`` and ``compare.md`` (plus each run's ``plan.json``/``verification.json`` in
``OUT/<problem>/<planner>/`` and, with ``figures=True``, the comparison figures in
``OUT/<problem>/``).

Figures per run: status and verdict; fruit harvested / reachable / unreachable; makespan;
cycle time per fruit (worst arm and mean); throughput (fruit/s); each arm's fruit count and
idle fraction; least clearance (sampled and certified) and collision intervals; peak
velocity / acceleration / jerk as fractions of the limits; planning time (wall-clock of the
whole solve, verification included); the makespan's lower bound and ratio to it. With
several problems the report aggregates per planner: counts, medians and worst cases.
"""

from __future__ import annotations

import errno
import json
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..allocate.allocation import AllocationMethod, lower_bound
from ..errors import Issue, ProblemError
from ..plan import Plan, PlannerKind, PlanStatus
from ..problem.model import Problem
from ..problem.load import load_problem
from ..output import atomic_text, check_folder, is_run_folder, keep_reports
from ..progress import ProgressCallbackError, Tick, nested, speaker, ticker
from .aggregate import aggregate
from .compared import Comparison, rich_tables, same_source, to_markdown

__all__ = ["PlannerSpec", "DEFAULT_PLANNERS", "Comparison", "compare", "run_row", "aggregate", "to_markdown", "rich_tables"]

DEFAULT_PLANNERS = ("heuristic", "coordinated", "optimal")


@dataclass(frozen=True)
class PlannerSpec:
    """A planner and optionally its allocation method; written ``planner[:allocation]``."""

    planner: PlannerKind
    allocation: AllocationMethod | None = None

    @classmethod
    def parse(cls, text: "str | PlannerSpec") -> "PlannerSpec":
        if isinstance(text, PlannerSpec):
            return text
        name, _, alloc = str(text).strip().partition(":")
        try:
            return cls(PlannerKind(name), AllocationMethod(alloc) if alloc else None)
        except ValueError:
            raise ValueError(
                f"expected planner[:allocation] with planner in {[k.value for k in PlannerKind]} and allocation in "
                f"{[m.value for m in AllocationMethod]}, found {text!r}"
            ) from None

    @property
    def label(self) -> str:
        return self.planner.value + (f":{self.allocation.value}" if self.allocation else "")

    @property
    def folder(self) -> str:
        return self.label.replace(":", "-")


def _ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a is not None and b and b > 0 else None


def run_row(problem: Problem, spec: PlannerSpec, plan: Plan, summary: dict[str, Any], intervals: list[dict], timings: dict,
            lb: float | None) -> dict[str, Any]:
    """The comparison figures of one verified plan (a flat, JSON-able dict)."""
    m = plan.metrics
    peaks = summary.get("peaks") or {}

    def peak(kind: str) -> float | None:
        vals = [p[kind] for p in peaks.values() if p.get(kind) is not None]
        return max(vals) if vals else None

    lb = m.get("lower_bound") or lb
    return {
        "problem": problem.name,
        "planner": spec.label,
        "status": plan.status.value,
        "passed": bool(summary.get("passed")),
        "complete": bool(summary.get("complete")),
        "error": None,
        "harvested": m.get("harvested"),
        "reachable": m.get("reachable"),
        "unreachable": m.get("unreachable"),
        "makespan": m.get("makespan"),
        "cycle_time_worst": m.get("cycle_time"),
        "cycle_time_mean": m.get("cycle_time_mean"),
        "throughput": m.get("throughput"),
        "per_arm": {a: {"fruit": v.get("fruit"), "idle_fraction": v.get("idle_fraction"), "cycle_time": v.get("cycle_time")}
                    for a, v in (m.get("per_arm") or {}).items()},
        "min_clearance": summary.get("min_clearance"),
        "certified_clearance": summary.get("certified_clearance"),
        "required_clearance": problem.task.clearance,
        "margin": summary.get("margin"),
        "margin_per_pair": {k: v.get("margin") for k, v in (summary.get("pairs") or {}).items()},
        "rms_jerk": {a: v.get("rms_jerk") for a, v in (m.get("per_arm") or {}).items()},
        "peak_jerk_per_arm": {a: v.get("peak_jerk") for a, v in (m.get("per_arm") or {}).items()},
        # arms whose acceleration jumps (the course's cubic): jerk unbounded, the sampled peak a grid's figure
        "acceleration_steps": summary.get("acceleration_steps") or {},
        "collision_count": summary.get("collision_count"),
        "collision_intervals": intervals,
        "violation_count": summary.get("violation_count"),
        "violation_kinds": summary.get("violation_kinds"),
        "peak_velocity": peak("velocity"),
        "peak_acceleration": peak("acceleration"),
        "peak_jerk": peak("jerk"),
        "peaks": peaks,
        "planning_time": timings.get("total"),
        "verify_time": timings.get("verify"),
        "lower_bound": lb,
        "makespan_ratio": _ratio(m.get("makespan"), lb),
        "optimality": m.get("optimality") or ("proven" if summary.get("passed") and lb and m.get("makespan") is not None
                                              and m["makespan"] <= lb + 1e-3 else "not proven"),
    }


def _problem_files(source: str | Path | Sequence[str | Path]) -> list[Path]:
    if isinstance(source, (str, os.PathLike)):
        p = Path(source)
        if p.is_dir():
            files = sorted([*p.glob("*.yaml"), *p.glob("*.yml")])
            if not files:
                raise ProblemError([Issue("", "expected a problem file or a folder of *.yaml problem files, found no *.yaml files")], str(p))
            return files
        return [p]
    if not isinstance(source, (list, tuple)) or not all(
            isinstance(s, (str, os.PathLike)) for s in source):  # (a Problem: "'Problem' object is not iterable")
        raise TypeError(f"source: expected a problem file, a folder of them or a list of files (str or Path), found "
                        f"{type(source).__name__}" + ("; a Problem made in Python is planned by coplan.solve(problem), "
                                                      "once per planner" if type(source).__name__ == "Problem" else ""))
    return [Path(s) for s in source]


def compare(
    source: str | Path | Sequence[str | Path],
    planners: Iterable[str | PlannerSpec] = DEFAULT_PLANNERS,
    out_dir: str | Path = "coplan-compare",
    figures: bool = True,
    options=None,
    progress: Callable[[str], None] | None = None,
) -> Comparison:
    """Solve every problem with every planner, verify, and write ``compare.json``/``compare.md``.

    Parameters
    ----------
    source : a problem file, a folder of problem files, or a list of files
    planners : planner specs, e.g. ``("heuristic", "coordinated", "optimal")`` or ``("heuristic", "heuristic:makespan")``
    figures : also draw :func:`coplan.viz.plots.save_comparison_figures` per problem
    options : :class:`coplan.optimal.OptimalOptions` for the optimal and coordinated planners

    A single bad problem file raises :class:`ProblemError`; in a folder it is recorded (in
    ``problems[*].error``) and the rest are compared. A planner that fails in any way (a coplan
    error, a missing module, a bug) is recorded in its row's ``error`` and the run goes on.

    Nothing finished is lost: with several problems, each problem's own ``compare.json`` /
    ``compare.md`` go into ``OUT/<problem>/`` as soon as it finishes, and the report in ``OUT``
    is rewritten with every problem finished so far. Ctrl-C (``KeyboardInterrupt``, or a planner
    returning an interrupted plan) stops the run: the report then covers the problems that
    finished and, of the one interrupted (a note names it), the planners that finished and the
    interrupted planner's verified incumbent where it returned one (status interrupted); the
    interruption is raised again.
    """
    if isinstance(planners, (str, PlannerSpec)):  # one planner, not its letters
        planners = [planners]
    specs, twice = [], []
    for spec in (PlannerSpec.parse(p) for p in planners):
        if spec.label in [s.label for s in specs]:  # (the same label: the same run folder and row)
            twice.append(spec.label)
        else:
            specs.append(spec)
    if not specs:
        raise ValueError("expected at least one planner")
    check_folder(out_dir, "out_dir")  # (before any work)
    files = _problem_files(source)
    single = isinstance(source, (str, Path)) and not Path(source).is_dir()
    if single:
        first = load_problem(files[0])  # a bad or missing file fails here, before the output folder is made
        if first.gantry is not None:  # (its heuristic column read "ValueError: ... plans a stationary cell")
            raise ValueError(f"source: {first.name!r} is a row (it has a gantry): its stop rules side by side are "
                             f"coplan.report.rows.compare_rows(problem, out_dir) (coplan compare ROW.yaml); "
                             f"compare() sets the cell planners side by side")
    say = speaker(progress)
    tick = ticker(progress)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cmp = Comparison(planners=[s.label for s in specs])
    cmp.notes += [f"planner {label} given more than once: compared once" for label in dict.fromkeys(twice)]
    cmp.notes += _earlier_runs(out, files, specs)
    cmp.notes += keep_reports(out, REPORT_FILES)
    _warm_up()
    runs = len(files) * len(specs)
    for k, path in enumerate(files):
        def ran(j: int, what: str) -> None:
            tick(Tick("compare", k * len(specs) + j, runs, "runs", note=f"{path.stem}: {what}"))

        entry = None
        try:
            entry, rows, plans = _compare_problem(path, specs, out, options, say, single, ran, nested(progress))
            problem = entry.pop("_problem", None)
            if figures and plans:
                ran(len(specs), "figures")
                _figures(problem, plans, out / path.stem, cmp)
        except KeyboardInterrupt as e:
            if entry is not None:  # every planner finished, the figures were being drawn: the rows are kept
                cmp.problems.append(entry)
                cmp.rows += rows
                cmp.notes.append(f"interrupted while drawing the figures of {path.name}: every planner of it finished "
                                 f"(in this report, with the {k} problem files before it); its figures are not all drawn")
                _write_report(cmp, specs, out)
                raise KeyboardInterrupt from None
            note = (f"interrupted while comparing {path.name}: this report covers the {k} of {len(files)} problem files "
                    "that finished")
            if isinstance(e, _Cut) and e.rows:  # what finished of the interrupted one is kept too
                e.entry.pop("_problem", None)
                cmp.problems.append(e.entry)
                cmp.rows += e.rows
                cut = [r["planner"] for r in e.rows if r.get("status") == PlanStatus.INTERRUPTED]
                done = [r["planner"] for r in e.rows if r.get("status") != PlanStatus.INTERRUPTED]
                note += (f", and of {path.name} the planners that finished ({', '.join(done) or 'none'})"
                         + (f" and {cut[0]}'s verified incumbent when it was interrupted (status interrupted)" if cut else ""))
            cmp.notes.append(note)
            _write_report(cmp, specs, out)
            raise KeyboardInterrupt from None
        cmp.problems.append(entry)
        cmp.rows += rows
        if not single:
            mine = Comparison(planners=cmp.planners, problems=[entry], rows=rows, notes=keep_reports(out / path.stem, REPORT_FILES))
            _write_report(mine, specs, out / path.stem, figures_from=cmp)
            cmp.files[f"{path.stem}/compare.json"] = mine.files["json"]
        _write_report(cmp, specs, out)
        bad = sum(1 for e in cmp.problems if e.get("error"))
        skipped = f" ({bad} skipped: invalid)" if bad else ""
        say(f"{k + 1} of {len(files)} problem files done, {k + 1 - bad} compared{skipped}; report written to {out / 'compare.json'}")
    return cmp


#: the report's files in its folder (an earlier comparison's moved aside first: :func:`coplan.output.keep_reports`)
REPORT_FILES = ("compare.json", "compare.md")


def _earlier_runs(out: Path, files: list[Path], specs: list[PlannerSpec]) -> list[str]:
    """Notes naming the run folders of an earlier comparison into ``out`` that this one does not
    write (another planner's): left as they were, and not this report's."""
    mine = {s.folder for s in specs}
    notes = []
    for path in files:
        folder = out / path.stem
        if folder.is_dir():
            for run in sorted(folder.iterdir()):
                if run.name not in mine and not run.name.endswith(".previous") and is_run_folder(run):
                    notes.append(f"{run}: a run of an earlier comparison (not in this one; left as it was)")
    return notes


def _warm_up() -> None:
    """Import, before anything is timed, what the planners and the verifier import on first use
    (SciPy's MILP, CasADi, python-fcl: 0.25-0.4 s), so that the first planner compared is not
    charged for it in its planning time (single_arm: heuristic 0.38 s first, 0.01 s second)."""
    import importlib

    for name in ("scipy.optimize", "scipy.sparse", "coplan.planners.heuristic", "coplan.planners.coordinated.planner",
                 "coplan.planners.optimal.planner", "coplan.verify.verifier", "coplan.allocate.allocation"):
        importlib.import_module(name)


class _Cut(KeyboardInterrupt):
    """Ctrl-C while one problem was compared, with what finished of it: its ``problems`` entry
    and the rows of the planners done (the interrupted one's too, where it returned its
    verified incumbent, status interrupted)."""

    def __init__(self, entry: dict, rows: list[dict]):
        super().__init__()
        self.entry, self.rows = entry, rows


def _compare_problem(path: Path, specs: list[PlannerSpec], out: Path, options, say, single: bool,
                     ran=lambda j, what: None, inner=None):
    """One problem file with every planner: its ``problems`` entry, its rows and its plans.
    Any failure becomes a recorded error; only an interruption escapes, as :class:`_Cut` with
    the rows done so far."""
    from ..kinds import PlanStatus
    from ..pipeline import solve

    try:
        problem = load_problem(path)
    except ProblemError as e:
        if single:
            raise
        say(f"skipping {path.name}: invalid problem file")
        return {"file": str(path), "name": None, "error": str(e)}, [], {}
    except Exception as e:  # noqa: BLE001 -- any failure reading one file is that file's row; the run goes on
        if single:
            raise
        say(f"skipping {path.name}: {type(e).__name__}: {e}")
        return {"file": str(path), "name": None, "error": f"{type(e).__name__}: {e}"}, [], {}
    entry = {"file": str(path), "name": problem.name, "arms": len(problem.arms), "fruit": len(problem.fruits),
             "reachable": len(problem.reachable_ids()), "error": None, "_problem": problem}
    rows: list[dict[str, Any]] = []
    plans: dict[str, Plan] = {}
    lb_cache: list[float] = []

    def mine() -> list[dict]:
        for row in rows:  # (two files may share a problem name: a row belongs to its file)
            row["file"] = str(path)
        return rows

    for j, spec in enumerate(specs):
        ran(j, spec.label)
        say(f"{problem.name}: solving with {spec.label}")
        kw = {"options": options} if spec.planner != PlannerKind.HEURISTIC else {}
        try:
            res = solve(problem, planner=spec.planner, allocation=spec.allocation, out_dir=out / path.stem / spec.folder,
                        progress=inner if inner is not None else say, **kw)
            row = _row_of(problem, spec, res, lb_cache)
            if res.error:  # (an internal error in a stage: the plan kept from before it is the row's, the run failed)
                row["error"] = res.error
                say(f"{problem.name}: {spec.label} failed: {res.error}; keeping its plan from before the error")
        except KeyboardInterrupt:
            raise _Cut(entry, mine()) from None
        except OSError as e:
            if e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS):  # the disk, not the planner: exit 8, named
                raise  # (a full disk was 'coordinated failed', exit 7, and the next planner met it again)
            rows.append({"problem": problem.name, "planner": spec.label, "status": None, "error": f"{type(e).__name__}: {e}"})
            say(f"{problem.name}: {spec.label} failed: {e}")
            continue
        except ProgressCallbackError:
            raise  # (the caller's callback, not the planner)
        except Exception as e:  # noqa: BLE001 -- a planner failing in any way (even a bug) is a row; the run goes on
            rows.append({"problem": problem.name, "planner": spec.label, "status": None, "error": f"{type(e).__name__}: {e}"})
            say(f"{problem.name}: {spec.label} failed: {e}")
            continue
        rows.append(row)
        if res.plan.status == PlanStatus.INTERRUPTED:  # its verified incumbent: a row, status interrupted
            raise _Cut(entry, mine())
        plans[spec.label] = res.plan
    return entry, mine(), plans


def _row_of(problem: Problem, spec: PlannerSpec, res, lb_cache: list[float]) -> dict[str, Any]:
    ver = res.verification
    if ver is None:
        from ..verify.verifier import verify

        ver = verify(problem, res.plan)
    if res.plan.metrics.get("lower_bound") is None and not lb_cache:
        lb_cache.append(lower_bound(problem))
    intervals = [{"arms": list(c.arms), "t_start": c.t_start, "t_end": c.t_end, "penetration": c.penetration}
                 for c in ver.collisions]
    row = run_row(problem, spec, res.plan, ver.summary(), intervals, res.timings, lb_cache[0] if lb_cache else None)
    row["files"] = {k: str(v) for k, v in res.files.items() if k in ("json", "verification")}
    return row


def _write_report(cmp: Comparison, specs: list[PlannerSpec], out: Path, figures_from: Comparison | None = None) -> None:
    """Relative makespans, aggregates, then ``compare.json`` and ``compare.md`` in ``out``."""
    base = specs[0].label
    for row in cmp.rows:
        ref = next((r for r in cmp.rows if same_source(r, row) and r["planner"] == base and not r.get("error")), None)
        if not row.get("error") and ref is not None:
            row["makespan_vs_" + base.replace(":", "_")] = _ratio(row["makespan"], ref["makespan"])
    cmp.aggregate = aggregate(cmp.rows, cmp.planners)
    if figures_from is not None:  # a problem's own report shows its figures too
        cmp.files.update({k: v for k, v in figures_from.files.items() if k.startswith(f"{out.name}/") and k.endswith(".png")})
    out.mkdir(parents=True, exist_ok=True)
    json_path, md_path = (out / name for name in REPORT_FILES)
    cmp.files.update(json=str(json_path), markdown=str(md_path))
    atomic_text(json_path, json.dumps(cmp.to_dict(), indent=1, allow_nan=False))
    atomic_text(md_path, to_markdown(cmp, out))


def _figures(problem: Problem, plans: dict[str, Plan], folder: Path, cmp: Comparison) -> None:
    try:
        from ..viz.plots import save_comparison_figures
    except ImportError as e:
        cmp.notes.append(f"figures skipped: {e}")
        return
    try:
        saved = save_comparison_figures(problem, plans, folder)
    except Exception as e:  # noqa: BLE001 -- a figure failing never loses the comparison itself
        cmp.notes.append(f"figures of {problem.name} not drawn: {type(e).__name__}: {e}")
        return
    for p in saved:
        cmp.files[f"{folder.name}/{Path(p).name}"] = str(p)
