"""Design sweeps (``coplan.sweep``): the sweep file, Dask runs, resume, worker deaths, the table
and the report.

Sweeps here use the coordinated planner on small rows (a fraction of a second each), so the
cost is mostly starting local clusters (a few seconds each).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import coplan
from typer.testing import CliRunner

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

from coplan.cli import app  # noqa: E402
from coplan.kinds import ExitCode, PlannerKind, RowStatus, SweepBase, SweepMode  # noqa: E402
from coplan.sweep.report import pareto_front, sweep_report  # noqa: E402
from coplan.sweep.run import hard_limit, run_sweep, solve_item  # noqa: E402
from coplan.sweep.spec import PARAMETERS, TOP_KEYS, SweepError, SweepItem, load_sweep, parse_sweep  # noqa: E402
from coplan.sweep.table import COLUMNS, JOURNAL, normalise, read_rows, read_table  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "sweeps" / "small.yaml"

TINY = """\
name: tiny
base: row
fixed: {n_arms: 2, spacing: 2.0, seed: 3}
vary:
  n_fruits: [2, 3, 4]
planner: coordinated
time_limit: 60
"""


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "small"
    seen: list[dict] = []
    res = run_sweep(load_sweep(SMALL), out, workers=2, on_row=lambda row, o: seen.append(dict(row)))
    return out, res, seen


# ---------------------------------------------------------------------- runs
def test_small_sweep_on_a_two_worker_local_cluster(small_run):
    out, res, seen = small_run
    assert (res.total, res.skipped, res.done, res.workers) == (6, 0, 6, 2)
    rows = read_table(out).to_pylist()
    assert len(rows) == 6 and len({r["key"] for r in rows}) == 6
    assert list(read_table(out).schema.names) == list(COLUMNS)
    assert {(r["n_arms"], r["spacing"]) for r in rows} == {(a, s) for a in (2, 3) for s in (1.6, 2.0, 2.4)}
    for r in rows:
        assert r["status"] == RowStatus.SUCCESS.value and r["exit_class"] == "ok" and r["exit_code"] == 0 and r["verified"]
        assert r["n_fruits"] == round(1.0 * r["n_arms"] * r["spacing"])  # density 1/m over arms x spacing of row
        assert r["row_length"] == pytest.approx(r["n_arms"] * r["spacing"])
        assert r["throughput"] == pytest.approx(60.0 * r["harvested"] / r["makespan"])
        assert r["throughput_per_m"] == pytest.approx(r["throughput"] / r["row_length"])
        assert r["ratio"] == pytest.approx(r["makespan"] / r["lower_bound"]) and r["ratio"] >= 1 - 1e-9
        assert r["coordinated_makespan"] == r["makespan"]  # the coordinated planner: its own figure
        assert r["certified_clearance"] >= r["required_clearance"] - 1e-12
        assert r["sweep"] == "small" and json.loads(r["params"])["density"] == 1.0
    assert sorted(r["key"] for r in seen) == sorted(r["key"] for r in rows)  # a row per task, as it finished


def test_a_row_matches_solving_the_same_problem_directly(small_run):
    from coplan import solve
    from coplan.generate import row_problem, to_yaml
    from coplan.problem import parse_problem

    out, _, _ = small_run
    row = next(r for r in read_rows(out) if r["n_arms"] == 3 and r["spacing"] == 2.0)
    prob = parse_problem(to_yaml(row_problem(3, 6, spacing=2.0, seed=0, x_pad=1.0, reachable_only=True)))
    res = solve(prob, planner="coordinated")
    assert row["makespan"] == pytest.approx(res.plan.metrics["makespan"], rel=1e-9)
    assert row["lower_bound"] == pytest.approx(res.plan.metrics["lower_bound"], rel=1e-9)


def test_resume_skips_finished_rows_and_survives_a_torn_line(small_run, tmp_path):
    src, _, _ = small_run
    out = tmp_path / "resume"
    shutil.copytree(src, out)
    lines = (out / JOURNAL).read_text().splitlines(keepends=True)
    kept, dropped = lines[:4], [json.loads(ln)["key"] for ln in lines[4:]]
    (out / JOURNAL).write_text("".join(kept) + lines[4][:40])  # a crash in the middle of writing row 5
    solved: list[str] = []
    res = run_sweep(load_sweep(SMALL), out, workers=1, on_row=lambda row, o: solved.append(row["key"]))
    assert (res.skipped, res.done) == (4, 2) and sorted(solved) == sorted(dropped)
    assert len(read_rows(out)) == 6 and read_table(out).num_rows == 6
    again = run_sweep(load_sweep(SMALL), out, workers=1)  # all done: no cluster, nothing solved
    assert (again.skipped, again.done, again.counts) == (6, 0, {"success": 6})


def test_a_second_sweep_into_a_folder_another_is_writing_is_refused(small_run, tmp_path):
    """(Two sweeps into one folder at once both ran: the second solved every problem the first
    had not finished again, and the journal held those rows twice.) While the folder's lock is
    held the second is refused, naming the first, before any work; once released, it runs."""
    from coplan.sweep.run import FolderBusy, _FolderLock

    src, _, _ = small_run
    out = tmp_path / "busy"
    shutil.copytree(src, out)
    spec = load_sweep(SMALL)
    first = _FolderLock(out, spec)
    first.acquire()
    try:
        before = (out / JOURNAL).read_text()
        with pytest.raises(FolderBusy, match="being written by coplan sweep .* process [0-9]+; wait for it to finish"):
            run_sweep(spec, out, workers=1)
        assert (out / JOURNAL).read_text() == before and FolderBusy.exit_code == 2
    finally:
        first.release()
    again = run_sweep(spec, out, workers=1)  # (all done: nothing solved, and its own lock released at the end)
    assert again.skipped == 6
    last = _FolderLock(out, spec)  # (released: the next one takes it)
    last.acquire()
    last.release()


def test_a_killed_worker_process_is_replaced_and_its_task_retried(tmp_path):
    marker = tmp_path / "killed-once"

    def dies_once(item, state_dir, keep_plan):
        if item.index == 1 and not marker.exists():
            marker.write_text(str(os.getpid()))
            os.kill(os.getpid(), 9)  # the worker process dies in the middle of the sweep
        return solve_item(item, state_dir, keep_plan)

    spec = parse_sweep(TINY, "tiny.yaml")
    res = run_sweep(spec, tmp_path / "out", workers=2, task=dies_once)
    rows = read_rows(tmp_path / "out")
    assert marker.exists(), "the task never killed its worker"
    assert res.done == 3 and len(rows) == 3 and {r["status"] for r in rows} == {RowStatus.SUCCESS.value}
    assert sorted(r["n_fruits"] for r in rows) == [2, 3, 4]
    victim = next(r for r in rows if r["index"] == 1)
    assert victim["worker"] is not None and victim["makespan"] > 0


def test_a_scheduler_with_no_workers_is_said_and_the_sweep_goes_on_when_one_joins(tmp_path, monkeypatch):
    """(A sweep on a --scheduler no worker had joined waited, as Dask does, with "no problem
    finished yet" and not a word why.) A scheduler with no workers: the sweep says so; a worker
    joins (here: on that note) and the sweep finishes, every row solved."""
    from distributed import LocalCluster

    import coplan.sweep.cluster as cluster_mod
    import coplan.sweep.run as run

    monkeypatch.setattr(cluster_mod, "WORKER_CHECK_SECONDS", 0.2)
    notes: list[str] = []
    with LocalCluster(n_workers=0, processes=True, threads_per_worker=1, dashboard_address=":0") as cluster:
        def note(message):
            notes.append(message)
            if len(notes) == 1:
                cluster.scale(1)  # a worker connects once told

        res = run.run_sweep(parse_sweep(TINY, "tiny.yaml"), tmp_path / "out", scheduler=cluster.scheduler_address,
                            on_note=note)
    assert notes and "has no workers: the sweep waits for one to connect" in notes[0]
    assert cluster.scheduler_address in notes[0]
    assert res.done == 3 and {r["status"] for r in read_rows(tmp_path / "out")} == {RowStatus.SUCCESS.value}


def test_bad_problems_are_rows_with_exit_class_bad_input(tmp_path, problems_dir):
    good = tmp_path / "p" / "a_good.yaml"
    good.parent.mkdir()
    shutil.copy(problems_dir / "single_arm.yaml", good)
    (tmp_path / "p" / "b_bad.yaml").write_text("name: broken\narms:\n  - {name: a, base: [0, 0], links: [1.0, -0.5]}\n")
    (tmp_path / "p" / "c_not_utf8.yaml").write_bytes(b"name: \xff\n")
    (tmp_path / "files.yaml").write_text("problems: p\nplanner: coordinated\ntime_limit: 30\n")
    res = run_sweep(load_sweep(tmp_path / "files.yaml"), tmp_path / "out", workers=1, keep_plans=True)
    rows = {Path(json.loads(r["params"])["problem"]).name: r for r in read_rows(tmp_path / "out")}
    assert res.done == 3 and set(rows) == {"a_good.yaml", "b_bad.yaml", "c_not_utf8.yaml"}
    assert rows["a_good.yaml"]["status"] == "success"
    saved = tmp_path / "out" / "plans" / rows["a_good.yaml"]["key"]
    r = CliRunner().invoke(app, ["verify", str(saved.with_suffix(".yaml")), str(saved.with_suffix(".json"))])
    assert r.exit_code == 0, r.output  # the kept plan passes coplan verify on its own
    assert sorted(p.name for p in saved.parent.iterdir()) == [saved.name + ".json", saved.name + ".yaml"]
    # it names its problem, as a solve's plan does (copied away from its folder it still says which), and
    # it and the sweep record what made them
    import hashlib

    kept = json.loads(saved.with_suffix(".json").read_text())
    assert kept["problem_file"] == {"path": str(saved.with_suffix(".yaml").resolve()),
                                    "sha256": hashlib.sha256(saved.with_suffix(".yaml").read_bytes()).hexdigest()}
    meta = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert kept["software"]["coplan"] == meta["software"]["coplan"] == coplan.__version__
    for name in ("b_bad.yaml", "c_not_utf8.yaml"):
        r = rows[name]
        assert (r["status"], r["exit_class"], r["exit_code"]) == ("bad input", "bad input", int(ExitCode.BAD_INPUT))
        assert name in r["message"]
    assert "links" in rows["b_bad.yaml"]["message"] and "UTF-8" in rows["c_not_utf8.yaml"]["message"]
    # the command says so in its exit code, as compare does (here resumed: every row already done)
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(tmp_path / "files.yaml"), "--out", str(tmp_path / "out")])
    assert r.exit_code == int(ExitCode.BAD_INPUT) and "2 problems of the sweep are invalid" in r.output, r.output
    assert "message column" in r.output  # the column the reason is in (it once said "error", which no column is)
    from coplan.sweep.report import summarise

    named = {f["key"]: f["name"] for f in summarise(read_rows(tmp_path / "out"))["failures"]}
    assert sorted(Path(v).name for v in named.values()) == ["b_bad.yaml", "c_not_utf8.yaml"], named  # its file, not None


def test_solve_item_turns_errors_into_rows_without_a_cluster():
    item = SweepItem(0, "k", {"seed": 1}, "coordinated", {}, 30.0, "gen", "name: x\narms: 3\n")
    row, plan = solve_item(item)
    assert row["status"] == "bad input" and "arms" in row["message"] and plan is None
    gen_err = SweepItem(1, "k2", {}, "coordinated", {}, 30.0, "gen", None, None, "could not generate the problem: no")
    assert solve_item(gen_err)[0]["exit_class"] == "bad input"


def test_a_bad_input_row_keeps_its_design_and_a_row_file_with_the_heuristic_is_bad_input(problems_dir):
    """(A design whose problem could not be made lost its arms, spacing and links in the table --
    its n_arms column read as floats in pandas -- and the generator's default seed 0 read null;
    a row file swept with the heuristic was an 'internal error'.)"""
    params = {"n_arms": 2, "spacing": 0.3, "density": 1e9, "links": [0.9, 0.7], "link_radius": 0.05}
    row = solve_item(SweepItem(0, "k", params, "coordinated", {}, 5.0, "row generator", None, 2.4, "could not generate"))[0]
    assert row["status"] == "bad input"
    assert (row["n_arms"], row["spacing"], row["density"], row["row_length"]) == (2, 0.3, 1e9, 2.4)
    assert (row["link_1"], row["link_2"], row["link_radius"], row["seed"]) == (0.9, 0.7, 0.05, 0)
    text = (problems_dir / "rows" / "sparse_row.yaml").read_text() if (problems_dir / "rows").is_dir() else None
    if text is None:
        from coplan.problem import shipped_rows

        text = next(p for p in shipped_rows() if p.stem == "sparse_row").read_text()
    row = solve_item(SweepItem(1, "k2", {"problem": "sparse_row.yaml"}, "heuristic", {}, 30.0, "sparse_row.yaml", text))[0]
    assert (row["status"], row["exit_class"]) == ("bad input", "bad input") and "planner" in row["message"]
    # on the move no cell planner plans: the heuristic named there is not in the way (the file parses so)
    from coplan.generate import gantry_row, to_yaml

    short = to_yaml(gantry_row(length=4.0, n_arms=2, density=1.0, seed=1))
    moving = solve_item(SweepItem(3, "k4", {"gantry": "continuous"}, "heuristic", {}, 30.0, "gantry_row", short))[0]
    assert moving["status"] == "success" and moving["gantry"] == "continuous", moving["message"]
    # auto: the design asked for stays in `gantry` (it was overwritten: the report merged it with continuous), the mode
    # kept is `gantry_mode`
    both = solve_item(SweepItem(4, "k5", {"gantry": "auto"}, "coordinated", {}, 30.0, "gantry_row", short))[0]
    assert both["status"] == "success" and both["gantry"] == "auto" and both["gantry_mode"] in ("stop-and-go", "continuous")
    from coplan.sweep.report import _mode

    assert _mode(both) == f"auto: {both['gantry_mode']}" and _mode(moving) == "continuous"
    assert row["seed"] is None and row["n_arms"] == 3  # (a file's: its own figures, no generator seed)
    # why the optimal planner stopped, so that a row its clock stopped (machine-dependent) can be found
    single = (problems_dir / "single_arm.yaml").read_text()
    row = solve_item(SweepItem(2, "k3", {"problem": "single_arm.yaml"}, "optimal", {}, 30.0, "single_arm.yaml", single))[0]
    assert row["status"] == "success" and row["stopped_by"] == "proven_optimal"


def test_a_task_dask_returns_no_row_for_says_why():
    """(Every task cancelled when an external scheduler went away said 'the worker process died on
    all 3 attempts'.)"""
    import types

    from distributed import KilledWorker
    from distributed.client import FutureCancelledError

    from coplan.sweep.run import lost_reason

    assert lost_reason(KilledWorker("t", types.SimpleNamespace(address="tcp://w"), 2), 3).startswith("the worker process died on all 3 attempts")
    why = lost_reason(FutureCancelledError("t", reason="scheduler-connection-lost"), 3)
    assert why.startswith("the connection to the Dask scheduler was lost") and "run the same command again" in why
    assert lost_reason(RuntimeError("boom"), 3).startswith("Dask returned no result (RuntimeError: boom)")


def test_the_watchdog_stops_a_hung_worker_and_the_retry_writes_a_timeout_row(tmp_path):
    code = textwrap.dedent(f"""
        import time
        from pathlib import Path
        from coplan.sweep.run import Watchdog
        with Watchdog(0.3, Path({str(tmp_path / 'timeouts' / 'k')!r})):
            time.sleep(30)
    """)
    p = subprocess.run([sys.executable, "-c", code], timeout=60)  # blocked: the wall-clock bound (4 x 0.3 s)
    assert p.returncode == int(ExitCode.SOLVER_FAILED) and (tmp_path / "timeouts" / "k").exists()
    spin = textwrap.dedent(f"""
        import time
        from pathlib import Path
        from coplan.sweep.run import Watchdog
        t0 = time.monotonic()
        with Watchdog(0.5, Path({str(tmp_path / 'timeouts' / 'spin')!r}), wall_factor=1000):
            while time.monotonic() - t0 < 60:
                pass
    """)
    p = subprocess.run([sys.executable, "-c", spin], timeout=90)  # spinning: the CPU bound
    assert p.returncode == int(ExitCode.SOLVER_FAILED) and (tmp_path / "timeouts" / "spin").exists()
    calm = "from coplan.sweep.run import Watchdog\nwith Watchdog(5.0, None):\n    sum(range(10))\nprint('returned')"
    assert subprocess.run([sys.executable, "-c", calm], capture_output=True, text=True, timeout=60).stdout.strip() == "returned"
    item = SweepItem(0, "k", {}, "coordinated", {}, 30.0, "gen", "name: x\n")
    row, _ = solve_item(item, str(tmp_path))
    assert row["status"] == RowStatus.TIMEOUT.value and row["exit_class"] == "solver failed"


# ---------------------------------------------------------------------- the sweep file
def test_grid_expansion_density_and_keys():
    spec = load_sweep(SMALL)
    items = spec.items()
    assert spec.base == SweepBase.ROW and spec.mode == SweepMode.GRID and len(items) == 6
    assert [it.params["spacing"] for it in items[:3]] == [1.6, 2.0, 2.4]
    assert items == spec.items()  # deterministic
    other = spec.items(planner="optimal")
    assert {it.key for it in other}.isdisjoint({it.key for it in items})  # the key covers the planner
    assert {it.key for it in spec.items(time_limit=5)}.isdisjoint({it.key for it in items})


def test_random_mode_draws_seeded_values_within_ranges():
    text = textwrap.dedent("""
        base: row
        mode: random
        samples: 40
        seed: 7
        vary:
          n_arms: {from: 2, to: 5}
          spacing: {from: 1.2, to: 2.6}
          density: [0.5, 1.0]
          options.search_work: {from: 1000, to: 3000, step: 1000}
    """)
    a, b = parse_sweep(text, "r.yaml").items(), parse_sweep(text, "r.yaml").items()
    assert [i.key for i in a] == [i.key for i in b] and len(a) == 40  # (a draw that repeats a problem is drawn again)
    assert {i.params["n_arms"] for i in a} == {2, 3, 4, 5}
    assert all(1.2 <= i.params["spacing"] <= 2.6 for i in a) and {i.params["density"] for i in a} == {0.5, 1.0}
    assert {i.options["search_work"] for i in a} == {1000, 2000, 3000}
    assert parse_sweep(text.replace("seed: 7", "seed: 8"), "r.yaml").items()[0].key != a[0].key


def test_random_mode_gives_the_samples_asked_for_or_the_whole_grid():
    """(100 samples of a 36-set grid gave 27 problems, silently: repeats were dropped; a range
    with a count was drawn from as if it had none.)"""
    text = textwrap.dedent("""
        base: row
        mode: random
        samples: 100
        seed: 3
        vary:
          spacing: {from: 1.2, to: 2.0, step: 0.1}
          n_arms: [2, 3]
          density: {from: 0.5, to: 1.0, count: 2}
    """)
    spec = parse_sweep(text, "r.yaml")
    assert spec.grid_size() == 9 * 2 * 2 and spec.vary["density"] == [0.5, 1.0]
    whole = spec.items()
    grid = parse_sweep(text.replace("mode: random\n", "").replace("samples: 100\n", "").replace("seed: 3\n", ""), "g.yaml").items()
    assert [i.key for i in whole] == [i.key for i in grid] and len(whole) == 36
    some = parse_sweep(text.replace("samples: 100", "samples: 20"), "r.yaml").items()
    assert len(some) == 20 and {i.key for i in some} <= {i.key for i in grid}
    with pytest.raises(SweepError) as e:
        parse_sweep(text.replace("samples: 100", "samples: 1000000000"), "r.yaml")
    assert [(i.path, i.line) for i in e.value.issues] == [("samples", 4)] and "found samples: 1000000000" in str(e.value)


def test_random_mode_over_a_huge_range_is_quick_and_draws_each_set_once():
    """(A whole-number option range of 1e12 values was listed to be counted: items() never
    returned; 50 x samples sets were drawn before the first problem was made. Now 1e9, the most
    a whole-number option may be.)"""
    import time

    spec = parse_sweep("base: cell\nmode: random\nsamples: 5\nvary:\n  options.search_work: {from: 1000, to: 1000000000}\n"
                       "  seed: [1, 2]\n", "r.yaml")
    t0 = time.perf_counter()
    assert spec.grid_size() == (10**9 - 1000 + 1) * 2
    items = spec.items()
    assert len(items) == 5 and len({json.dumps(i.params, sort_keys=True) for i in items}) == 5
    assert time.perf_counter() - t0 < 30  # (generous: a few problems made; it was unbounded)


@pytest.mark.parametrize("text, path, words", [
    # a solver option's range is checked as an options file's values are (h_target 1e-9: 23 GB)
    ("base: cell\nvary: {options.h_target: {from: 0.000000001, to: 0.1, count: 3}}\n", "vary.options.h_target", "within [0.005, 1]"),
    ("base: cell\nvary: {options.polish_rounds: {from: 0, to: 2}}\n", "vary.options.polish_rounds", "positive integer"),
    # base gantry takes no solver option (the same plan was solved twice, as two designs)
    ("base: gantry\nvary: {options.search_work: [1000, 2000]}\n", "vary.options.search_work", "no solver option with base gantry"),
    ("base: cell\nvary: {options.nonsense: [1, 2]}\n", "vary.options.nonsense", "unknown key 'nonsense'"),  # (once, not per value)
])
def test_sweep_option_values_are_checked_however_given(text, path, words, tmp_path):
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "s.yaml", tmp_path)
    assert [i.path for i in e.value.issues] == [path] and words in e.value.issues[0].message, e.value.issues


def test_the_heuristic_is_refused_on_a_gantry_only_where_it_would_plan():
    ok = ["base: gantry\nvary: {n_arms: [2]}\nplanner: heuristic\nfixed: {planner: coordinated}\n",  # (fixed overrides the key)
          "base: gantry\nvary: {n_arms: [2], planner: [coordinated, optimal]}\nplanner: heuristic\n",
          "base: gantry\nvary: {n_arms: [2], gantry: [continuous]}\nplanner: heuristic\n"]  # (on the move: no cell planner)
    for text in ok:
        parse_sweep(text, "g.yaml")
    with pytest.raises(ValueError, match="planner: expected coordinated or optimal with base gantry"):
        parse_sweep("base: gantry\nvary: {n_arms: [2]}\n", "g.yaml").items(planner="heuristic")
    spec_file = ROOT / "sweeps" / "small.yaml"  # (a cell sweep: --planner heuristic is fine there)
    assert parse_sweep(spec_file.read_text(), str(spec_file)).items(planner="heuristic")


def test_a_gantry_sweep_plans_its_stops_with_coplan_solve_s_cell_planner_unless_told():
    """A row's default cell planner in a sweep is `coplan solve ROW`'s (coordinated); a cell
    sweep's default stays the optimal planner; a planner given is the one used."""
    rows = parse_sweep("base: gantry\nvary: {n_arms: [2], gantry: [stop-and-go, continuous]}\n", "g.yaml")
    assert rows.planner == PlannerKind.COORDINATED and {it.planner for it in rows.items()} == {"coordinated"}
    told = parse_sweep("base: gantry\nvary: {n_arms: [2]}\nplanner: optimal\n", "g.yaml")
    assert {it.planner for it in told.items()} == {"optimal"}
    assert parse_sweep("base: row\nvary: {n_arms: [2]}\n", "r.yaml").planner == PlannerKind.OPTIMAL


def test_a_files_sweep_plans_its_row_files_stops_with_coplan_solve_s_cell_planner_unless_told(tmp_path):
    """A sweep over problem files, its planner not given: each row file's stops are planned as
    `coplan solve ROW` plans them (coordinated), each cell file with the optimal planner; a planner
    given (the key, or --planner) is the one used for all."""
    from coplan.generate import gantry_row, to_yaml

    (tmp_path / "row.yaml").write_text(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=3)))
    shutil.copy(ROOT / "src" / "coplan" / "problems" / "single_arm.yaml", tmp_path / "cell.yaml")
    text = "base: files\nproblems: ['row.yaml', 'cell.yaml']\n"
    by_file = lambda items: {Path(it.source).name: it.planner for it in items}  # noqa: E731
    assert by_file(parse_sweep(text, str(tmp_path / "s.yaml"), tmp_path).items()) == {"row.yaml": "coordinated", "cell.yaml": "optimal"}
    told = parse_sweep(text + "planner: optimal\n", str(tmp_path / "s.yaml"), tmp_path)
    assert set(by_file(told.items()).values()) == {"optimal"}
    assert set(by_file(parse_sweep(text, str(tmp_path / "s.yaml"), tmp_path).items(planner="optimal")).values()) == {"optimal"}


def test_a_row_file_takes_no_solver_options_one_row_per_file_not_per_option_value(tmp_path):
    """A files sweep that varies a solver option: each cell file gets a row per value, a row file
    one row with no options (its solve takes none, as `coplan solve ROW`; it was solved once per
    value, the same plan under two keys, the option shown as an axis that did nothing)."""
    from coplan.generate import gantry_row, to_yaml

    (tmp_path / "row.yaml").write_text(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=3)))
    shutil.copy(ROOT / "src" / "coplan" / "problems" / "single_arm.yaml", tmp_path / "cell.yaml")
    text = ("base: files\nproblems: ['row.yaml', 'cell.yaml']\nplanner: optimal\n"
            "options: {polish: false}\nvary: {options.search_work: [100, 200]}\n")
    items = parse_sweep(text, str(tmp_path / "s.yaml"), tmp_path).items()
    rows = [it for it in items if Path(it.source).name == "row.yaml"]
    cells = [it for it in items if Path(it.source).name == "cell.yaml"]
    assert len({it.key for it in rows}) == 1 and all(it.options == {} for it in rows)
    assert all(not any(k.startswith("options.") for k in it.params) for it in rows)
    assert len({it.key for it in cells}) == 2
    assert sorted(it.options["search_work"] for it in cells) == [100, 200] and all(it.options["polish"] is False for it in cells)


def test_the_sweep_command_refuses_the_heuristic_on_a_gantry_as_a_usage_error(tmp_path):
    spec = tmp_path / "g.yaml"
    spec.write_text("name: g\nbase: gantry\nvary: {n_arms: [2]}\n")
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--planner", "heuristic", "--out", str(tmp_path / "o")])
    assert r.exit_code == int(ExitCode.USAGE) and "--planner: expected coordinated or optimal" in " ".join(r.output.split())
    assert not (tmp_path / "o").exists()


def test_every_sweep_file_key_and_parameter_is_in_the_usage_guide():
    """(The guide named no base, no `fixed`, `mode`, `samples`, `seed` or `retries`, and few
    parameters: a user found `gantry` from an error message.)"""
    text = (ROOT / "docs" / "usage.md").read_text()
    section = text[text.index("## Design sweeps"):text.index("## Exit codes")]
    missing = [k for k in sorted(TOP_KEYS) + list(PARAMETERS) + [b.value for b in SweepBase] if f"`{k}`" not in section]
    assert missing == []


def test_the_shipped_sweeps_validate():
    specs = {p.name: load_sweep(p) for p in sorted((ROOT / "sweeps").glob("*.yaml"))}
    assert len(specs["small.yaml"].items()) == 6
    assert len(specs["spacing_arms_density.yaml"].items()) == 8 * 4 * 3 * 5
    big = specs["random1000.yaml"]  # (generating its 1000 problems takes seconds: sizes only)
    assert big.base == SweepBase.RANDOM and big.sizes == {"seed": 1000} and big.vary["seed"] == list(range(1000))


BAD = """\
name: bad
base: row
fixed:
  link_radius: -0.1
vary:
  spacng: [1.5, 2.0]
  n_arms: [2, 0]
  density: {from: 2.0, to: 1.0, step: 0.5}
  seed: {from: 0, to: 4.5}
  options.search_work: [-5]
options: {polish: maybe}
planner: fastest
retries: -1
"""


def test_sweep_file_errors_name_the_key_path_and_line():
    with pytest.raises(SweepError) as e:
        parse_sweep(BAD, "bad.yaml")
    got = {i.path: (i.line, i.message) for i in e.value.issues}
    assert got["fixed.link_radius"][0] == 4 and "positive" in got["fixed.link_radius"][1]
    assert got["vary.spacng"][0] == 6 and "did you mean 'spacing'" in got["vary.spacng"][1]
    assert got["vary.n_arms[1]"] == (7, "expected an integer >= 1 and <= 64 (what a problem may have), found number 0")
    assert got["vary.density"][0] == 8 and "from <= to" in got["vary.density"][1]
    assert got["vary.seed"][0] == 9 and "whole numbers" in got["vary.seed"][1]
    assert got["vary.options.search_work[0]"][0] == 10
    assert got["options.polish"][0] == 11 and "true or false" in got["options.polish"][1]
    assert got["planner"][0] == 12 and "coordinated" in got["planner"][1]
    assert got["retries"][0] == 13
    assert "bad.yaml:6: vary.spacng: expected a sweep parameter" in str(e.value)


@pytest.mark.parametrize("text, path, words", [
    ("base: random\nvary: {spacing: [1.0]}\n", "vary.spacing", "only applies to base row, overlap"),
    ("base: row\nfixed: {n_fruits: 3}\nvary: {density: [1.0]}\n", "vary", "either n_fruits or density"),
    ("base: row\nmode: random\n", "samples", "mode: random"),
    ("base: row\nvary: {spacing: {from: 1, to: 2}}\n", "vary.spacing", "'step' or 'count'"),
    ("problems: nowhere/*.yaml\n", "problems", "found none matching"),
    ("base: row\nvary: {y_range: [[1.0, 0.5]]}\n", "vary.y_range[0]", "low < high"),
    ("base: row\nbase_: x\n", "base_", "did you mean 'base'"),
    ("- 1\n", "", "expected a mapping"),
    ("base: row\nvary: {n_arms: &a [1]}\n", "vary.n_arms", "anchor"),
    ("base: row\nvary: {}\n", "vary", "at least one to vary"),  # (as `vary:` left empty)
    ("base: row\nvary: {n_arms: [2, -1, two, 2.5]}\n", "vary.n_arms[3]", "integer"),  # (every bad value, not the first)
    # (the heuristic plans no row: every row of such a sweep was an 'internal error', and it exited 0)
    ("base: gantry\nvary: {n_arms: [2]}\nplanner: heuristic\n", "planner", "coordinated or optimal with base gantry"),
    ("base: gantry\nvary: {n_arms: [2], planner: [optimal, heuristic]}\n", "vary.planner[1]", "with base gantry"),
])
def test_sweep_file_errors(text, path, words, tmp_path):
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "s.yaml", tmp_path)
    assert any(i.path == path and words in i.message for i in e.value.issues), e.value.issues


def test_the_sweep_command_reports_a_bad_file_with_exit_code_3(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BAD)
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(bad), "--out", str(tmp_path / "o")])
    assert r.exit_code == int(ExitCode.BAD_INPUT)
    assert f"{bad}:7: vary.n_arms[1]: expected an integer >= 1 and <= 64 (what a problem may have), found number 0" in r.output
    assert "Traceback" not in r.output and not (tmp_path / "o").exists()
    r = CliRunner().invoke(app, ["sweep", str(SMALL), "--workers", "2", "--scheduler", "tcp://x:1"])
    assert r.exit_code == int(ExitCode.USAGE)


def test_a_scheduler_that_cannot_be_reached_leaves_no_sweep_folder_behind(tmp_path, monkeypatch):
    """(It left an empty results.parquet and sweep.json, which sweep-report then called a sweep of 0 rows.)"""
    import coplan.sweep.cluster as cluster_mod

    monkeypatch.setattr(cluster_mod, "SCHEDULER_TIMEOUT", "3s")  # (the 20 s a user gets: the test's wait)
    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY)
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(tmp_path / "o"), "--scheduler",
                                                        "tcp://127.0.0.1:9"])
    assert r.exit_code == int(ExitCode.USAGE) and "could not connect" in r.output, r.output
    assert not (tmp_path / "o").exists()


# ---------------------------------------------------------------------- report
def test_pareto_front():
    pts = [(2, 10.0), (3, 9.0), (3, 12.0), (4, 12.0), (5, 15.0), (2, 8.0)]
    assert pareto_front(pts) == [0, 2, 4]


def test_sweep_report_counts_medians_and_figures(small_run, tmp_path):
    out, _, _ = small_run
    rep = sweep_report(out, tmp_path / "rep")
    s = rep.summary
    assert s["rows"] == 6 and s["counts"] == {"success": 6} and s["success_rate"] == 1.0
    rows = read_rows(out)
    tp = sorted(r["throughput"] for r in rows)
    assert s["medians"]["throughput"] == pytest.approx((tp[2] + tp[3]) / 2)
    best = max(rows, key=lambda r: r["throughput"])
    assert max(d["throughput"] for d in s["pareto_front"]) == pytest.approx(best["throughput"])
    for k in ("markdown", "json", "throughput", "ratio", "solve_time", "pareto"):
        assert rep.files[k].exists() and rep.files[k].stat().st_size > 0
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep-report", str(out), "--out", str(tmp_path / "r2"), "--no-figures"])
    assert r.exit_code == 0 and "success 6" in r.output and (tmp_path / "r2" / "report.md").exists()
    # a notebook's backend is its own: the report draws on Figure objects (it switched the backend to Agg,
    # and the notebook's next plt.show() showed nothing)
    code = ("import sys, matplotlib; matplotlib.use('svg'); from coplan.sweep.report import sweep_report; "
            f"r = sweep_report({str(out)!r}, {str(tmp_path / 'r3')!r}); "
            "print(matplotlib.get_backend(), 'matplotlib.pyplot' in sys.modules, sorted(r.files))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.stdout.split()[:2] == ["svg", "False"] and "'pareto'" in p.stdout, p.stdout + p.stderr


def test_sweep_report_refuses_a_folder_that_is_not_a_sweep(tmp_path):
    """A folder with neither results.parquet nor the journal: exit 2 and nothing written in it."""
    (tmp_path / "a.yaml").write_text("name: x\n")
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep-report", str(tmp_path)])
    assert r.exit_code == 2 and "results.parquet" in r.output, r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.yaml"]
    with pytest.raises(FileNotFoundError, match="neither"):
        sweep_report(tmp_path)
    # a sweep stopped before its first problem was done: said so (it was "a folder with neither")
    (tmp_path / "sweep.json").write_text('{"name": "x"}')
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep-report", str(tmp_path)])
    assert r.exit_code == 2 and "found a sweep that has none yet" in " ".join(r.output.split()), r.output


def test_odd_tables_and_records_are_named_not_internal_errors(small_run, tmp_path):
    """(From a user's trial: each was an internal error, exit 1, or a silent wrong report.)
    A journal line of valid JSON with a value of the wrong type is a damaged line; a Parquet
    table trimmed in pandas reports with its missing columns named, another Parquet file is
    refused; a damaged sweep.json is named; a sweep stopped part-way is reported as unfinished."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from coplan.sweep.table import PARQUET, SweepTableError

    src, _, _ = small_run
    out = tmp_path / "odd"
    shutil.copytree(src, out)
    lines = (out / JOURNAL).read_text().splitlines(keepends=True)
    bad = json.loads(lines[0])
    bad["exit_code"] = "three"
    (out / JOURNAL).write_text(json.dumps(bad) + "\n" + "".join(lines[1:]))
    (out / PARQUET).unlink()
    unread: list[int] = []
    assert len(read_rows(out, unread)) == 5 and unread == [1]
    table = pq.read_table(src / PARQUET)
    pq.write_table(table.select(["key", "sweep", "status", "makespan"]), tmp_path / "few.parquet")
    notes: dict = {}
    few = read_table(tmp_path / "few.parquet", notes)
    assert few.num_rows == 6 and "exit_class" in notes["missing_columns"] and few.column("exit_class").null_count == 6
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep-report", str(tmp_path / "few.parquet"), "--out",
                                                      str(tmp_path / "r1"), "--no-figures"])
    assert r.exit_code == 0 and "lacks" in r.output and "6 rows" in r.output, r.output
    pq.write_table(pa.table({"a": [1, 2]}), tmp_path / "other.parquet")
    with pytest.raises(SweepTableError, match="without key and status"):
        read_table(tmp_path / "other.parquet")
    # sweep.json says the last run had 48 problems: the report says it is unfinished
    meta = json.loads((src / "sweep.json").read_text())
    part = tmp_path / "part"
    shutil.copytree(src, part)
    (part / "sweep.json").write_text(json.dumps(dict(meta, problems=48)))
    rep = sweep_report(part, tmp_path / "r2", figures=False)
    assert rep.summary["unfinished"] == {"problems": 48, "done": 6} and "**Unfinished:** 6 of the 48" in rep.text
    assert sweep_report(src, tmp_path / "r3", figures=False).summary["unfinished"] is None
    (part / "sweep.json").write_text('{"name": "sm')
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(SMALL), "--out", str(part)])
    assert r.exit_code == 3 and "damaged file" in r.output and "sweep.json" in r.output, r.output


def test_sweep_files_that_ask_for_nothing_or_a_clock_among_the_options_are_refused(tmp_path):
    """(Accepted before: 'problems: []' ran nothing and exited 0; options.time_limit was shown
    in the row and replaced by the sweep's own.)"""
    for text, words in (("name: e\nproblems: []\n", "problems: expected a file, folder or glob"),
                        (TINY + "options: {time_limit: 3}\n", "options.time_limit: expected the sweep file's own time_limit"),
                        (TINY.replace("  n_fruits: [2, 3, 4]", "  options.time_limit: [5, 10]"), "options.time_limit")):
        with pytest.raises(SweepError) as e:
            parse_sweep(text, "s.yaml", here=tmp_path)
        assert words in str(e.value), str(e.value)


def test_a_sweep_of_two_planners_keeps_them_apart(tmp_path):
    """(From a user's trial.) Options the coordinated planner does not take make no rows of
    their own; the report's coordinated / plan median counts only rows whose plan is not the
    coordinated one; a worst case names its planner when planners are varied."""
    from coplan.sweep.report import summarise

    spec = parse_sweep("name: two\nbase: row\nfixed: {n_arms: 2, spacing: 2.0, seed: 0}\nvary:\n"
                       "  options.search_work: [2000, 8000]\n  planner: [coordinated, optimal]\nplanner: coordinated\n",
                       "two.yaml")
    items = spec.items()
    assert sorted(it.planner for it in items) == ["coordinated", "optimal", "optimal"]
    assert next(it for it in items if it.planner == "coordinated").options == {}
    base = dict.fromkeys(COLUMNS)
    rows = [dict(base, key="a", name="p", status="success", planner="optimal", makespan=10.0, coordinated_makespan=11.0,
                 ratio=1.2, params="{}"),
            dict(base, key="b", name="p", status="success", planner="coordinated", makespan=11.0,
                 coordinated_makespan=11.0, ratio=1.3, params="{}")]
    s = summarise(rows)
    assert s["median_coordinated_over_plan"] == pytest.approx(1.1)
    assert [w["planner"] for w in s["worst"]["ratio"]] == ["coordinated", "optimal"]


def test_a_random_sweep_that_draws_fewer_problems_than_asked_says_so(tmp_path):
    spec = tmp_path / "rdup.yaml"
    spec.write_text("name: rdup\nbase: row\nmode: random\nsamples: 5\nfixed: {n_arms: 2, spacing: 2.0, seed: 0}\n"
                    "vary:\n  density: {from: 1.0, to: 1.2}\nplanner: coordinated\n")
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(spec), "--out", str(tmp_path / "o"), "--workers", "1"])
    assert r.exit_code == 0, r.output
    assert "distinct problems of the 5 samples asked" in r.output, r.output


def test_sweep_report_on_damaged_files_says_so(small_run, tmp_path):
    """(A cut-short results.parquet, or a file given in its place, was an internal error; a
    damaged journal line was left out in silence.) The table that does not read is named; a
    folder's report then comes from its journal, each line that is no row named."""
    from coplan.sweep.table import PARQUET

    src, _, _ = small_run
    out = tmp_path / "damaged"
    shutil.copytree(src, out)
    data = (out / PARQUET).read_bytes()
    (out / PARQUET).write_bytes(data[: len(data) // 2])
    lines = (out / JOURNAL).read_text().splitlines(keepends=True)
    (out / JOURNAL).write_text("".join(lines[:5]) + "{not json\n" + lines[5])
    notes: dict = {}
    assert read_table(out, notes).num_rows == 6 and "damaged" in notes["damaged"] and notes["unread"] == [6]
    unread: list[int] = []
    assert len(read_rows(out, unread)) == 6 and unread == [6]
    runner = CliRunner(env={"COLUMNS": "200"})
    r = runner.invoke(app, ["sweep-report", str(out), "--no-figures", "--out", str(tmp_path / "rep")])
    assert r.exit_code == 0 and "results.parquet" in r.output and "1 line (6) is no complete row" in r.output, r.output
    assert json.loads((tmp_path / "rep" / "report.json").read_text())
    r = runner.invoke(app, ["sweep-report", str(out / PARQUET), "--no-figures", "--out", str(tmp_path / "rep2")])
    assert r.exit_code == 3 and "expected a sweep's results table (Parquet), found a damaged" in r.output, r.output


def test_every_generated_base_expands_to_valid_problems_or_a_bad_input_item():
    from coplan.problem import parse_problem

    over = parse_sweep("base: overlap\nfixed: {spacing: 1.5, density: 2.0}\nvary: {n_arms: [2, 3]}\n", "o.yaml").items()
    assert [len(parse_problem(i.problem_text).fruits) for i in over] == [6, 9]  # round(2 /m x arms x 1.5 m)
    cell = parse_sweep("base: cell\nvary: {seed: [0, 1], n_arms: [3]}\n", "c.yaml").items()
    assert [len(parse_problem(i.problem_text).arms) for i in cell] == [3, 3] and cell[0].row_length is None
    rnd = parse_sweep("base: random\nvary: {seed: [5]}\n", "r.yaml").items()[0]
    from coplan.generate import random_problem, to_yaml

    assert rnd.problem_text == to_yaml(random_problem(5)) and rnd.source == "random_problem(seed=5)"
    tiny_arm = parse_sweep("base: row\nfixed: {n_arms: 2, links: [0.3, 0.2]}\n", "t.yaml").items()[0]
    assert tiny_arm.problem_text is None and "within reach" in tiny_arm.error
    # (a gantry row of 1e9 fruit per metre crashed the whole sweep: MemoryError, 149 GiB asked for)
    huge = parse_sweep("base: gantry\nvary: {density: [1e9]}\n", "g.yaml").items()[0]
    assert huge.problem_text is None and "expected at most 20000 fruit" in huge.error
    row, _ = solve_item(tiny_arm)
    assert (row["status"], row["exit_code"]) == ("bad input", int(ExitCode.BAD_INPUT))
    limits = parse_sweep("base: row\nfixed: {n_arms: 2, n_fruits: 2}\nvary: {max_velocity: [2.0, [1.0, 1.5]]}\n", "l.yaml").items()
    assert [parse_problem(i.problem_text).arms[0].max_velocity for i in limits] == [(2.0, 2.0), (1.0, 1.5)]


def test_an_output_folder_of_another_sweep_is_refused(small_run, tmp_path):
    out, _, _ = small_run
    with pytest.raises(SweepError, match="holding sweep 'small'"):
        run_sweep(parse_sweep(TINY, "tiny.yaml"), out, workers=1)
    assert len(read_rows(out)) == 6
    # the command line: a --out mistake, exit 2 (it was the sweep file's, exit 3, "name: expected ...")
    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY)
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(spec), "--out", str(out)])
    assert r.exit_code == int(ExitCode.USAGE), r.output
    assert f"--out {out}: expected the output folder of sweep 'tiny' or a new folder, found one holding sweep 'small'" in r.output
    assert len(read_rows(out)) == 6


def test_workers_and_a_scheduler_together_are_refused_by_the_api_as_by_the_command_line(tmp_path):
    """(``run_sweep(..., workers=2, scheduler=...)`` ran on the scheduler and dropped ``workers``
    without a word; the command line refuses both.) And ``--workers auto`` is the default, as
    ``run_sweep(workers="auto")`` and ``coplan solve --workers auto`` take it (it was refused)."""
    with pytest.raises(ValueError, match="expected either workers .* or scheduler .*, found both"):
        run_sweep(parse_sweep(TINY, "tiny.yaml"), tmp_path / "o", workers=2, scheduler="tcp://127.0.0.1:8786")
    assert not (tmp_path / "o").exists()
    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY)
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(spec), "--workers", "auto", "--out", str(tmp_path / "a")])
    assert r.exit_code == 0 and len(read_rows(tmp_path / "a")) == 3, r.output


def test_what_a_run_does_otherwise_than_its_sweep_file_asks_is_said(tmp_path):
    """(From a new user's trial, both silent: solver options beside a row file, which a row's solve
    does not take; and --planner in place of the planners the file varies -- said as "densities that
    round to the same number of fruit".)"""
    from coplan.generate import gantry_row, to_yaml

    (tmp_path / "row.yaml").write_text(to_yaml(gantry_row(length=4.0, n_arms=2, density=1.0, seed=3)))
    spec = tmp_path / "rowfile.yaml"
    spec.write_text("name: rowfile\nproblems: row.yaml\noptions: {search_work: 1000}\n")
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(spec), "--workers", "1", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "note: 1 problem file is a row (row.yaml): solved as coplan solve ROW solves it, without the sweep's solver " \
           "options" in " ".join(r.output.split())
    spec = tmp_path / "pv.yaml"
    spec.write_text("name: pv\nbase: row\nfixed: {n_fruits: 2, n_arms: 2, spacing: 2.0, seed: 1}\n"
                    "vary:\n  planner: [coordinated, heuristic]\n")
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(spec), "--workers", "1", "--planner", "coordinated",
                                                       "--out", str(tmp_path / "p")])
    assert r.exit_code == 0 and "note: --planner coordinated replaces the planners the sweep varies (coordinated, " \
        "heuristic)" in " ".join(r.output.split()), r.output


def test_a_range_past_what_a_parameter_takes_names_the_end_the_file_gives():
    """(``n_arms: {from: 2, to: 1000}`` said "found number 65", a value the file does not hold.)"""
    with pytest.raises(SweepError, match=r"vary\.n_arms: range: expected an integer >= 1 and <= 64 .*, found to: 1000"):
        parse_sweep("name: huge\nbase: row\nvary:\n  n_arms: {from: 2, to: 1000}\n", "huge.yaml")


def test_the_command_line_loads_neither_dask_nor_pyarrow():
    code = ("import sys, coplan.cli\n"
            "print(sorted(m for m in ('dask', 'distributed', 'pyarrow', 'numpy', 'yaml') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() in ("[]", "['yaml']")


def test_success_rate_counts_failed_solves_against_it():
    from coplan.sweep.report import summarise
    from coplan.sweep.table import normalise

    base = {"exit_class": "ok", "verified": True}
    rows = [normalise(dict(base, key=f"k{i}", status="success", reachable=5)) for i in range(7)]
    rows += [normalise(dict(base, key="n", status="infeasible", reachable=0, exit_class="infeasible")),
             normalise(dict(base, key="b", status="bad input", exit_class="bad input")),
             normalise(dict(base, key="t", status="timeout", exit_class="solver failed")),
             normalise(dict(base, key="p", status="partial", reachable=4, exit_class="partial"))]
    s = summarise(rows)
    assert (s["success_with_reachable_fruit"], s["with_reachable_fruit"]) == (7, 9)  # timeout and partial count
    assert s["counts"] == {"success": 7, "infeasible": 1, "bad input": 1, "timeout": 1, "partial": 1}
    assert {f["key"] for f in s["failures"]} == {"n", "b", "t", "p"}
    from coplan.sweep.report import _text

    assert "## Worst cases" not in _text(summarise(rows[7:]), "t")  # (no successful row: no empty heading)


def test_a_hung_solve_is_stopped_and_its_row_says_timeout(tmp_path):
    from coplan.sweep.run import Watchdog

    def hangs(item, state_dir, keep_plan):
        marker = Path(state_dir) / "timeouts" / item.key
        if item.index == 0 and not marker.exists():
            with Watchdog(0.5, marker):  # the hard limit, shortened: stops this worker process
                import time

                time.sleep(60)
        return solve_item(item, state_dir, keep_plan)

    res = run_sweep(parse_sweep(TINY, "tiny.yaml"), tmp_path / "out", workers=2, task=hangs)
    rows = {r["index"]: r for r in read_rows(tmp_path / "out")}
    assert res.done == 3 and rows[0]["status"] == RowStatus.TIMEOUT.value and rows[0]["exit_class"] == "solver failed"
    assert "hard limit" in rows[0]["message"] and {rows[1]["status"], rows[2]["status"]} == {"success"}
    # (its row had no solve_time nor problem columns: the solve-time figure left the slowest solve out)
    assert rows[0]["solve_time"] == hard_limit(rows[0]["time_limit"]) and rows[0]["n_arms"] == rows[1]["n_arms"]
    # with no retry the stopped solve is still a timeout, not "lost" (exit 9)
    again = run_sweep(parse_sweep(TINY + "retries: 0\n", "tiny.yaml"), tmp_path / "zero", workers=2, task=hangs)
    zero = {r["index"]: r for r in read_rows(tmp_path / "zero")}
    assert again.done == 3 and zero[0]["status"] == RowStatus.TIMEOUT.value and "hard limit" in zero[0]["message"]


def test_a_folder_or_glob_of_problem_files_is_a_sweep(problems_dir):
    folder = load_sweep(problems_dir)
    assert folder.base == SweepBase.FILES and len(folder.items()) == len(list(problems_dir.glob("*.yaml")))
    some = load_sweep(str(problems_dir / "*_arm*.yaml"))
    assert sorted(Path(i.source).name for i in some.items()) == sorted(p.name for p in problems_dir.glob("*_arm*.yaml"))
    with pytest.raises(SweepError, match="found none matching"):
        load_sweep(str(problems_dir / "nothing-*.yaml"))


def test_the_sweep_command_end_to_end(tmp_path):
    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY)
    out = tmp_path / "o"
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(out), "--workers", "1", "--csv"])
    assert r.exit_code == 0, r.output
    assert "3 problems (3 solved now, 0 already done)" in r.output and "success 3" in r.output
    header = (out / "results.csv").read_text().splitlines()[0]
    assert header.replace('"', "").split(",") == list(COLUMNS)
    assert len((out / "results.csv").read_text().splitlines()) == 4
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(out), "--planner", "heuristic",
                                                        "--keep-plans"])
    assert r.exit_code == 0 and "3 problems (3 solved now, 0 already done)" in r.output  # another planner: other keys
    assert "also holds 3 rows of other runs of this sweep (planner coordinated" in r.output  # (and says so)
    assert len(list((out / "plans").glob("*.json"))) == 3
    assert len((out / "results.csv").read_text().splitlines()) == 7  # (the CSV of the first run rewritten, not stale)
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(out), "--keep-plans"])
    assert r.exit_code == 0 and "3 of the 3 already done have no plan in" in " ".join(r.output.split())
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(out), "--planner", "heuristic",
                                                        "--keep-plans"])
    assert r.exit_code == 0 and "--keep-plans" not in r.output  # (every plan already there: nothing to say)
    rows = read_rows(out)
    assert len(rows) == 6 and sorted(r["planner"] for r in rows) == ["coordinated"] * 3 + ["heuristic"] * 3
    assert all(r["heuristic_makespan"] == r["makespan"] for r in rows if r["planner"] == "heuristic")
    spec.write_text(TINY.replace("n_fruits: [2, 3, 4]", "n_fruits: [2, 5]"))  # the spec changed, not the planner
    shutil.copytree(out, tmp_path / "o2")
    shutil.rmtree(tmp_path / "o2" / "plans")
    (tmp_path / "o2" / JOURNAL).write_text("".join(ln for ln in (out / JOURNAL).read_text().splitlines(keepends=True)
                                                   if '"planner": "heuristic"' in ln))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(tmp_path / "o2"), "--planner", "heuristic"])
    said = " ".join(r.output.split())
    assert r.exit_code == 0 and "also holds 2 rows of other runs" in said and "(planner" not in said, said
    assert "the same planners: other problems, time limits or options" in said


def test_designs_that_differ_in_links_or_time_limit_are_told_apart_in_the_report(tmp_path):
    """(Two link sets at one spacing were one zig-zag line of the throughput figure, and the
    Pareto table had no link column; a re-run with another time limit counted as a second seed.)"""
    from coplan.sweep.report import designs, sweep_report, varied
    from coplan.sweep.table import RowJournal

    base = {"exit_class": "ok", "verified": True, "status": "success", "reachable": 5, "n_arms": 3, "spacing": 1.4,
            "link_2": 0.8, "planner": "coordinated", "time_limit": 20.0, "sweep": "links", "name": "row",
            "params": json.dumps({"density": 2.0}), "makespan": 10.0}
    rows = [dict(base, key="a", link_1=1.0, seed=0, throughput=42.2), dict(base, key="b", link_1=0.8, seed=0, throughput=52.9),
            dict(base, key="c", link_1=1.0, seed=1, throughput=44.0),
            dict(base, key="d", link_1=1.0, seed=0, throughput=40.0, time_limit=25.0)]  # (a re-run: another time limit)
    journal = RowJournal(tmp_path)
    for r in rows:
        journal.append(r)
    table = [normalise(r) for r in rows]
    des = designs(table)
    assert varied(des) == ["link_1", "time_limit"]
    assert sorted((d["link_1"], d["time_limit"], d["seeds"], d["rows"]) for d in des) == [
        (0.8, 20.0, 1, 1), (1.0, 20.0, 2, 2), (1.0, 25.0, 1, 1)]
    rep = sweep_report(tmp_path)
    table_md = rep.text[rep.text.index("## Pareto front"):]
    assert "| link 1, m |" in table_md and "| time limit, s |" in table_md and "| 0.800 |" in table_md
    assert (tmp_path / "report" / "throughput.png").exists()
    # any other parameter the sweep set tells designs apart too (two dwells were one design, 'seeds 3')
    dwell = [normalise(dict(base, key=f"w{i}", link_1=1.0, seed=i % 3, throughput=40.0 + i,
                             params=json.dumps({"density": 2.0, "pick_dwell": 0.5 if i < 3 else 2.0, "seed": i % 3})))
             for i in range(6)]
    des = designs(dwell)
    assert sorted((d["params"]["pick_dwell"], d["seeds"], d["rows"]) for d in des) == [(0.5, 3, 3), (2.0, 3, 3)]
    assert varied(des) == ["pick_dwell"]


def _report_figures(folder, monkeypatch, rows, seen):
    """``sweep_report`` on ``rows`` journalled into ``folder``: ``({figure file: [seen(ax) for each
    of its axes]}, the report)``, each figure looked at as it is saved."""
    from matplotlib.figure import Figure
    from coplan.sweep.report import sweep_report
    from coplan.sweep.table import RowJournal

    journal = RowJournal(folder)
    for r in rows:
        journal.append(r)
    saved = {}
    real = Figure.savefig

    def savefig(fig, path, *a, **kw):
        saved[Path(path).name] = [seen(ax) for ax in fig.axes]
        return real(fig, path, *a, **kw)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved, sweep_report(folder)


def test_one_arm_designs_have_a_throughput_panel_and_file_rows_no_seed_none(tmp_path, monkeypatch):
    """(The arms curve's one-arm rows, which have no base spacing, were left out of throughput.png;
    the worst cases of rows swept from problem files read "seed None".)"""
    base = {"exit_class": "ok", "verified": True, "status": "success", "reachable": 5, "planner": "coordinated",
            "time_limit": 20.0, "sweep": "arms", "name": "row", "params": json.dumps({"density": 2.0}), "makespan": 10.0}
    rows = [dict(base, key="a", n_arms=1, spacing=None, seed=None, throughput=10.0),
            dict(base, key="b", n_arms=3, spacing=1.4, seed=None, throughput=25.0),
            dict(base, key="c", n_arms=3, spacing=1.8, seed=None, throughput=28.0)]
    saved, rep = _report_figures(tmp_path, monkeypatch, rows, lambda ax: (ax.get_title(), len(ax.lines)))
    assert saved["throughput.png"] == [("1 arm", 1), ("3 arms", 1)]
    assert "seed None" not in rep.text and "from its file" in rep.text


def test_each_throughput_panel_has_its_own_legend_and_no_density_the_sweep_did_not_set(tmp_path, monkeypatch):
    """(A cell sweep's throughput.png had one legend, the last panel's, whose colours named other
    designs in the first panel; and each label began '?', the density a cell's generator draws.)"""
    base = {"exit_class": "ok", "verified": True, "status": "success", "reachable": 5, "planner": "optimal",
            "time_limit": 20.0, "sweep": "cells", "name": "cell", "params": json.dumps({}), "makespan": 10.0}
    rows = [dict(base, key="a", n_arms=2, spacing=1.5, seed=0, throughput=10.0, link_1=0.8658),
            dict(base, key="b", n_arms=3, spacing=1.6, seed=1, throughput=25.0, link_1=0.8193),
            dict(base, key="c", n_arms=3, spacing=1.8, seed=2, throughput=28.0, link_1=0.9)]
    saved, _ = _report_figures(tmp_path, monkeypatch, rows,
                               lambda ax: (ax.get_title(), [t.get_text() for t in ax.get_legend().get_texts()]))
    assert saved["throughput.png"] == [("2 arms", ["l1 0.8658 m"]), ("3 arms", ["l1 0.8193 m", "l1 0.9 m"])]


def test_two_gantry_modes_of_one_row_are_two_designs_in_the_report_not_one_with_twice_the_seeds():
    from coplan.sweep.report import designs, summarise
    from coplan.sweep.table import normalise

    base = {"exit_class": "ok", "verified": True, "status": "success", "reachable": 5, "n_arms": 3, "spacing": 2.0,
            "link_1": 1.0, "link_2": 0.8, "planner": "coordinated", "seed": 2, "name": "row-8m-seed2", "params": "{}"}
    rows = [normalise(dict(base, key="a", gantry="stop-and-go", throughput=2.0, ratio=2.136)),
            normalise(dict(base, key="b", gantry="continuous", throughput=3.0, ratio=1.995))]
    des = designs(rows)
    assert sorted((d["gantry"], d["seeds"], d["throughput"]) for d in des) == [("continuous", 1, 3.0), ("stop-and-go", 1, 2.0)]
    worst = summarise(rows)["worst"]["ratio"]
    assert [(w["key"], w["gantry"]) for w in worst] == [("a", "stop-and-go"), ("b", "continuous")]
    # the mode a varied parameter too: said once (it read 'continuous, gantry "continuous"')
    from coplan.sweep.report import _text

    varied_rows = [dict(r, params=json.dumps({"gantry": r["gantry"]})) for r in rows]
    text = _text(summarise(varied_rows), "t")
    assert "seed 2, continuous, key b" in text and 'gantry "continuous"' not in text, text


def test_a_worst_case_names_the_parameters_its_rows_differ_in():
    """(Four worst cases read "row-2arms-1.8m-5fruit-seed1 (seed 1, key ...)", the same name,
    told apart by key alone: they differed in clearance and joint speed.) Each names the
    parameters the sweep's rows differ in besides the seed."""
    from coplan.sweep.report import summarise, _text
    from coplan.sweep.table import normalise

    base = {"exit_class": "ok", "verified": True, "status": "success", "reachable": 5, "n_arms": 2, "spacing": 1.8,
            "link_1": 1.0, "link_2": 0.8, "planner": "coordinated", "seed": 1, "name": "row-2arms-1.8m-5fruit-seed1"}
    rows = [normalise(dict(base, key=f"k{i}", throughput=10.0 + i, ratio=1.1 + 0.1 * i,
                           params=json.dumps({"clearance": c, "max_velocity": v, "seed": 1, "n_fruits": 5})))
            for i, (c, v) in enumerate([(0.05, 1.0), (0.05, 2.0), (0.15, 1.0), (0.15, 2.0)])]
    worst = summarise(rows)["worst"]["ratio"]
    assert [w["params"] for w in worst][:2] == [{"clearance": 0.15, "max_velocity": 2.0}, {"clearance": 0.15, "max_velocity": 1.0}]
    assert "seed 1, clearance 0.15, max_velocity 2.0, key k3)" in _text(summarise(rows), "t")


@pytest.mark.parametrize("presses", [1, 3])
def test_ctrl_c_on_a_sweep_stops_it_cleanly_without_the_workers_tracebacks(tmp_path, presses):
    """Ctrl-C reaches the whole foreground process group: each Dask worker printed its own
    KeyboardInterrupt traceback after the sweep's clean 'interrupted' (the workers now start with
    SIGINT ignored; the sweep stops them). Exit 130, the finished rows kept, resumable. Pressed
    three times 0.3 s apart it is the same, the table written (from a new user's trial: exit 142,
    SIGALRM -- a Ctrl-C swallowed as the interpreter shut down was sent again once Python had
    reset its handler -- and no results.parquet, the second Ctrl-C landing as it was written)."""
    import signal
    import time

    spec = tmp_path / "slow.yaml"
    spec.write_text("name: slow\nbase: random\nvary:\n  seed: {from: 0, to: 7}\nplanner: optimal\ntime_limit: 3\n")
    out = tmp_path / "out"
    # (Ctrl-C as a terminal has it: an xdist worker, this test's process, ignores SIGINT, and a
    # child inherits that -- the sweep then ran to its end)
    proc = subprocess.Popen([sys.executable, "-m", "coplan.cli", "sweep", str(spec), "--out", str(out), "--workers", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    journal = out / JOURNAL
    t0 = time.monotonic()
    while time.monotonic() - t0 < 120 and proc.poll() is None:  # a row finished: the workers are at work
        if journal.exists() and journal.read_text().strip():
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.communicate()
    for k in range(presses):
        if k:
            time.sleep(0.3)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == ExitCode.INTERRUPTED, (stdout, stderr)
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert "interrupted: every finished row is kept" in stdout + stderr
    assert 1 <= len(read_rows(out)) < 8 and (out / "results.parquet").is_file()


@pytest.mark.parametrize("address", ["localhost", "tcp://127.0.0.1", "http://127.0.0.1:8786", ""])
def test_a_malformed_scheduler_address_is_a_usage_error_before_any_work(tmp_path, address):
    """(It was an internal error, exit 1, from deep in Dask.)"""
    res = CliRunner().invoke(app, ["sweep", str(SMALL), "--scheduler", address, "--out", str(tmp_path / "o")])
    assert res.exit_code == ExitCode.USAGE, res.output
    assert "expected a Dask scheduler address such as tcp://10.0.0.5:8786" in " ".join(res.output.split())
    assert not (tmp_path / "o").exists()


def test_a_scheduler_port_nothing_listens_on_is_said_at_once_not_after_the_clients_timeout(tmp_path):
    """(Dask's client retried the refused connection for SCHEDULER_TIMEOUT, 20 s, before saying so.)"""
    import socket
    import time

    with socket.socket() as s:  # a port that was free a moment ago, and nothing listens on now
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    res = CliRunner().invoke(app, ["sweep", str(SMALL), "--scheduler", f"tcp://127.0.0.1:{port}", "--out", str(tmp_path / "o")])
    took = time.monotonic() - t0
    assert res.exit_code == ExitCode.USAGE, res.output
    said = " ".join(res.output.split())
    assert f"could not connect (connection refused at 127.0.0.1:{port}: no scheduler listens there)" in said, said
    assert took < 15.0, took  # (three tries 0.5 s apart; the client's own wait was 20 s)
    assert not (tmp_path / "o").exists()


def test_problems_left_without_a_result_make_the_sweep_exit_9_and_the_next_run_solves_them(tmp_path, monkeypatch):
    """(A sweep whose external scheduler died mid-run, or whose worker died on every attempt,
    had rows with status "lost" and exited 0: a script took the sweep for done.)"""
    import coplan.sweep.run as sweep_run

    def always_dies(item, state_dir, keep_plan):
        if item.index == 1:
            os.kill(os.getpid(), 9)  # every attempt: the task's worker process dies
        return solve_item(item, state_dir, keep_plan)

    real = sweep_run.run_sweep
    monkeypatch.setattr(sweep_run, "run_sweep", lambda *a, **k: real(*a, **dict(k, task=always_dies)))
    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY + "retries: 0\n")
    out = tmp_path / "o"
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(out), "--workers", "1"])
    said = " ".join(r.output.split())
    assert r.exit_code == int(ExitCode.INCOMPLETE) == 9, said
    rows = {r["index"]: r for r in read_rows(out)}
    lost = sorted(i for i, r in rows.items() if r["status"] == RowStatus.LOST.value)
    # (Dask may also give up on a task queued on the dying worker with no retry left: lost too)
    assert 1 in lost and all(rows[i]["status"] == "success" for i in rows if i not in lost)
    assert f"({3 - len(lost)} solved now, {len(lost)} lost, 0 already done)" in said, said  # (lost ones were 'solved')
    assert all(rows[i]["exit_class"] == "incomplete" and "died" in rows[i]["message"] for i in lost)
    n = len(lost)
    assert f"{n} problem{'s' if n > 1 else ''} of the sweep {'have' if n > 1 else 'has'} no result" in said, said
    assert "run the same command again" in said
    monkeypatch.setattr(sweep_run, "run_sweep", real)
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 0 and f"3 problems ({n} solved now, {3 - n} already done)" in " ".join(r.output.split()), r.output
    assert all([r["status"] for r in read_rows(out) if r["index"] == i][-1] == "success" for i in lost)


def test_ctrl_c_while_the_cluster_starts_stops_the_sweep(tmp_path):
    """(The local cluster starts with SIGINT ignored, so that its workers inherit that: a Ctrl-C
    then was dropped, and the sweep ran every problem and exited 0. It is held now, and answered
    once the cluster is up.)"""
    import signal
    import time

    import psutil

    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "coplan.cli", "sweep", str(spec), "--out", str(out), "--workers", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    me = psutil.Process(proc.pid)
    t0 = time.monotonic()
    def worker_started() -> bool:  # a worker process of the cluster (its command line says so)
        try:
            return any("--multiprocessing-fork" in c.cmdline() for c in me.children())
        except psutil.Error:
            return False

    while time.monotonic() - t0 < 60 and proc.poll() is None and not worker_started():
        time.sleep(0.02)
    starting = proc.poll() is None and not (out / "sweep.json").exists()
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert starting, "the Ctrl-C did not land while the cluster started"
    assert proc.returncode == ExitCode.INTERRUPTED, (stdout, stderr)
    assert "Traceback" not in stderr and len(read_rows(out)) < 3, stderr


def test_a_ctrl_c_swallowed_where_it_landed_still_stops_the_sweep():
    """(A Ctrl-C that landed in Dask's garbage-collection callback was printed as 'Exception
    ignored' and lost: the sweep ran on to its end and exited 0. The sweep's handler remembers
    it, and the loop over finished solves asks between its waits.)"""
    import signal

    from coplan.sweep.cluster import Interrupt, completed

    class Waiting:  # a distributed.as_completed with nothing finished yet
        def is_empty(self):
            return False

        def next_batch(self, block=True):
            return []

    with Interrupt() as stop:
        if signal.getsignal(signal.SIGINT) == stop._handler:
            with pytest.raises(KeyboardInterrupt):
                signal.getsignal(signal.SIGINT)(signal.SIGINT, None)  # raised where it lands ...
        stop.seen = True  # ... and, swallowed there, still remembered
        with pytest.raises(KeyboardInterrupt):
            next(completed(Waiting(), stop, poll=0.01))


def test_a_problem_file_given_as_the_sweep_file_is_said_to_be_one(problems_dir):
    """(It listed six unknown keys: base missing, arms unknown -- did you mean 'vary'?, ...)"""
    with pytest.raises(SweepError) as e:
        load_sweep(problems_dir / "crossing_paths.yaml")
    assert len(e.value.issues) == 1 and "found a problem file" in str(e.value) and "glob" in str(e.value)


def test_a_row_file_in_a_files_sweep_has_its_rail_as_its_length(tmp_path):
    """(A generated 8 m row swept from its file had row_length 6.0 -- arms x spacing -- so its
    density and throughput per metre were a third too high.)"""
    from coplan.generate import gantry_row, to_yaml
    from coplan.sweep.columns import problem_columns
    from coplan.problem import parse_problem

    path = tmp_path / "row8.yaml"
    path.write_text(to_yaml(gantry_row(length=8, n_arms=3, density=3, seed=1)))
    (item,) = load_sweep(str(path.parent / "row8*.yaml")).items()
    problem = parse_problem(item.problem_text)
    cols = problem_columns(problem, item)
    assert cols["row_length"] == 8.0 and cols["density"] == pytest.approx(len(problem.fruits) / 8.0)


def test_a_value_repeated_in_a_list_is_refused_at_its_line():
    """(``seed: [0, 0]`` made one problem of two, silently.)"""
    text = "name: dup\nbase: row\nfixed:\n  n_arms: 2\n  n_fruits: 4\nvary:\n  seed: [0, 0]\n  spacing: [1.6, 2.0, 2]\n"
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "dup.yaml")
    by_path = {i.path: i for i in e.value.issues}
    assert set(by_path) == {"vary.seed[1]", "vary.spacing[2]"}
    assert by_path["vary.seed[1]"].line == 7 and "expected distinct values, found number 0 again" in by_path["vary.seed[1]"].message
    nested = "name: dup\nbase: row\nfixed:\n  n_arms: 2\n  n_fruits: 4\nvary:\n  y_range: [[0.5, 1], [0.5, 1.0]]\n"
    with pytest.raises(SweepError) as e:  # (pairs compared as text: one problem made of two)
        parse_sweep(nested, "dup.yaml")
    assert [i.path for i in e.value.issues] == ["vary.y_range[1]"]


def test_the_sweep_s_ctrl_c_handler_is_installed_under_the_coplan_console_too():
    """(Under the ``coplan`` command the console's SIGINT handler is not Python's own, and the
    sweep's, which remembers a Ctrl-C a callback swallowed, was never installed.) Before it,
    Python's or the console's (marked as raising as Python's does): installed, the console's
    still told; anything else: left alone."""
    import signal

    from coplan.sweep.cluster import Interrupt

    told = []

    def console(signum, frame):
        told.append(signum)
        raise KeyboardInterrupt

    console.raises_keyboard_interrupt = True
    old = signal.signal(signal.SIGINT, console)
    try:
        stop = Interrupt().__enter__()
        assert stop.old is console and signal.getsignal(signal.SIGINT) == stop._handler
        with pytest.raises(KeyboardInterrupt):
            stop._handler(signal.SIGINT, None)
        assert stop.seen and told == [signal.SIGINT]
        stop.__exit__()
        assert signal.getsignal(signal.SIGINT) is console
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        assert Interrupt().__enter__().old is None  # (ignored: a sweep leaves that as it is)
    finally:
        signal.signal(signal.SIGINT, old)


def test_a_range_whose_step_misses_its_end_is_refused_not_cut_short():
    """{from: 1.0, to: 2.0, step: 0.3} used to sweep 1.0 ... 1.9 and drop 2.0 without a word."""
    text = "name: s\nbase: row\nvary:\n  spacing: {from: 1.0, to: 2.0, step: 0.3}\n"
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "s.yaml")
    (issue,) = e.value.issues
    assert issue.path == "vary.spacing" and issue.line == 4
    assert "last value would be 1.9" in issue.message and "count" in issue.message
    # a step that divides the span (up to rounding: 0.2 into 1.4) is fine, its end included
    ok = parse_sweep(text.replace("to: 2.0, step: 0.3", "to: 2.6, step: 0.2").replace("1.0", "1.2"), "s.yaml")
    assert ok.vary["spacing"][0] == 1.2 and ok.vary["spacing"][-1] == 2.6 and len(ok.vary["spacing"]) == 8


@pytest.mark.parametrize("text, path, words", [
    # (internal errors, exit 1: a local list named 'found' hid found(); set membership of a list)
    ("problems: 5\n", "problems", "expected a file, folder or glob, found number 5"),
    ("problems: [a.yaml, 3]\n", "problems[1]", "expected a file, folder or glob, found number 3"),
    ("base: [row]\n", "base", "expected one of row, overlap"),
    ("base: {row: 1}\n", "base", "expected one of row, overlap"),
    ("base: row\nmode: [grid]\n", "mode", "expected one of grid, random"),
    # (ignored: every problem had the generators' seed 0)
    ("base: row\nseed: 5\nvary: {n_arms: [2, 3]}\n", "seed", "expected 'seed' only with mode: random"),
    ("base: row\nsamples: 3\nvary: {n_arms: [2, 3]}\n", "samples", "expected 'samples' only with mode: random"),
    # (the varied values won without a word)
    ("base: row\noptions: {search_work: 100}\nvary:\n  options.search_work: [100, 200]\n", "vary.options.search_work",
     "found 'search_work' both in options and varied"),
    ("base: row\noptions: {search_work: 200}\nfixed:\n  options.search_work: 100\n", "fixed.options.search_work",
     "found 'search_work' both in options and fixed"),
    # (rounded to 2, 3: two problems of the five asked, silently)
    ("base: row\nvary:\n  n_arms: {from: 2, to: 3, count: 5}\n", "vary.n_arms", "expected a count that gives whole numbers"),
    ("base: row\nvary:\n  n_arms: {from: 2, to: 4, count: 1}\n", "vary.n_arms", "expected a count of at least 2"),
])
def test_sweep_file_mistakes_that_were_internal_errors_or_silent_are_named(text, path, words):
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "s.yaml")
    got = {i.path: i.message for i in e.value.issues}
    assert path in got and words in got[path], got


def test_an_integer_range_with_a_count_that_fits_is_its_values():
    spec = parse_sweep("base: row\nvary:\n  n_arms: {from: 2, to: 5, count: 4}\n", "s.yaml")
    assert spec.vary["n_arms"] == [2, 3, 4, 5]


def test_a_big_sweep_says_it_is_making_its_problems_before_the_wait(tmp_path, monkeypatch):
    """(A grid of 64,320 problems printed nothing for minutes while its problems were made.)"""
    import coplan.sweep.run as sweep_run

    def stop(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_run, "run_sweep", stop)
    (tmp_path / "big.yaml").write_text("base: row\nplanner: coordinated\nvary:\n  seed: {from: 0, to: 1199}\n")
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(tmp_path / "big.yaml"), "--out", str(tmp_path / "o")])
    assert "making its 1,200 problems" in " ".join(r.output.split()), r.output
    (tmp_path / "small.yaml").write_text("base: row\nplanner: coordinated\nvary:\n  seed: [0, 1]\n")
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(tmp_path / "small.yaml"), "--out", str(tmp_path / "s")])
    assert "making its" not in r.output


def test_parameter_sets_that_make_one_problem_are_said(tmp_path):
    """(Eleven densities from 0.5 to 1.5 on a 2-arm row round to five fruit counts: five problems
    ran and six values vanished without a word.)"""
    spec = tmp_path / "d.yaml"
    spec.write_text("base: row\nplanner: coordinated\nfixed: {n_arms: 2}\nvary:\n  density: {from: 0.5, to: 1.5, step: 0.1}\n")
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["sweep", str(spec), "--out", str(tmp_path / "o"), "--workers", "1"])
    said = " ".join(r.output.split())
    n = len(load_sweep(spec).items())
    assert r.exit_code == 0 and n < 11 and f"note: {11 - n} of the 11 parameter sets make a problem another set makes too" in said, said


def test_a_snapshot_that_cannot_be_written_does_not_stop_the_sweep(tmp_path, monkeypatch):
    """(On Windows results.csv open in a spreadsheet cannot be replaced: the periodic snapshot's
    error stopped the sweep part-way, exit 8, naming a hidden temporary file.) The sweep goes on;
    the final table's error names the file itself."""
    import os

    import coplan.sweep.run as sweep_run
    import coplan.sweep.table as table

    spec = tmp_path / "s.yaml"
    spec.write_text("base: row\nplanner: coordinated\nvary:\n  seed: [0, 1, 2]\n")
    monkeypatch.setattr(sweep_run, "SNAPSHOT_SECONDS", -1.0)  # (a snapshot after every row)
    real = os.replace
    calls = []

    def busy(src, dst):
        if str(dst).endswith("results.parquet"):
            calls.append(dst)
            if len(calls) == 1:  # (the first snapshot: the file is open elsewhere)
                raise PermissionError(13, "Access is denied", str(src))
        return real(src, dst)

    monkeypatch.setattr(table.os, "replace", busy)
    out = run_sweep(load_sweep(spec), tmp_path / "o", workers=1)
    assert out.done == 3 and out.counts == {"success": 3} and "Access is denied" in out.snapshot_error
    assert "results.parquet" in out.snapshot_error and ".tmp" not in out.snapshot_error
    assert len(read_table(tmp_path / "o")) == 3


def test_the_table_s_pyarrow_is_imported_before_the_sweep_s_work_starts(tmp_path):
    """A Ctrl-C while the first snapshot imported pyarrow left it half imported, and the table
    written after it failed: exit 1 (internal error, "module 'pyarrow' has no attribute 'lib'")
    instead of 130. The sweep imports what the table needs before its work starts: in a fresh
    process, the modules are there when the first row comes, before any snapshot."""
    script = textwrap.dedent(f"""
        import sys
        from coplan.sweep.run import run_sweep
        from coplan.sweep.spec import load_sweep
        seen = []
        run_sweep(load_sweep({str(SMALL)!r}), {str(tmp_path / 'out')!r}, workers=1,
                  on_row=lambda row, o: seen.append(all(m in sys.modules for m in ("pyarrow.lib", "pyarrow.csv", "pyarrow.parquet"))))
        print(seen[0])
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "True"


def test_a_row_that_is_not_a_success_says_why_and_shows_no_ratio_to_a_bound_it_does_not_answer():
    """A partial row's message names the first fruit left out and why (the screen's reason, or
    the planner's), and it has no ratio (the bound counts the fruit it left: 0.73 x 'a bound no
    plan can beat'); a problem with no fruit says so, its makespan and bound empty, not 0.0."""
    from coplan.generate import row_problem, to_yaml

    d = row_problem(n_arms=2, n_fruits=4, spacing=0.2, seed=1)
    row, _ = solve_item(SweepItem(0, "k1", {"seed": 1}, "coordinated", {}, 30.0, "row", to_yaml(d)))
    assert row["status"] == "partial" and row["ratio"] is None
    assert "left out: f003: only arm1 reaches it and arm1 cannot reach its bin" in row["message"], row["message"]
    d = row_problem(n_arms=2, n_fruits=4, spacing=0.2, seed=2)
    # (the planner's reason: with its planning buffer kept, the arms take turns and leave a fruit out;
    # without it, since 2620c3e, it harvests all the screen allows)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("coplan.planners.coordinated.planner._without_margin", lambda *args: None)
        row, _ = solve_item(SweepItem(1, "k2", {"seed": 2}, "coordinated", {}, 30.0, "row", to_yaml(d)))
    assert row["status"] == "partial" and "no serial schedule" in row["message"], row["message"]
    row, _ = solve_item(SweepItem(1, "k2", {"seed": 2}, "coordinated", {}, 30.0, "row", to_yaml(d)))
    assert row["message"] == "partial: 3/4 fruit harvested; left out: f002: only arm1 reaches it and arm1 cannot reach its bin"
    d = row_problem(n_arms=2, n_fruits=0, spacing=0.2, seed=0)
    row, _ = solve_item(SweepItem(2, "k3", {}, "coordinated", {}, 30.0, "row", to_yaml(d)))
    assert row["status"] == "infeasible" and "no fruit" in row["message"]
    assert row["makespan"] is None and row["lower_bound"] is None and row["ratio"] is None


def test_a_sweep_interrupted_before_its_first_row_says_what_its_folder_holds(tmp_path, monkeypatch):
    """(A SIGTERM 2 s in said "interrupted before any problem was solved: nothing written" beside the
    empty results.parquet and sweep.json it had written.)"""
    import coplan.sweep.run as sweep_run

    def cut(sw, folder, **kw):
        Path(folder).mkdir(parents=True, exist_ok=True)
        (Path(folder) / "sweep.json").write_text("{}")
        (Path(folder) / "results.parquet").write_bytes(b"")
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_run, "run_sweep", cut)
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["sweep", str(SMALL), "--out", str(tmp_path / "o")])
    said = " ".join(r.output.split())
    assert r.exit_code == int(ExitCode.INTERRUPTED) and "nothing written" not in said, said
    assert "no rows;" in said and "results.parquet, sweep.json (no row in any)" in said
