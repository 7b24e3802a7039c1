"""On the move with arms close together: a fruit no direct cycle reaches, with the carriage at
rest for good, is booked with its ways to the fruit and back tucked
(:func:`coplan.row.track.tucked_route`), the last try before it would be left."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from coplan.cli import app
from coplan.generate import gantry_row, to_yaml
from coplan.plan import EventKind, load_plan
from coplan.planners.coordinated.routing import FOLD
from coplan.problem import parse_problem
from coplan.row.booking import Booker
from coplan.row.track import Leg, tucked_route
from coplan.verify import verify


def _rest(q) -> np.ndarray:
    return np.array([np.asarray(q, float), np.zeros(2), np.zeros(2)])


def test_a_tucked_route_folds_turns_and_opens_at_rest_between_within_the_limits():
    arm = parse_problem(to_yaml(gantry_row(length=4.0, n_arms=3, seed=0))).arms[0]
    q_a, q_b = np.array([0.77, 1.08]), np.array([-0.66, -2.63])  # a fruit high to the side -> the bin below
    for side in (1, -1):
        r = tucked_route(arm, _rest(q_a), _rest(q_b), side)
        assert r.duration == sum(leg.duration for leg in r.legs) and len(r.legs) == 3
        assert r.duration > Leg(arm, _rest(q_a), _rest(q_b)).duration  # (slower than the direct move)
        dt = 1e-3
        t = np.arange(0.0, r.duration + 5 * dt, dt)
        q = r.sample(t)
        assert np.allclose(q[0], q_a, atol=1e-12) and np.allclose(q[-1], q_b, atol=1e-12)
        # folded while the shoulder turns: the middle leg keeps the elbow at the fold
        mid = q[(t > r.starts[1]) & (t < r.starts[2])]
        assert np.allclose(mid[:, 1], side * FOLD, atol=1e-9) and np.all(np.diff(np.sign(np.diff(mid[:, 0]))) == 0)
        # continuous, within the joint limits and the velocity limit (the legs at rest where they meet)
        lim = arm.limits
        assert np.all(q >= lim[:, 0] - 1e-9) and np.all(q <= lim[:, 1] + 1e-9)
        v = np.abs(np.diff(q, axis=0)) / dt
        assert np.all(v <= np.asarray(arm.max_velocity) * (1 + 1e-3))
        for s in r.starts[1:]:
            k = int(np.searchsorted(t, s))
            assert np.all(v[max(k - 2, 0):k + 2] < 0.05 * np.asarray(arm.max_velocity))


def test_a_fruit_between_close_arms_at_the_rail_s_end_is_reached_tucked(monkeypatch, tmp_path):
    # three arms 1.2 m apart, live on the move at 0.15 m/s, no noise: the offline plan's arm3
    # picks f0043 (x = 11.30 m, 1.46 m high) at 62.6 s; live, arm3 is busy while it can, and
    # the fruit is left to arm1 and arm2 with the carriage at rest at the rail's end, where
    # every direct way from a fruit that high between two bases down to the bin swings the arm
    # over its neighbour's shoulder, wherever the neighbour rests (the run harvested 42 of 43)
    row = tmp_path / "row.yaml"
    row.write_text(to_yaml(gantry_row(length=12, n_arms=3, density=3.6, spacing=1.2, seed=1)))
    tucked = []
    plan_cycle = Booker.plan_cycle

    def spy(self, i, fid, w, t_from, tuck=False):
        cyc = plan_cycle(self, i, fid, w, t_from, tuck)
        if tuck:
            assert t_from >= self.cruise.duration  # (only with the carriage at rest for good)
            tucked.append((fid, cyc is not None))
        return cyc

    monkeypatch.setattr(Booker, "plan_cycle", spy)
    out = CliRunner(env={"COLUMNS": "250"}).invoke(app, ["run", str(row), "--speed", "0.15", "--sigma", "0", "--false-rate", "0",
                                                       "--duplicate-rate", "0", "-o", str(tmp_path / "live")])
    assert out.exit_code == 0, out.output
    plan = load_plan(tmp_path / "live" / "plan.json")
    assert verify(parse_problem(row.read_text()), plan).passed
    doc = json.loads((tmp_path / "live" / "run.json").read_text())
    assert doc["metrics"]["of_offline"] == 1.0 and doc["metrics"]["harvested"] == 43
    assert ("d0043", True) in tucked  # (its report's id: booked tucked, its direct tries all refused)
    # the plan and the run's summary say which fruit a tucked cycle picked
    placed = {e.fruit for e in plan.events if e.kind == EventKind.PLACE}
    assert plan.solver["row"]["tucked"] == ["f0043"] and "f0043" in placed
    assert "1 fruit picked with the arm's ways tucked round a neighbour" in " ".join(out.output.split())
    # the offline plan at 0.18 m/s takes a fruit so (the carriage at rest where the last fruit comes
    # into reach), and its summary says which (at 0.15 m/s it took two so until the rail's-end
    # give-up counted tries PATIENCE s apart, 1d685e0: its direct tries now find a cycle later)
    solved = CliRunner(env={"COLUMNS": "250"}).invoke(app, ["solve", str(row), "--gantry", "continuous", "--speed", "0.18",
                                                          "-o", str(tmp_path / "offline")])
    assert solved.exit_code == 0, solved.output
    off = load_plan(tmp_path / "offline" / "plan.json")
    got = off.solver["row"]["tucked"]
    assert got and set(got) <= {e.fruit for e in off.events if e.kind == EventKind.PLACE}
    assert f"tucked {len(got)} fruit picked with the arm's ways tucked" in " ".join(solved.output.split())
