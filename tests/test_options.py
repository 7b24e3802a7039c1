"""Solver options from a file (``--options``): validated like problem files, recorded in plan.json."""

from __future__ import annotations

import json
from dataclasses import asdict, fields
from pathlib import Path

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.kinds import ExitCode
from coplan.planners.optimal import OptimalOptions
from coplan.planners.optimal import OptionsError, load_options, parse_options


def run(*args: str):
    return CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(app, list(args))


def test_every_field_round_trips_through_yaml() -> None:
    """Every OptimalOptions field can be set from a file (values different from the defaults)."""
    import yaml

    d = OptimalOptions()
    changed = {}
    for f in fields(OptimalOptions):
        v = getattr(d, f.name)
        changed[f.name] = (not v if isinstance(v, bool) else v + 3 if isinstance(v, int) else v * 2 + 0.5
                           if isinstance(v, float) else 7.5 if v is None else {"ipopt.max_iter": 50})
    changed["margin"] = 0.25  # (within its range: at most 0.5 m)
    changed["tolerance"] = 0.005  # (at most 0.01 s)
    back = parse_options(yaml.safe_dump(changed), "all.yaml")
    assert asdict(back) == changed


def test_empty_file_is_the_defaults(tmp_path: Path) -> None:
    (tmp_path / "o.yaml").write_text("# nothing\n")
    assert load_options(tmp_path / "o.yaml") == OptimalOptions()


BAD = [
    ("search_wrok: 5\n", "search_wrok", "did you mean 'search_work'?"),
    ("search_work: -1\n", "search_work", "expected a non-negative integer, found number -1"),
    ("search_work: 2.5\n", "search_work", "expected a non-negative integer, found number 2.5"),
    ("polish: yes please\n", "polish", "expected true or false, found string 'yes please'"),
    ("margin: .inf\n", "margin", "expected a non-negative number, found number inf"),
    ("widen_cap: 1e400\n", "widen_cap", "expected a number coplan can hold, found 1e400 (beyond a float's range)"),
    ("widen_cap: -.inf\n", "widen_cap", "expected a non-negative number, found number -inf (not finite)"),
    ("time_limit: 0\n", "time_limit", "expected a positive number or null, found number 0"),
    ("window: true\n", "window", "expected a positive number, found boolean True"),
    ("ipopt: 5\n", "ipopt", "expected a mapping of IPOPT settings"),
    ("ipopt: {ipopt.tol: [1]}\n", "ipopt", "expected setting: number or string"),
    # (1e-9 s built billions of knots: 23 GB of memory; 0 polish iterations or rounds crashed the polish)
    ("h_target: 1.0e-9\n", "h_target", "within [0.005, 1], found 1e-09"),
    ("check_rate: 1.0e+9\n", "check_rate", "within [100, 100000]"),
    ("polish_iterations: 0\n", "polish_iterations", "expected a positive integer, found number 0"),
    ("polish_rounds: 0\n", "polish_rounds", "expected a positive integer"),
    ("max_rounds: 0\n", "max_rounds", "expected a positive integer"),
]


@pytest.mark.parametrize("text,key,fragment", BAD, ids=[b[1] + str(i) for i, b in enumerate(BAD)])
def test_bad_options_name_file_line_and_key(tmp_path: Path, text: str, key: str, fragment: str) -> None:
    path = tmp_path / "opts.yaml"
    path.write_text("# solver options\n" + text)
    with pytest.raises(OptionsError) as ei:
        load_options(path)
    (it,) = ei.value.issues
    assert it.path == key and it.line == 2 and fragment in it.message
    assert it.message.startswith("expected ")
    # and through the CLI: exit 3, the same message, nothing solved
    res = run("solve", "--options", str(path), "--out", str(tmp_path / "out"))
    assert res.exit_code == int(ExitCode.BAD_INPUT) and f"{path}:2: {key}: " in res.output
    assert not (tmp_path / "out" / "plan.json").exists()


def test_options_reach_the_planner_and_plan_json(tmp_path: Path, problems_dir: Path) -> None:
    opts = tmp_path / "opts.yaml"
    opts.write_text("search_work: 300\nsearch_temperature: 0.0\npolish: false\nseed: 4\n")
    res = run("solve", str(problems_dir / "crossing_paths.yaml"), "--options", str(opts), "--out", str(tmp_path / "o"))
    assert res.exit_code == 0, res.output
    used = json.loads((tmp_path / "o" / "plan.json").read_text())["solver"]["options"]
    assert (used["search_work"], used["search_temperature"], used["polish"], used["seed"]) == (300, 0.0, False, 4)
    assert json.loads((tmp_path / "o" / "plan.json").read_text())["solver"]["search"]["checks"] <= 300 + 600


def test_options_with_the_heuristic_is_a_usage_error(tmp_path: Path) -> None:
    opts = tmp_path / "opts.yaml"
    opts.write_text("seed: 1\n")
    res = run("solve", "--planner", "heuristic", "--options", str(opts), "--out", str(tmp_path / "o"))
    assert res.exit_code == int(ExitCode.USAGE) and "the heuristic planner has no solver options" in res.output
    # nor a time limit: refused, not silently ignored
    res = run("solve", "--planner", "heuristic", "--time-limit", "5", "--out", str(tmp_path / "o"))
    assert res.exit_code == int(ExitCode.USAGE) and "--time-limit: the heuristic planner" in res.output
    assert not (tmp_path / "o").exists()
    # nor --workers where no planner compared has a search (compare ignored it, solve refused it)
    res = run("compare", "single_arm", "--planner", "heuristic", "--planner", "coordinated", "--workers", "2",
              "--no-figures", "--out", str(tmp_path / "c"))
    assert res.exit_code == int(ExitCode.USAGE) and "--workers: no planner compared has a search" in res.output, res.output
    assert not (tmp_path / "c").exists()


def test_ipopt_settings_are_checked_before_any_work(tmp_path: Path) -> None:
    """(A bad IPOPT setting passed the options check and failed inside the first program, an
    internal error after seconds of solving, exit 1.) CasADi and IPOPT judge each setting on a
    one-variable program when the options are made: exit 3, each bad setting on its line."""
    text = ("ipopt:\n  ipopt.tol: x\n  ipopt.max_iter: -5\n  ipopt.mu_strategy: bogus\n  ipopt.nonsense: 2\n"
            "  print_tme: true\n  ipopt.max_cpu_time: 10\n")
    with pytest.raises(OptionsError) as e:
        parse_options(text, "o.yaml")
    got = {(i.path, i.line): i.message for i in e.value.issues}
    assert got.keys() == {("ipopt.ipopt.tol", 2), ("ipopt.ipopt.max_iter", 3), ("ipopt.ipopt.mu_strategy", 4),
                          ("ipopt.ipopt.nonsense", 5), ("ipopt.print_tme", 6)}
    assert "found 'x'" in got[("ipopt.ipopt.tol", 2)]
    assert "0 <= (3000) <= +inf" in got[("ipopt.ipopt.max_iter", 3)] and "found -5" in got[("ipopt.ipopt.max_iter", 3)]
    assert "one of: monotone, adaptive" in got[("ipopt.ipopt.mu_strategy", 4)]
    assert "did you mean 'print_time'?" in got[("ipopt.print_tme", 6)]
    assert parse_options("ipopt: {ipopt.tol: 1.0e-6, ipopt.max_iter: 50}\n").ipopt == {"ipopt.tol": 1e-6, "ipopt.max_iter": 50}
    with pytest.raises(OptionsError, match="ipopt.ipopt.tol: expected a value of the type IPOPT's tol takes"):
        OptimalOptions(ipopt={"ipopt.tol": "x"})  # built in Python: the same check
    path = tmp_path / "o.yaml"
    path.write_text(text)
    res = CliRunner().invoke(app, ["solve", "crossing_paths", "--options", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == ExitCode.BAD_INPUT and "o.yaml:3: ipopt.ipopt.max_iter" in res.output, res.output
    assert not (tmp_path / "out").exists()


def test_a_margin_that_leaves_no_room_is_refused_in_a_file_and_in_python(tmp_path: Path) -> None:
    """(``margin: 5`` was read; the planners then spent their whole budget finding no room.)"""
    from coplan.planners.coordinated import CoordinatedOptions
    from coplan.row.continuous import MovingOptions

    f = tmp_path / "o.yaml"
    f.write_text("margin: 5\n")
    with pytest.raises(OptionsError, match=r"o\.yaml:1: margin: expected a planning margin of at most 0\.5 m"):
        load_options(f)
    for cls in (OptimalOptions, CoordinatedOptions, MovingOptions):
        with pytest.raises(OptionsError, match="margin: expected a planning margin of at most"):
            cls(margin=0.6)
        assert cls(margin=0.5).margin == 0.5


def test_a_tolerance_that_would_call_a_slower_plan_proven_optimal_is_refused(tmp_path: Path) -> None:
    """(``tolerance: 10`` was read: 6.50 s against a 5.66 s bound was then 'proven optimal'.)"""
    f = tmp_path / "o.yaml"
    f.write_text("search_work: 10\ntolerance: 10\n")
    with pytest.raises(OptionsError, match=r"o\.yaml:2: tolerance: expected a tolerance of at most 0\.01 s"):
        load_options(f)
    with pytest.raises(OptionsError, match="tolerance: expected a tolerance of at most 0.01 s"):
        OptimalOptions(tolerance=0.5)
    assert OptimalOptions(tolerance=0.01).tolerance == 0.01 and OptimalOptions().tolerance == 1e-3


def test_a_time_limit_stops_the_coordinated_search_after_its_first_candidate_when_none_is_feasible(problems_dir: Path) -> None:
    """(A margin leaving no room: every candidate was tried, 8 x a 3 s limit.) The first candidate is
    always tried; then, past the limit, the arms take turns -- and the plan is still verified."""
    from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
    from coplan.problem import load_problem

    p = load_problem(problems_dir / "crossing_paths.yaml")
    res = plan_coordinated(p, options=CoordinatedOptions(margin=0.3, time_limit=0.0))
    cands = res.plan.solver["candidates"]
    attempts = [c for c in cands if "schedules" in c and "fallback" not in c]
    assert len(attempts) == 1 and not attempts[0]["feasible"]
    assert any("fallback" in c for c in cands) and res.verification.passed


def test_another_coplan_file_given_as_options_is_named_in_one_sentence(tmp_path: Path, problems_dir: Path) -> None:
    """(A plan.json given to --options listed each of its 13 keys as an unknown option.)"""
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"format": "coplan.plan/1", "problem": "p", "planner": "heuristic", "time": [0.0]}))
    csv = tmp_path / "plan.csv"
    csv.write_text("t,left_q1,left_q2\n0,0,0\n")
    for path, what in ((plan, "a coplan plan file (format 'coplan.plan/1')"), (problems_dir / "crossing_paths.yaml", "a problem file"),
                       (csv, "a coplan plan CSV")):
        with pytest.raises(OptionsError) as e:
            load_options(path)
        assert len(e.value.issues) == 1 and what in str(e.value) and "were the arguments swapped?" in str(e.value)
    r = CliRunner().invoke(app, ["solve", str(problems_dir / "crossing_paths.yaml"), "--options", str(plan), "-o", str(tmp_path / "o")])
    assert r.exit_code == ExitCode.BAD_INPUT and "unknown key" not in r.output and not (tmp_path / "o").exists()


def test_ipopt_settings_changed_after_the_options_were_made_are_refused_before_any_work():
    """(OptimalOptions is frozen but its ipopt dict is not: a value changed afterwards ran the
    whole search, then came back 'success' with an error and exit code 1.)"""
    from coplan.errors import OptionsError
    from coplan.planners.optimal.planner import plan_optimal
    from coplan.problem import load_problem, shipped_problems

    o = OptimalOptions(search_work=300, ipopt={"ipopt.max_iter": 50})
    o.ipopt["ipopt.max_iter"] = "lots"
    problem = load_problem(next(p for p in shipped_problems() if p.name == "single_arm.yaml"))
    with pytest.raises(OptionsError, match=r"as changed since it was made.*ipopt.ipopt.max_iter.*found 'lots'"):
        plan_optimal(problem, options=o)


def test_the_coordinated_planners_options_are_recorded_in_the_plan(tmp_path):
    """(``--planner coordinated --time-limit 5`` or ``--options`` left solver.options out of plan.json:
    the run could not be made again from its file.)"""
    from coplan.problem import default_problem_path

    r = CliRunner().invoke(app, ["solve", str(default_problem_path().with_name("single_arm.yaml")), "--planner", "coordinated",
                                 "--time-limit", "5", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    opts = json.loads((tmp_path / "o" / "plan.json").read_text())["solver"]["options"]
    assert opts["time_limit"] == 5.0 and "margin" in opts


def test_a_work_budget_beyond_any_run_is_refused_a_seed_is_not():
    """(``search_work: 1e30`` was taken, recorded as 1000000000000000019884624838656 checks: a
    typo in the exponent that never ends.)"""
    with pytest.raises(OptionsError) as e:
        parse_options("search_work: 1e30\n", "o.yaml")
    (issue,) = e.value.issues
    assert issue.path == "search_work" and issue.line == 1 and "at most 1,000,000,000" in issue.message
    with pytest.raises(OptionsError):
        OptimalOptions(widen_iterations=10**12)
    assert OptimalOptions(search_work=10**9).search_work == 10**9
    assert OptimalOptions(seed=2**40).seed == 2**40


def test_an_integer_option_written_with_an_exponent_beyond_2_to_53_is_refused():
    """(seed: 1e40 was taken, and plan.json recorded 10000000000000000303786028427003666890752.)"""
    with pytest.raises(OptionsError) as e:
        parse_options("seed: 1e40\n")
    assert "seed" in str(e.value) and "not exact beyond 2^53" in str(e.value)
    assert parse_options("seed: 12345678901234567890\n").seed == 12345678901234567890  # (in full: kept)
    assert parse_options("seed: 1.0e3\n").seed == 1000
