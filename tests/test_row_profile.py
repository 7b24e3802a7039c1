"""``coplan solve ROW --profile``: what the speed search on the move varies (coplan.row.moving)."""

from __future__ import annotations

import json

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
    for args, said in ((["--profile", "constant"], "--profile: the speed search's profile applies on the move"),
                       (["--gantry", "stop-and-go", "--profile", "density"], "--profile: the speed search's profile applies on the move"),
                       (["--gantry", "continuous", "--speed", "0.2", "--profile", "density"], "--profile density: --speed gives one"),
                       (["--gantry", "continuous", "--profile", "fast"], "fast")):
        r = runner.invoke(app, ["solve", str(f), *args, "--out", str(tmp_path / "x")])
        assert r.exit_code == 2 and said in " ".join(r.output.split()), (args, r.output)
    r = runner.invoke(app, ["solve", str(problems_dir / "crossing_paths.yaml"), "--profile", "constant", "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "crossing-paths is a stationary cell" in " ".join(r.output.split()), r.output
    assert not (tmp_path / "x").exists()
