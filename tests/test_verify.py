"""The independent verifier: it catches what it must and passes what it should."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from coplan import kinematics as kin
from coplan.verify.clearance import DEFAULT_SUBSTEPS, clearance_profile, segment_distances
from coplan.cli import app
from coplan.errors import PlanFileError
from coplan.planners.heuristic import plan_heuristic
from coplan.pipeline import ExitCode
from coplan.plan import Event, EventKind, Piece, Plan, PlannerKind, PlanStatus, load_plan, sample_pieces
from coplan.problem import Problem, load_problem, parse_problem, shipped_problems
from coplan.kinematics import SCurve, cubic_eval
from coplan.verify.verifier import FclMode, IntervalKind, Verification, ViolationKind, WarningKind, verify

RATE = 100.0

TWO_ARMS = """
name: two-arms
defaults:
  links: [1.0, 0.8]
  link_radius: 0.04
  joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]]
  max_velocity: [3.0, 4.0]
  max_acceleration: [8.0, 12.0]
  max_jerk: [80.0, 120.0]
arms:
  - {name: west, base: [-1.0, 0.0], bin: [-1.0, -0.5], home: [2.0, 0.6]}
  - {name: east, base: [1.0, 0.0], bin: [1.0, -0.5], home: [0.6, 0.6]}
fruits:
  - {id: w1, position: [-1.9, 0.9]}
  - {id: w2, position: [-1.2, 1.3]}
  - {id: e1, position: [1.8, 1.0]}
task: {pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}
"""


def shipped(name: str):
    return next(p for p in shipped_problems() if p.name == name)


@pytest.fixture(scope="module")
def two_arms() -> Problem:
    return parse_problem(TWO_ARMS, "two-arms")


def _ik(problem: Problem, arm_name: str, point, branch: int | None = None) -> np.ndarray:
    arm = problem.arm(arm_name)
    q, valid = arm.ik(np.asarray(point, float))
    b = branch if branch is not None else int(np.flatnonzero(valid)[0])
    assert valid[b]
    return q[b]


def scurve_plan(
    problem: Problem,
    jobs: dict[str, list[str]],
    offsets: dict[str, np.ndarray] | None = None,
    pick_hold: float | None = None,
    start: dict[str, float] | None = None,
) -> Plan:
    """Every arm: home -> fruit (hold) -> bin (hold) -> ... -> home with jerk-limited S-curves.

    ``offsets`` moves a fruit's pick point (fruit id -> (2,) m); ``pick_hold`` holds for that long
    at the fruit while the pick event still lasts ``pick_dwell``; ``start`` delays an arm.
    """
    offsets = offsets or {}
    task = problem.task
    timelines, events, t_end = {}, [], 0.0
    for arm in problem.arms:
        t = (start or {}).get(arm.name, 0.0)
        cur = np.asarray(arm.home, float)
        pieces: list[Piece] = []
        q_bin = _ik(problem, arm.name, arm.bin)

        def move(t, a, b):
            s = SCurve.between(a, b, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
            pieces.append(Piece(t, t + s.duration, s.eval))
            return t + s.duration

        def hold(t, q, d):
            pieces.append(Piece(t, t + d, lambda x, q=np.array(q): np.tile(q, (np.size(x), 1))))
            return t + d

        for fid in jobs.get(arm.name, []):
            target = np.add(problem.fruit(fid).position, offsets.get(fid, 0.0))
            qf = _ik(problem, arm.name, target)
            t = move(t, cur, qf)
            events.append(Event(arm.name, fid, EventKind.PICK, t, t + task.pick_dwell))
            t = hold(t, qf, task.pick_dwell if pick_hold is None else pick_hold)
            t = move(t, qf, q_bin)
            events.append(Event(arm.name, fid, EventKind.PLACE, t, t + task.place_dwell))
            t = hold(t, q_bin, task.place_dwell)
            cur = q_bin
        t = move(t, cur, arm.home)
        timelines[arm.name] = pieces
        t_end = max(t_end, t)
    times = np.arange(int(math.ceil(t_end * RATE)) + 2) / RATE
    q = {a.name: sample_pieces(timelines[a.name], a.home, times) for a in problem.arms}
    return Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times, q, sorted(events, key=lambda e: e.t_start),
                {a: list(v) for a, v in jobs.items()}, [])


def kinds(ver: Verification) -> set[ViolationKind]:
    return {v.kind for v in ver.violations}


# ---------------------------------------------------------------------------- passes
def test_hand_built_safe_plan_passes(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1", "w2"], "east": ["e1"]})
    ver = verify(two_arms, plan)
    assert ver.passed, ver.violations[:5]
    assert ver.complete and ver.unharvested == []
    assert ver.fcl is not None and ver.fcl.agree and ver.fcl.queries > 0
    assert ver.certified_clearance >= two_arms.task.clearance
    assert ver.certified_clearance <= ver.min_clearance
    s = ver.summary()
    for key in ("passed", "collision_count", "min_clearance", "certified_clearance", "violation_count", "violation_kinds", "pairs", "peaks"):
        assert key in s
    assert s["pairs"].keys() == {"west-east"}
    # the S-curves ride their limits: peaks are close to, never above, 1
    for arm in ("west", "east"):
        assert 0.9 < s["peaks"][arm]["jerk"] <= 1.0 + 1e-6
        assert s["peaks"][arm]["velocity"] <= 1.0 + 1e-6
        assert s["peaks"][arm]["acceleration"] <= 1.0 + 1e-6


def test_scurve_moves_of_every_shape_pass_their_limits():
    """Third differences of jerk-limited S-curves (incl. short, triangular ones) never false-alarm."""
    problem = load_problem(shipped("single_arm.yaml"))
    arm = problem.arms[0]
    rng = np.random.default_rng(7)
    pieces, t, cur = [], 0.137, np.asarray(arm.home, float)
    for _ in range(40):
        nxt = np.clip(cur + rng.normal(0, 1, 2) * rng.choice([0.002, 0.05, 0.4, 1.5]), -2.9, 2.9)
        s = SCurve.between(cur, nxt, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
        pieces.append(Piece(t, t + s.duration, s.eval))
        t += s.duration + rng.choice([0.0, 0.013, 0.2])
        cur = nxt
    times = np.arange(int(t * RATE) + 5) / RATE
    plan = Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times,
                {arm.name: sample_pieces(pieces, arm.home, times)}, [], {}, [])
    ver = verify(problem, plan)
    assert not kinds(ver) & {ViolationKind.VELOCITY, ViolationKind.ACCELERATION, ViolationKind.JERK}
    assert ver.peaks[arm.name]["jerk"] > 0.95


# ---------------------------------------------------------------------------- catches
def _sweep_plan(problem: Problem, n_before: int = 5) -> tuple[Plan, int]:
    """East holds still; west's shoulder jumps across east's forearm between samples n and n+1."""
    east_q = np.array([2.6416, -0.3])  # forearm reaching left over west's base
    west_a, west_b = np.array([-0.5, 0.0]), np.array([1.6, 0.0])
    n = n_before + 1
    times = np.arange(2 * n) / RATE
    west = np.where((np.arange(2 * n) < n)[:, None], west_a, west_b)
    plan = Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times,
                {"west": west, "east": np.tile(east_q, (2 * n, 1))}, [], {}, [])
    return plan, n - 1


@pytest.mark.parametrize("substeps", [1, DEFAULT_SUBSTEPS])
def test_collision_planted_between_two_samples_is_caught(substeps):
    problem = parse_problem(TWO_ARMS.replace("home: [2.0, 0.6]", "home: [-0.5, 0.0]").replace("home: [0.6, 0.6]", "home: [2.6416, -0.3]"))
    plan, n = _sweep_plan(problem)
    # at the plan's own samples the arms are well clear ...
    t100, d100 = clearance_profile(problem, plan, substeps=1)
    assert d100[(0, 1)].min() > 0.4
    # ... but west's forearm sweeps through east's between samples n and n + 1
    ver = verify(problem, plan, substeps=substeps)
    assert not ver.passed
    hits = [c for c in ver.intervals if c.kind == IntervalKind.COLLISION]
    assert hits, ver.violations
    assert all(plan.time[n] < c.t_worst < plan.time[n + 1] for c in hits)
    assert ver.certified_clearance < 0
    assert ViolationKind.COLLISION in kinds(ver)
    assert ver.fcl.agree  # FCL confirms the overlap at the worst instant


def test_limit_violated_between_knots_is_caught():
    """A planner's 10 Hz knots move within limits, the 100 Hz samples between them do not."""
    problem = load_problem(shipped("single_arm.yaml"))
    arm = problem.arms[0]
    times = np.arange(101) / RATE
    q1 = arm.home[0] + 0.5 * times + 0.15 * np.sin(10 * np.pi * times)  # = home + 0.5 t at every knot
    q = np.stack([q1, np.full_like(times, arm.home[1])], axis=1)
    knots = q[::10, 0]
    assert np.all(np.abs(np.diff(knots)) / 0.1 <= arm.max_velocity[0])  # knot-to-knot velocity is fine
    plan = Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times, {arm.name: q}, [], {}, [])
    ver = verify(problem, plan)
    vel = [v for v in ver.violations if v.kind == ViolationKind.VELOCITY]
    assert vel and all(v.joint == 0 and v.arms == (arm.name,) for v in vel)
    worst = max(vel, key=lambda v: v.amount)
    assert worst.value == pytest.approx(0.5 + 1.5 * np.pi, rel=0.02)
    assert not np.isclose((worst.t / 0.1) % 1.0, 0.0, atol=0.05)  # strictly between knots


def test_acceleration_step_is_a_jerk_violation_only():
    """The course's cubic starts with an acceleration step: velocity/acceleration fine, jerk not."""
    problem = load_problem(shipped("single_arm.yaml"))
    arm = problem.arms[0]
    q0, q1 = np.asarray(arm.home), np.asarray(arm.home) + [0.8, -0.5]
    T = 1.0
    times = np.arange(int(T * RATE) + 21) / RATE
    q = cubic_eval(q0, q1, T, times - 0.1)
    plan = Plan(problem.name, PlannerKind.HEURISTIC, PlanStatus.UNVERIFIED, times, {arm.name: q}, [], {}, [])
    ver = verify(problem, plan)
    assert ViolationKind.JERK in kinds(ver)
    assert not kinds(ver) & {ViolationKind.VELOCITY, ViolationKind.ACCELERATION}
    starts = sorted(v.t for v in ver.violations if v.kind == ViolationKind.JERK)
    assert starts[0] == pytest.approx(0.1, abs=0.03) and starts[-1] == pytest.approx(1.1, abs=0.03)


def test_fruit_missed_by_6mm_is_caught_and_4mm_is_not(two_arms):
    miss = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}, offsets={"w1": np.array([0.006, 0.0])})
    ver = verify(two_arms, miss)
    missed = [v for v in ver.violations if v.kind == ViolationKind.PICK_MISSED]
    assert len(missed) == 1 and missed[0].fruit == "w1" and missed[0].arms == ("west",)
    assert missed[0].value == pytest.approx(0.006, abs=1e-5)
    near = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}, offsets={"w1": np.array([0.0, -0.004])})
    assert verify(two_arms, near).passed


def test_a_pick_or_place_the_tip_never_reaches_harvests_nothing(two_arms):
    """A fruit counts as harvested only where a pick and a place of it are on target: a pick 6 mm
    off, or a place 1 cm above a lowered bin, leaves its fruit unharvested beside the violation (a
    plan checked against a fruit moved 2 cm was called complete, every fruit harvested). A second,
    bogus pick of a fruit another arm harvested does not undo that harvest."""
    miss = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}, offsets={"w1": np.array([0.006, 0.0])})
    ver = verify(two_arms, miss)
    assert kinds(ver) == {ViolationKind.PICK_MISSED}
    assert ver.unharvested == ["w1", "w2"] and not ver.complete and ver.measured["harvested"] == 1
    assert ver.summary()["unharvested"] == ["w1", "w2"]
    lowered = parse_problem(TWO_ARMS.replace("bin: [1.0, -0.5]", "bin: [1.0, -0.51]"))
    ver = verify(lowered, scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}))
    assert kinds(ver) == {ViolationKind.PLACE_MISSED} and ver.unharvested == ["w2", "e1"]
    plan = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]})
    pick = next(e for e in plan.events if e.fruit == "w1" and e.kind == EventKind.PICK)
    plan.events.append(Event("east", "w1", EventKind.PICK, pick.t_start, pick.t_end))
    ver = verify(two_arms, plan)
    assert ViolationKind.PICK_MISSED in kinds(ver) and ver.unharvested == ["w2"]


def test_dwell_cut_short_is_caught(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}, pick_hold=0.2)
    ver = verify(two_arms, plan)
    short = [v for v in ver.violations if v.kind == ViolationKind.PICK_DWELL]
    assert sorted(v.fruit for v in short) == ["e1", "w1"]
    # S-curves leave gently: the first few ms of the departure are still slower than 5 mm/s
    assert all(v.value == pytest.approx(0.2, abs=0.02) and v.limit == 0.3 for v in short)


def test_event_shorter_than_the_dwell_is_caught(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]})
    e = plan.events[-1]
    assert e.kind == EventKind.PLACE
    plan.events[-1] = Event(e.arm, e.fruit, e.kind, e.t_start, e.t_start + 0.1)
    ver = verify(two_arms, plan)
    assert [v.kind for v in ver.violations] == [ViolationKind.PLACE_DWELL]


def test_place_away_from_the_bin_is_caught(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]})
    moved = parse_problem(TWO_ARMS.replace("bin: [1.0, -0.5]", "bin: [1.0, -0.51]"))  # the bin is 1 cm lower
    ver = verify(moved, plan)
    assert [(v.kind, v.arms, v.fruit) for v in ver.violations] == [(ViolationKind.PLACE_MISSED, ("east",), "e1")]
    assert ver.violations[0].value == pytest.approx(0.01, abs=1e-4)


def test_bookkeeping_violations(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]})
    pick = next(e for e in plan.events if e.fruit == "w1" and e.kind == EventKind.PICK)
    assert not two_arms.reach_matrix()[1, 0]  # east cannot reach w1
    # east also "picks" w1 (a duplicate it cannot reach, and holds it: never placed), and an unknown fruit
    plan.events.append(Event("east", "w1", EventKind.PICK, pick.t_start, pick.t_end))
    plan.events.append(Event("east", "nope", EventKind.PICK, 0.0, 0.3))
    ver = verify(two_arms, plan)
    k = kinds(ver)
    assert {ViolationKind.DUPLICATE_PICK, ViolationKind.UNKNOWN_FRUIT, ViolationKind.SEQUENCE,
            ViolationKind.UNREACHABLE_PICK, ViolationKind.PICK_MISSED} <= k
    dup = next(v for v in ver.violations if v.kind == ViolationKind.DUPLICATE_PICK)
    assert dup.arms == ("east", "west") and dup.fruit == "w1"


def test_unharvested_fruit_is_reported_not_failed(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]})
    ver = verify(two_arms, plan)
    assert ver.passed and not ver.complete
    assert ver.unharvested == ["w2"]
    assert any(w.kind == WarningKind.NOT_HARVESTED for w in ver.warnings)
    assert ver.summary()["unharvested"] == ["w2"]


def test_joint_limit_and_singular_pose():
    problem = load_problem(shipped("single_arm.yaml"))
    arm = problem.arms[0]
    times = np.arange(50) / RATE
    q = np.tile([arm.home[0], 0.0], (50, 1))  # stretched out: singular
    q[20:30, 0] = 3.2  # beyond 3.1416 (a jump: limits too, we only look at the joint limit)
    plan = Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times, {arm.name: q}, [], {}, [])
    ver = verify(problem, plan)
    jl = [v for v in ver.violations if v.kind == ViolationKind.JOINT_LIMIT]
    assert len(jl) == 1 and jl[0].t_start == pytest.approx(0.2) and jl[0].t_end == pytest.approx(0.29)
    assert jl[0].amount == pytest.approx(3.2 - 3.1416)
    assert any(w.kind == WarningKind.SINGULAR for w in ver.warnings)


def test_plan_for_other_arms_is_bad_input(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1"]})
    plan.q["north"] = plan.q.pop("east")
    with pytest.raises(PlanFileError, match="north"):
        verify(two_arms, plan)


def test_fcl_disagreement_fails_the_plan(two_arms, monkeypatch):
    import coplan.verify.fclcheck as fc

    real = fc.arm_link_distances
    monkeypatch.setattr(fc, "arm_link_distances", lambda pa, pb: real(pa, pb) + 1e-4)
    ver = verify(two_arms, scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}))
    assert not ver.passed and ViolationKind.CROSS_CHECK in kinds(ver)
    assert not ver.fcl.agree and ver.summary()["fcl_agree"] is False


# ---------------------------------------------------------------------------- shipped problems
def test_crossing_paths_heuristic_plan_has_collision_intervals():
    problem = load_problem(shipped("crossing_paths.yaml"))
    plan = plan_heuristic(problem)
    ver = verify(problem, plan)
    s = ver.summary()
    assert not ver.passed and s["collision_count"] >= 2
    assert "collision" in s["violation_kinds"]
    assert s["min_clearance"] < 0 and s["certified_clearance"] <= s["min_clearance"]
    for c in ver.collisions:
        assert c.arms == ("left", "right")
        assert c.t_start <= c.t_worst <= c.t_end
        assert 0 < c.penetration <= 0.08 + 1e-9
    assert ver.fcl.agree and ver.fcl.samples >= len(ver.collisions)
    # the intervals are real: the capsules overlap at each worst instant
    for c in ver.collisions:
        q = plan.sample([c.t_worst])
        pts = {a.name: kin.fk_points(q[a.name][0], a.links, a.base) for a in problem.arms}
        d = min(
            float(segment_distances(pts["left"][i], pts["left"][i + 1], pts["right"][j], pts["right"][j + 1]))
            for i in (0, 1) for j in (0, 1)
        )
        assert d - 0.08 == pytest.approx(c.least_distance, abs=1e-9)
    # a notebook cell shows the verdict, not every interval and finding (it was 42 KB on a row)
    shown = repr(ver)
    assert len(shown) < 300 and "passed=False" in shown and "'collision'" in shown and "margin -" in shown, shown


def test_greenhouse_heuristic_plan_verdict(tmp_path):
    problem = load_problem(shipped("greenhouse_row.yaml"))
    plan = plan_heuristic(problem)
    ver = verify(problem, plan)
    s = ver.summary()
    assert s["collision_count"] == 0 and s["certified_clearance"] >= problem.task.clearance
    assert s["violation_kinds"] == ["jerk"]  # cubic endpoints: acceleration steps, by design
    assert set(s["pairs"]) == {"left-center", "center-right"}
    path = ver.save(tmp_path)
    doc = json.loads(path.read_text())
    assert path.name == "verification.json" and doc["summary"]["violation_count"] == s["violation_count"]
    assert doc["fcl"]["agree"] is True
    plan.verification = s
    json.dumps(plan.to_dict(), allow_nan=False)  # the summary stored in plan.json is strict JSON


def test_certified_margin_is_the_least_distance_to_a_micrometre():
    """A clear plan's certified clearance is a bound on a 100 kHz sampling and within a
    micrometre of it; without the margin's refinement (``margin_tol`` 1 m) the Lipschitz bound
    at 1 kHz is looser by more than 0.1 mm on the same plan."""
    from coplan.planners.coordinated import plan_coordinated
    from coplan.verify.clearance import arm_motions, certify_pair

    problem = load_problem(shipped("crossing_paths.yaml"))
    plan = plan_coordinated(problem).plan
    ver = verify(problem, plan, fcl=FclMode.OFF)
    assert ver.passed
    _, dense = clearance_profile(problem, plan, substeps=1000)
    least = float(dense[(0, 1)].min())
    assert least - 1e-6 <= ver.certified_clearance <= least + 1e-12
    loose = certify_pair(arm_motions(problem, plan), 0, 1, plan, problem.task.clearance, margin_tol=1.0)
    assert loose.certified < ver.certified_clearance - 1e-4


def test_certificate_bounds_a_much_denser_sampling():
    problem = load_problem(shipped("crossing_paths.yaml"))
    plan = plan_heuristic(problem)
    ver = verify(problem, plan, fcl=FclMode.OFF)
    _, dense = clearance_profile(problem, plan, substeps=200)
    assert ver.certified_clearance <= dense[(0, 1)].min() + 1e-12
    assert ver.min_clearance >= dense[(0, 1)].min() - 1e-12


@pytest.mark.parametrize("name", ["crossing_paths.yaml", "greenhouse_row.yaml"])
def test_adaptive_sampling_matches_uniform_1khz(name):
    """The verifier densifies only where it matters; its figures equal uniform 1 kHz sampling."""
    problem = load_problem(shipped(name))
    plan = plan_heuristic(problem)
    ver = verify(problem, plan, fcl=FclMode.OFF)
    t, prof = clearance_profile(problem, plan)  # uniform, substeps=10
    assert t.size == (plan.time.size - 1) * DEFAULT_SUBSTEPS + 1
    for pc, ((i, j), d) in zip(ver.pairs, prof.items()):
        assert pc.arms == (problem.arms[i].name, problem.arms[j].name)
        # the least distance is uniform sampling's, or a little below it where the margin's
        # certificate refined further (between 1 kHz samples)
        assert d.min() - 1e-5 <= pc.min_clearance <= d.min() + 1e-12
        assert pc.certified <= pc.min_clearance
        assert pc.samples < t.size  # fewer evaluations than uniform sampling
        n_runs = sum(1 for k in range(1, d.size) if d[k] < 0 <= d[k - 1]) + int(d[0] < 0)
        assert sum(c.arms == pc.arms for c in ver.collisions) == n_runs


@pytest.mark.parametrize("chunk", [1, 7, 10_000])
def test_the_profile_in_pieces_is_the_whole_profile(chunk):
    """clearance_chunks (a long plan's profile, reduced piece by piece) yields the uniform
    profile's instants and distances, in order, whatever the piece size."""
    from coplan.verify.clearance import clearance_chunks

    problem = load_problem(shipped("crossing_paths.yaml"))
    plan = plan_heuristic(problem)
    t, prof = clearance_profile(problem, plan)
    pieces = list(clearance_chunks(problem, plan, chunk=chunk))
    assert len(pieces) == -(-(plan.time.size - 1) // chunk)
    tc = np.concatenate([tt for tt, _ in pieces])
    assert tc.size == (plan.time.size - 1) * DEFAULT_SUBSTEPS + 1 and tc[-1] == plan.time[-1]
    np.testing.assert_array_equal(tc, t)
    np.testing.assert_array_equal(np.concatenate([d[(0, 1)] for _, d in pieces]), prof[(0, 1)])
    # the whole profile at 1 kHz from samples 10 ms apart: the instants are the plan's knots
    # and nine between each two
    np.testing.assert_allclose(t[::DEFAULT_SUBSTEPS], plan.time, atol=1e-12)


def test_single_arm_has_no_pairs_and_saves_clean_json(tmp_path):
    problem = load_problem(shipped("single_arm.yaml"))
    plan = scurve_plan(problem, {"arm": ["pick"]})
    ver = verify(problem, plan)
    assert ver.passed and ver.complete and ver.pairs == []
    assert math.isinf(ver.summary()["min_clearance"])
    doc = json.loads(ver.save(tmp_path / "v.json").read_text())
    assert doc["summary"]["min_clearance"] is None


def test_any_arm_count_checks_every_neighbouring_pair():
    """Four arms 1 m apart: every pair can touch (not only adjacent ones) and all are checked."""
    arms = "\n".join(f"  - {{name: a{k}, base: [{k}.0, 0.0], bin: [{k}.0, -0.5], home: [1.5708, 0.0]}}" for k in range(4))
    head = TWO_ARMS.split("arms:")[0]
    text = f"{head}arms:\n{arms}\nfruits: []\ntask: {{pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}}\n"
    problem = parse_problem(text)
    assert len(problem.neighbour_pairs()) == 6
    times = np.arange(3) / RATE
    plan = Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times,
                {a.name: np.tile(a.home, (3, 1)) for a in problem.arms}, [], {}, [])
    ver = verify(problem, plan)
    assert set(ver.summary()["pairs"]) == {f"a{i}-a{j}" for i in range(4) for j in range(i + 1, 4)}
    assert ver.passed and ver.min_clearance == pytest.approx(1.0 - 0.08)
    assert any(w.kind == WarningKind.SINGULAR for w in ver.warnings)  # stretched straight up


def test_one_sample_plan(two_arms):
    plan = Plan(two_arms.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, np.zeros(1),
                {a.name: np.array([a.home]) for a in two_arms.arms}, [], {}, [])
    ver = verify(two_arms, plan)
    assert ver.passed and ver.certified_clearance == ver.min_clearance > 0.05
    assert ver.unharvested == ["w1", "w2", "e1"]


# ---------------------------------------------------------------------------- command line
def _write_plan(tmp_path, problem: Problem, plan: Plan) -> str:
    return str(plan.save(tmp_path, "plan")["json"])


def test_cli_verify_exit_codes(tmp_path, two_arms):
    runner = CliRunner()
    prob = tmp_path / "two.yaml"
    prob.write_text(TWO_ARMS)
    good = _write_plan(tmp_path / "good", two_arms, scurve_plan(two_arms, {"west": ["w1", "w2"], "east": ["e1"]}))
    res = runner.invoke(app, ["verify", str(prob), good])
    assert res.exit_code == ExitCode.OK, res.output
    assert "passed" in res.output
    partial = _write_plan(tmp_path / "partial", two_arms, scurve_plan(two_arms, {"west": ["w1"], "east": ["e1"]}))
    assert runner.invoke(app, ["verify", str(prob), partial]).exit_code == ExitCode.PARTIAL
    bad = _write_plan(tmp_path / "bad", two_arms, scurve_plan(two_arms, {"west": ["w1", "w2"], "east": ["e1"]}, pick_hold=0.1))
    out = tmp_path / "report" / "verification.json"
    res = runner.invoke(app, ["verify", str(prob), bad, "--out", str(out)])
    assert res.exit_code == ExitCode.UNSAFE
    assert "pick_dwell" in res.output and out.is_file()
    res = runner.invoke(app, ["verify", str(prob), bad, "--json"])
    assert res.exit_code == ExitCode.UNSAFE
    doc = json.loads(res.stdout)
    assert doc["summary"]["passed"] is False and doc["violations"]
    junk = tmp_path / "junk.json"
    junk.write_text("{not json")
    assert runner.invoke(app, ["verify", str(prob), str(junk)]).exit_code == ExitCode.BAD_INPUT
    assert runner.invoke(app, ["verify", str(tmp_path / "missing.yaml"), good]).exit_code == ExitCode.BAD_INPUT
    # a plan of another problem (other arm names) is bad input too
    other = load_problem(shipped("single_arm.yaml"))
    other_plan = _write_plan(tmp_path / "other", other, scurve_plan(other, {"arm": ["pick"]}))
    assert runner.invoke(app, ["verify", str(prob), other_plan]).exit_code == ExitCode.BAD_INPUT


def test_cli_verify_reads_back_a_saved_heuristic_plan(tmp_path):
    path = shipped("crossing_paths.yaml")
    problem = load_problem(path)
    plan_file = _write_plan(tmp_path, problem, plan_heuristic(problem))
    ver = verify(problem, load_plan(plan_file))
    assert ver.summary()["collision_count"] == verify(problem, plan_heuristic(problem)).summary()["collision_count"]
    res = CliRunner().invoke(app, ["verify", str(path), plan_file])
    assert res.exit_code == ExitCode.UNSAFE
    assert "collision" in res.output
    # (its peaks read "jerk 13.14 of the limits" beside violations saying the jerk is unbounded)
    peaks = [ln for ln in res.output.splitlines() if ln.strip().startswith("peaks")]
    assert len(peaks) == 2 and all("jerk unbounded (its acceleration steps)" in ln for ln in peaks), peaks


def _glide(plan: Plan, arm: str, dq, seconds: float = 3.0, at_start: bool = False) -> Plan:
    """``plan`` with a smooth quintic glide of ``arm`` by ``dq`` after its end (or, ``at_start``,
    from home + dq into its start, the events later by as much); the other arms rest meanwhile."""
    n = int(round(seconds / plan.dt))
    s = np.arange(1, n + 1) / n
    e = (s**3 * (10 - 15 * s + 6 * s * s))[:, None]
    q = {}
    for name, qa in plan.q.items():
        qa = np.asarray(qa, float)
        if at_start:
            pre = np.repeat(qa[:1], n, axis=0) + (np.asarray(dq) * (1 - np.r_[0.0, e[:-1, 0]])[:, None] if name == arm else 0.0)
            q[name] = np.vstack([pre, qa])
        else:
            post = np.repeat(qa[-1:], n, axis=0) + (np.asarray(dq) * e if name == arm else 0.0)
            q[name] = np.vstack([qa, post])
    time = np.arange(len(next(iter(q.values())))) * plan.dt
    shift = seconds if at_start else 0.0
    events = [Event(ev.arm, ev.fruit, ev.kind, ev.t_start + shift, ev.t_end + shift) for ev in plan.events]
    return Plan(plan.problem, plan.planner, PlanStatus.UNVERIFIED, time, q, events, plan.allocation, plan.unreachable)


def test_an_arm_that_does_not_start_at_home_fails_and_one_that_does_not_end_there_is_warned_of(tmp_path):
    """The problem's ``home`` is the arms' pose at start and end. A plan that starts 0.3 rad off
    home (an unplanned jump) was passed: now a violation. One that glides 0.5 rad off home after
    its last place leaves the arm out: a warning with the pose (the motion itself is verified;
    coplan's coordinated planner leaves an arm parked where locked neighbours block its home)."""
    from coplan.pipeline import solve

    prob = load_problem(shipped("single_arm.yaml"))
    plan = solve(prob, planner="coordinated").plan
    ok = verify(prob, plan)
    assert ok.passed and not [w for w in ok.warnings if w.kind == WarningKind.NOT_HOME]
    arm = prob.arms[0].name
    starts = verify(prob, _glide(plan, arm, [0.0, 0.3], at_start=True))
    assert not starts.passed and kinds(starts) == {ViolationKind.HOME}
    (v,) = starts.violations
    assert v.arms == (arm,) and v.t == 0.0 and v.amount == pytest.approx(0.3, abs=1e-9) and "starts at" in v.message
    ends = verify(prob, _glide(plan, arm, [-0.5, 0.0]))
    assert ends.passed
    (w,) = [w for w in ends.warnings if w.kind == WarningKind.NOT_HOME]
    assert w.arms == (arm,) and w.t == pytest.approx(plan.duration + 3.0) and "0.5000 rad from its home" in w.message
    assert "in its neighbours' way" in w.message
    # a micro-radian's rounding is nothing; the CLI fails a plan that starts off home with exit 6
    assert verify(prob, _glide(plan, arm, [5e-7, 0.0], at_start=True)).passed
    path = tmp_path / "starts_away.json"
    _glide(plan, arm, [0.0, 0.3], at_start=True).save(path)
    res = CliRunner().invoke(app, ["verify", str(shipped("single_arm.yaml")), str(path)])
    assert res.exit_code == ExitCode.UNSAFE, res.output
    assert "starts at" in " ".join(res.output.split())


def test_the_warning_names_a_declared_fault_that_left_the_arm_out():
    from coplan.pipeline import solve

    prob = load_problem(shipped("crossing_paths.yaml"))
    base = solve(prob, planner="coordinated").plan
    arm = prob.arms[0].name
    away = _glide(base, arm, [0.0, 0.2])
    away.solver = {"live": {"faults": {"arm_stop": {"arm": arm, "t": float(base.duration)}}}}
    ver = verify(prob, away)
    assert ver.passed
    (w,) = [w for w in ver.warnings if w.kind == WarningKind.NOT_HOME]
    assert w.arms == (arm,) and "the plan declares it stopped by a fault at t = " in w.message
    away.solver = {"live": {"faults": {"arm_stop": {"arm": arm, "t": "soon"}}}}  # not a declaration
    (w,) = [w for w in verify(prob, away).warnings if w.kind == WarningKind.NOT_HOME]
    assert "in its neighbours' way" in w.message


def test_verify_json_carries_the_exit_code_and_verdict(tmp_path):
    """(``solve --json`` did, ``verify --json`` did not: a script reading the document alone could
    not tell 'infeasible' from 'passed'.)"""
    from coplan.pipeline import solve

    path = shipped("single_arm.yaml")
    prob = load_problem(path)
    plan = solve(prob, planner="coordinated").plan
    good, bad = tmp_path / "good.json", tmp_path / "bad.json"
    plan.save(good)
    _glide(plan, prob.arms[0].name, [0.0, 0.3], at_start=True).save(bad)
    for f, code, verdict in ((good, 0, "ok"), (bad, 6, "unsafe")):
        res = CliRunner().invoke(app, ["verify", str(path), str(f), "--json"])
        doc = json.loads(res.stdout)
        assert res.exit_code == code and (doc["exit_code"], doc["verdict"]) == (code, verdict), res.output


def test_verify_takes_paths_and_says_what_it_expects(tmp_path):
    """(verify('problem.yaml', plan) died in an AttributeError: 'str' object has no attribute
    'arms'; options={'fcl': 'full'} in a TypeError from dataclasses.replace.)"""
    path = shipped("crossing_paths.yaml")
    problem = load_problem(path)
    plan = plan_heuristic(problem)
    plan.save(tmp_path)
    by_path = verify(str(path), tmp_path / "plan.json", options={"fcl": "off"})
    by_object = verify(problem, plan, fcl=FclMode.OFF)
    assert by_path.summary()["violation_kinds"] == by_object.summary()["violation_kinds"] == ["collision", "jerk"]
    assert by_path.fcl is None and by_path.certified_clearance == pytest.approx(by_object.certified_clearance, abs=1e-6)
    with pytest.raises(TypeError, match="problem: expected a Problem, the path of a problem file or a mapping, found list"):
        verify([], plan)
    with pytest.raises(TypeError, match="plan: expected a Plan, a SolveResult or the path of a plan file"):
        verify(problem, plan.q)
    with pytest.raises(TypeError, match="expected options among .*found 'fcll'"):
        verify(problem, plan, fcll="off")
    with pytest.raises(TypeError, match="options: expected VerifyOptions, a mapping of its fields or None, found str"):
        verify(problem, plan, "full")


# ---------------------------------------------------------------------------- grids finer than 100 Hz
def _scurves_at(problem: Problem, rate: float) -> Plan:
    arm = problem.arms[0]
    rng = np.random.default_rng(3)
    pieces, t, cur = [], 0.05, np.asarray(arm.home, float)
    for _ in range(6):
        nxt = np.clip(cur + rng.normal(0, 0.6, 2), -2.9, 2.9)
        s = SCurve.between(cur, nxt, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
        pieces.append(Piece(t, t + s.duration, s.eval))
        t += s.duration + 0.1
        cur = nxt
    pieces.append(Piece(t, t + 1.0, SCurve.between(cur, np.asarray(arm.home, float), arm.max_velocity, arm.max_acceleration,
                                                   arm.max_jerk).eval))
    times = np.arange(int((t + 1.2) * rate) + 1) / rate
    return Plan(problem.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, times,
                {arm.name: sample_pieces(pieces, arm.home, times)}, [], {}, [])


def test_a_finer_grid_earns_no_larger_rounding_allowance():
    """At 1 kHz the 1e-7 rad rounding allowance of the 100 Hz grid would be 400 rad/s^3 of
    jerk: a plan stored at full precision is checked to its floating point, one rounded to
    1e-7 rad is reported as not checkable, and a wiggle over the acceleration limit fails."""
    problem = load_problem(shipped("single_arm.yaml"))
    arm = problem.arms[0]
    plan = _scurves_at(problem, 1000.0)
    ver = verify(problem, plan)
    assert not kinds(ver) & {ViolationKind.VELOCITY, ViolationKind.ACCELERATION, ViolationKind.JERK}, ver.violations[:3]
    # 1.5 x the acceleration limit of joint 1 over 0.2 s, a 2 ms wiggle: caught at full precision
    w = 2000.0
    wiggle = 1.5 * arm.max_acceleration[0] / w**2 * np.sin(w * plan.time) * ((plan.time > 0.5) & (plan.time < 0.7))
    q = plan.q[arm.name].copy()
    q[:, 0] += wiggle
    bad = verify(problem, Plan(plan.problem, plan.planner, plan.status, plan.time, {arm.name: q}, [], {}, []))
    acc = [v for v in bad.violations if v.kind == ViolationKind.ACCELERATION]
    assert acc and all(0.45 < v.t < 0.75 for v in acc) and max(v.value for v in acc) > 1.3 * arm.max_acceleration[0]
    # the clean plan rounded as plan.json rounds: the limits it cannot resolve fail, said so
    rounded = Plan(plan.problem, plan.planner, plan.status, plan.time, {arm.name: np.round(plan.q[arm.name], 7)}, [], {}, [])
    v2 = verify(problem, rounded)
    unresolved = [v for v in v2.violations if "not checkable" in v.message]
    assert not v2.passed and {v.kind for v in unresolved} == {ViolationKind.JERK}  # (acceleration: 0.2 rad/s^2, 2.5 %)
    assert all("1000 Hz" in v.message and "100 Hz grid" in v.message for v in unresolved)
    # the 100 Hz grid keeps its allowance: the same motion rounded there passes
    at100 = _scurves_at(problem, 100.0)
    at100 = Plan(at100.problem, at100.planner, at100.status, at100.time, {arm.name: np.round(at100.q[arm.name], 7)}, [], {}, [])
    assert not kinds(verify(problem, at100)) & {ViolationKind.VELOCITY, ViolationKind.ACCELERATION, ViolationKind.JERK}


def test_a_finer_grid_with_an_arm_at_rest_on_the_lattice_is_checked_and_coplan_writes_it_whole(tmp_path, two_arms):
    """An arm resting at its home (4-decimal angles: on the 1e-7 lattice) beside one that moves:
    no difference of its is over a limit, so nothing is 'not checkable'; and a plan on a 1 kHz
    grid, written by coplan (at full precision there), reads back and passes as it did."""
    plan = scurve_plan(two_arms, {"west": ["w1", "w2"]})
    west = two_arms.arm("west")
    fine_t = np.arange(int(plan.time[-1] * 1000) + 1) / 1000.0
    pieces, t, cur = [], 0.0, np.asarray(west.home, float)
    for target in (np.asarray(west.home) + [0.6, -0.4], np.asarray(west.home)):
        s = SCurve.between(cur, target, west.max_velocity, west.max_acceleration, west.max_jerk)
        pieces.append(Piece(t, t + s.duration, s.eval))
        t, cur = t + s.duration + 0.2, target
    q = {"west": sample_pieces(pieces, west.home, fine_t), "east": np.tile(np.asarray(two_arms.arm("east").home), (fine_t.size, 1))}
    fine = Plan(two_arms.name, PlannerKind.OPTIMAL, PlanStatus.UNVERIFIED, fine_t, q, [], {}, [])
    ver = verify(two_arms, fine)
    assert not [v for v in ver.violations if "not checkable" in v.message], ver.violations[:3]
    assert not kinds(ver) & {ViolationKind.VELOCITY, ViolationKind.ACCELERATION, ViolationKind.JERK}
    files = fine.save(tmp_path)
    for name in ("json", "csv"):
        back = verify(two_arms, load_plan(files[name]))
        assert not kinds(back) & {ViolationKind.VELOCITY, ViolationKind.ACCELERATION, ViolationKind.JERK}, (name, back.violations[:2])


def test_a_fruit_picked_twice_is_reported_at_its_second_pick_with_both(two_arms):
    plan = scurve_plan(two_arms, {"west": ["w1", "w2"], "east": ["e1"]})
    first = next(e for e in plan.events if e.kind == EventKind.PICK and e.fruit == "w2")
    again = Event("west", "w2", EventKind.PICK, first.t_start + 0.5, first.t_end + 0.5)
    ver = verify(two_arms, Plan(plan.problem, plan.planner, plan.status, plan.time, plan.q, plan.events + [again], {}, []))
    dup = [v for v in ver.violations if v.kind == ViolationKind.DUPLICATE_PICK]
    assert len(dup) == 1 and dup[0].t == pytest.approx(again.t_start)
    assert f"{first.t_start:.3f}" in dup[0].message and f"{again.t_start:.3f}" in dup[0].message



def test_a_missed_place_names_the_bin_not_the_fruit(greenhouse):
    """(A place with the tip 40 mm from the bin read "fruit f02 tip never within 5 mm", as if the
    fruit had been missed.)"""
    import dataclasses

    from coplan.planners.coordinated import plan_coordinated

    p = plan_coordinated(greenhouse).plan
    i, place = next((i, e) for i, e in enumerate(p.events) if e.kind == EventKind.PLACE)
    events = list(p.events)
    events[i] = dataclasses.replace(place, t_start=0.0, t_end=place.t_end - place.t_start)  # (at home then, not at the bin)
    ver = verify(greenhouse, dataclasses.replace(p, events=events))
    v = next(v for v in ver.violations if v.kind == ViolationKind.PLACE_MISSED)
    assert v.fruit == place.fruit and f"of {place.arm}'s bin (placing it)" in v.message


def test_verify_says_where_a_plan_files_own_figures_are_not_its_motions(tmp_path):
    """plan.json's metrics edited (makespan, harvested) -- the motion still passes, and coplan
    verify says the stated figures are not the motion's (it passed without a word), in the report
    and in --json (``stated_figures``); a plan as written states nothing amiss."""
    run = CliRunner()
    out = tmp_path / "p"
    assert run.invoke(app, ["solve", "crossing_paths", "--planner", "coordinated", "-o", str(out)]).exit_code == 0
    clean = run.invoke(app, ["verify", "crossing_paths", str(out / "plan.json")], env={"COLUMNS": "300"})
    assert clean.exit_code == 0 and "stated figures" not in clean.output
    doc = json.loads((out / "plan.json").read_text())
    true_span, true_n = doc["metrics"]["makespan"], doc["metrics"]["harvested"]
    doc["metrics"]["makespan"], doc["metrics"]["harvested"] = 1.0, 99
    (out / "plan.json").write_text(json.dumps(doc))
    r = run.invoke(app, ["verify", "crossing_paths", str(out / "plan.json")], env={"COLUMNS": "300"})
    assert r.exit_code == 0 and "stated figures" in r.output and "harvested 99 stated" in r.output, r.output
    j = run.invoke(app, ["verify", "crossing_paths", str(out / "plan.json"), "--json"])
    got = json.loads(j.stdout[j.stdout.index("{"):])["stated_figures"]
    assert got == {"makespan": {"stated": 1.0, "measured": pytest.approx(true_span)},
                   "harvested": {"stated": 99.0, "measured": float(true_n)}}
    # the Python verdict carries the same figures, as a warning too, and names the problem it checked
    ver = verify(load_problem(shipped("crossing_paths.yaml")), out / "plan.json")
    assert ver.passed and ver.stated_figures == got and ver.to_dict()["stated_figures"] == got
    assert [w.kind for w in ver.warnings].count(WarningKind.STATED_FIGURES) == 1
    assert "harvested 99 stated" in next(w.message for w in ver.warnings if w.kind == WarningKind.STATED_FIGURES)
    doc["metrics"]["makespan"], doc["metrics"]["harvested"] = true_span, true_n
    (out / "plan.json").write_text(json.dumps(doc))
    assert verify(load_problem(shipped("crossing_paths.yaml")), out / "plan.json").stated_figures == {}


def test_verification_names_the_problem_it_checked_a_plan_against(tmp_path):
    """A plan of another problem is verified against the problem given: the verdict names that
    problem, and a problem_name warning names the plan's."""
    text = shipped("crossing_paths.yaml").read_text()
    plan = plan_heuristic(load_problem(shipped("crossing_paths.yaml")))
    (tmp_path / "other.yaml").write_text(text.replace("name: crossing-paths", "name: elsewhere"))
    other = load_problem(tmp_path / "other.yaml")
    ver = verify(other, plan)
    assert ver.problem == "elsewhere"
    assert [w.message for w in ver.warnings if w.kind == WarningKind.PROBLEM_NAME] == \
        ["plan is for 'crossing-paths', problem is 'elsewhere'"]
