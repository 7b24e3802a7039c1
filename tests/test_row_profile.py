"""``coplan solve ROW --profile``: what the speed search on the move varies (coplan.row.moving)."""

from __future__ import annotations

import json

import pytest

from typer.testing import CliRunner

from coplan.cli import app
from coplan.generate import gantry_row, to_yaml
from coplan.problem import parse_problem
from coplan.row.continuous import MovingOptions
from coplan.row.metrics import row_metrics
from coplan.row.moving import plan_moving

runner = CliRunner()


def test_the_search_over_one_constant_speed_is_the_one_python_plans(tmp_path):
    """The command's plan with --profile constant is plan_moving's with that profile (a
    cross-check of the two paths), recorded and said; the default stays density."""
    text = to_yaml(gantry_row(length=8.0, density=3.0, seed=5))
    f = tmp_path / "row.yaml"
    f.write_text(text)
    r = runner.invoke(app, ["solve", str(f), "--gantry", "continuous", "--profile", "constant", "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    doc = json.loads((tmp_path / "c" / "plan.json").read_text())
    row = doc["solver"]["row"]
    assert row["profile"] == "constant" and row["options"]["profile"] == "constant" and "constant speed profile" in r.output
    prob = parse_problem(text, "row.yaml")
    alone = plan_moving(prob, MovingOptions(profile="constant"))
    assert doc["metrics"]["row"]["row_time"] == row_metrics(prob, alone)["row_time"] and alone.verification.passed
    assert [p["level"] for p in row["speed_curve"]] == [p["level"] for p in alone.info["speed_curve"]]
    r = runner.invoke(app, ["solve", str(f), "--gantry", "continuous", "--out", str(tmp_path / "d")])
    assert r.exit_code == 0 and json.loads((tmp_path / "d" / "plan.json").read_text())["solver"]["row"]["profile"] == "density"


def test_profile_is_refused_where_it_means_nothing(tmp_path, problems_dir):
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=8.0, density=3.0, seed=5)))
    for args, said in ((["--stops", "optimised", "--profile", "constant"], "--profile and --stops: --profile plans the row on the move"),
                       (["--gantry", "stop-and-go", "--profile", "density"], "--profile: the speed search's profile applies on the move"),
                       (["--gantry", "continuous", "--speed", "0.2", "--profile", "density"], "--profile density: --speed gives one"),
                       (["--gantry", "continuous", "--speed", "0.2", "--profile", "auto"], "--profile auto: --speed gives one"),
                       (["--gantry", "continuous", "--profile", "fast"], "fast")):
        r = runner.invoke(app, ["solve", str(f), *args, "--out", str(tmp_path / "x")])
        assert r.exit_code == 2 and said in " ".join(r.output.split()), (args, r.output)
    r = runner.invoke(app, ["solve", str(problems_dir / "crossing_paths.yaml"), "--profile", "constant", "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "crossing-paths is a stationary cell" in " ".join(r.output.split()), r.output
    assert not (tmp_path / "x").exists()


def test_auto_searches_both_profiles_and_keeps_the_better(tmp_path, monkeypatch):
    """``profile=auto``: each profile's search as it is alone (the same plans), the better kept
    (complete, then most fruit per hour), both curves recorded; a level is refused; a Ctrl-C in
    the second search keeps the first's plan, said interrupted."""
    import coplan.row.moving as moving
    from coplan.errors import OptionsError
    from coplan.kinds import PlanStatus

    prob = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=3, density=8.0, seed=2)), "row.yaml")
    res = plan_moving(prob, MovingOptions(profile="auto"))
    alone = {p: plan_moving(prob, MovingOptions(profile=p)) for p in ("density", "constant")}
    profs = res.info["profiles"]
    for p, r in alone.items():
        assert profs[p]["row_time"] == r.plan.metrics["makespan"] and profs[p]["verified"] == r.verification.passed
    kept = max(("density", "constant"), key=lambda p: (profs[p]["harvested"], profs[p]["fruit_per_hour"]))
    assert profs["kept"] == kept == res.info["profile"] and res.verification.passed
    assert res.plan.metrics["makespan"] == alone[kept].plan.metrics["makespan"]
    assert len(res.info["speed_curve"]) == sum(len(r.info["speed_curve"]) for r in alone.values())
    assert {c["profile"] for c in res.info["speed_curve"]} == {"density", "constant"}
    assert res.info["options"]["profile"] == "auto" and res.timings["planning"] >= max(p["planning"] for p in
                                                                                        (profs["density"], profs["constant"]))
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=6.0, n_arms=3, density=8.0, seed=2)))
    r = runner.invoke(app, ["solve", str(f), "--gantry", "continuous", "--profile", "auto", "--out", str(tmp_path / "c")])
    doc = json.loads((tmp_path / "c" / "plan.json").read_text())
    assert r.exit_code == 0 and f"profile auto {kept} kept:" in " ".join(r.output.split()), r.output
    written = doc["solver"]["row"]["profiles"]
    assert written["kept"] == kept and all({a: b for a, b in written[k].items() if a != "planning"}
                                           == {a: b for a, b in profs[k].items() if a != "planning"} for k in ("density", "constant"))
    assert doc["metrics"]["makespan"] == res.plan.metrics["makespan"]
    with pytest.raises(OptionsError, match="level: expected null with profile auto"):
        MovingOptions(profile="auto", level=0.2)
    real = moving.speed_search

    def cut_constant(problem, options=None, *args, **kwargs):
        if options is not None and options.profile == "constant":
            raise KeyboardInterrupt
        return real(problem, options, *args, **kwargs)

    monkeypatch.setattr(moving, "speed_search", cut_constant)
    res = plan_moving(prob, MovingOptions(profile="auto"))
    assert res.plan.status == PlanStatus.INTERRUPTED and res.info["profiles"]["kept"] == "density"
    assert "constant" not in res.info["profiles"] and "constant profile's search" in res.info["interrupted"]
    assert res.plan.metrics["makespan"] == alone["density"].plan.metrics["makespan"]
