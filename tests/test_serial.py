"""coplan.serial: the serial fallback, checked the independent way.

Every schedule from :func:`serial_schedules` is replayed into a plan (``ArmSchedule.state``
on the plan grid, events from the PICK/PLACE steps) and run through :func:`coplan.verify.verify`;
the steps themselves are checked for the contract (contiguous, S-curve moves from the previous
pose, the input's picks and places unchanged, home at both ends).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from coplan import kinematics as kin
from coplan.allocate import allocate
from coplan.planners.coordinated.coordinate import coordinate
from coplan.generate import LESSON_DEFAULTS, LESSON_TASK, random_problem, to_yaml
from coplan.plan import DEFAULT_RATE, Plan, PlannerKind, PlanStatus, compute_metrics
from coplan.problem import Problem, load_problem, parse_problem
from coplan.planners.coordinated.schedule import ConflictError, StepKind, decoupled_schedules
from coplan.planners.coordinated.serial import BudgetSpent, serial_schedules
from coplan.kinematics import SCurve
from coplan.verify import verify
from layouts import IMPOSSIBLE

MARGIN = 0.015


def tight_problem(seed: int = 13, n_fruits: int = 25, spacing: float = 1.0, links=(0.8, 0.96)) -> Problem:
    """Two lesson arms ``spacing`` m apart (reach 1.76 m), ``n_fruits`` fruit reachable by both."""
    rng = np.random.default_rng(seed)
    bases = (-spacing / 2, spacing / 2)
    pts: list[tuple[float, float]] = []
    while len(pts) < n_fruits:
        x, y = round(float(rng.uniform(-1.2, 1.2)), 4), round(float(rng.uniform(0.3, 1.6)), 4)
        if all(kin.in_workspace(np.array([x, y]), links, (b, 0.0), 0.011) for b in bases):
            pts.append((x, y))
    d = {"name": f"tight-{seed}", "description": f"two arms {spacing:g} m apart, {n_fruits} shared fruit",
         "defaults": dict(LESSON_DEFAULTS, links=list(links)),
         "arms": [{"name": "a", "base": [bases[0], 0.0], "bin": [bases[0], -0.5]},
                  {"name": "b", "base": [bases[1], 0.0], "bin": [bases[1], -0.5]}],
         "fruits": [{"id": f"f{i + 1:03d}", "position": list(p)} for i, p in enumerate(pts)],
         "task": dict(LESSON_TASK)}
    return parse_problem(to_yaml(d))


def _plan(problem: Problem, alloc, schedules) -> Plan:
    t_end = max(s.end for s in schedules.values())
    times = np.arange(int(np.floor(t_end * DEFAULT_RATE)) + 2) / DEFAULT_RATE
    events = sorted((e for s in schedules.values() for e in s.events()), key=lambda e: (e.t_start, e.arm))
    plan = Plan(problem=problem.name, planner=PlannerKind.OPTIMAL, status=PlanStatus.UNVERIFIED, time=times,
                q={n: s.state(times)[0] for n, s in schedules.items()}, events=events,
                allocation={a: list(v) for a, v in alloc.assignment.items()}, unreachable=list(alloc.unreachable))
    plan.metrics = compute_metrics(plan, len(problem.reachable_ids()))
    return plan


def _check(problem: Problem, alloc, before, after):
    """The contract of serial_schedules, then the independent verifier; returns the verification."""
    assert set(after) == set(before)
    for arm in problem.arms:
        steps = after[arm.name].steps
        work = [(s.kind, s.fruit, s.q1, s.duration) for s in before[arm.name].steps if s.kind in (StepKind.PICK, StepKind.PLACE)]
        if not steps:
            assert not work
            continue
        assert steps[0].t0 == pytest.approx(0.0, abs=1e-12)
        assert np.allclose(steps[0].q0, arm.home) and np.allclose(steps[-1].q1, arm.home)
        for a, b in zip(steps[:-1], steps[1:]):
            assert b.t0 == pytest.approx(a.t1, abs=1e-9)
            assert np.allclose(a.q1, b.q0, atol=1e-12)
        for s in steps:
            if s.kind == StepKind.MOVE:  # a time-optimal S-curve from the previous pose
                ref = SCurve.between(s.q0, s.q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
                assert s.curve is not None and s.duration == pytest.approx(ref.duration, abs=1e-9)
                assert np.allclose(s.curve.eval(np.array([0.0, s.duration])), [s.q0, s.q1], atol=1e-9)
            else:
                assert s.q0 == s.q1
            if s.kind == StepKind.WAIT:
                assert s.duration >= 0.05 - 1e-9
        kept = [(s.kind, s.fruit, s.q1, s.duration) for s in steps if s.kind in (StepKind.PICK, StepKind.PLACE)]
        assert kept == work  # same fruit, same pose, same dwell, same order
    ver = verify(problem, _plan(problem, alloc, after))
    assert ver.passed, ver.summary()
    picked = {e.fruit for s in after.values() for e in s.events()}
    assert picked == {f for fs in alloc.assignment.values() for f in fs}
    return ver


def _span(schedules) -> float:
    return max((s.last_place for s in schedules.values()), default=0.0)


# --------------------------------------------------------------------------- where coordinate deadlocks
def test_coordinate_deadlocks_on_the_tight_layout():
    """The motivating case: coordinate() gives up on two arms 1 m apart sharing 25 fruit."""
    p = tight_problem()
    base = decoupled_schedules(p, allocate(p))
    try:
        coordinate(p, base, MARGIN)
    except ConflictError as e:
        assert "time budget" not in str(e)
        return
    pytest.skip("coordinate() no longer deadlocks on this layout")


def test_turns_resolve_a_layout_that_needs_the_arm_itself_to_back_off():
    # 1.15 m apart, 27 fruit: the only turn that works starts with the arm whose turn it is
    # moving to a candidate pose first (from where it stands its pick sweeps every rest pose of
    # its neighbour)
    p = tight_problem(seed=27, n_fruits=27, spacing=1.15)
    alloc = allocate(p)
    base = decoupled_schedules(p, alloc)
    assert not _check(p, alloc, base, serial_schedules(p, base, MARGIN)).unharvested


def test_serial_resolves_the_tight_layout():
    p = tight_problem()
    alloc = allocate(p)
    base = decoupled_schedules(p, alloc)
    out = serial_schedules(p, base, MARGIN)
    ver = _check(p, alloc, base, out)
    assert not ver.unharvested  # all 25 fruit
    # the arms take turns: the work is done, more slowly than by each arm alone
    assert _span(out) >= _span(base)


# --------------------------------------------------------------------------- shipped problems
@pytest.mark.parametrize("name", ["greenhouse_row", "crossing_paths", "five_arm_row", "dense_overlap", "single_arm", "locked_arms"])
def test_shipped_problems(problems_dir, name):
    if not (problems_dir / f"{name}.yaml").exists():
        pytest.skip(f"{name}.yaml is not shipped")
    p = load_problem(problems_dir / f"{name}.yaml")
    alloc = allocate(p)
    base = decoupled_schedules(p, alloc)
    out = serial_schedules(p, base, MARGIN)
    ver = _check(p, alloc, base, out)  # every allocated fruit (locked_arms: the screen leaves some out)
    assert name == "locked_arms" or not ver.unharvested
    if name in ("greenhouse_row", "single_arm"):  # no arm in another's way: nothing is delayed
        assert _span(out) == pytest.approx(_span(base), abs=1e-9)


# --------------------------------------------------------------------------- random layouts
@pytest.mark.parametrize("seed", range(6))  # (10 seeds took 40 s of a suite that must stay under 15 minutes)
def test_random_problems(seed):
    p = parse_problem(to_yaml(random_problem(seed)))
    alloc = allocate(p)
    base = decoupled_schedules(p, alloc)
    _check(p, alloc, base, serial_schedules(p, base, MARGIN))


# --------------------------------------------------------------------------- when nothing can work


def test_conflict_error_names_the_arms_when_no_rest_pose_helps():
    # f1 is 0.1 m above b's base: a's tip there is too close to b's shoulder whatever b does.
    # (An allocation may well refuse this fruit; the schedule is made by hand to force it.)
    p = parse_problem(IMPOSSIBLE)
    a = p.arms[0]
    qf, vf = a.ik(np.array([1.0, 0.1]))
    qb, vb = a.ik(np.array(a.bin))
    alloc = SimpleNamespace(assignment={"a": ("f1",), "b": ()}, fruit_q={"a": {"f1": qf[int(np.argmax(vf))]}},
                            place_q={"a": {"f1": qb[int(np.argmax(vb))]}})
    base = decoupled_schedules(p, alloc)
    with pytest.raises(ConflictError, match=r"arm 'b' .* arm 'a'") as e:
        serial_schedules(p, base, MARGIN)
    assert (e.value.arm, e.value.fruit) == ("a", "f1")  # the work that cannot be scheduled


# --------------------------------------------------------------------------- the work budget
def test_taking_turns_stops_at_its_work_budget_and_names_the_work_it_gave_up():
    """The tight layout needs about 2 million pose-pair tests: with 1000 the fallback stops at
    once; with a million it stops while looking for a turn, and names the arm and the fruit
    whose turn it was looking for; it counts what it spent either way."""
    p = tight_problem()
    base = decoupled_schedules(p, allocate(p))
    for budget in (1000, 1_000_000):
        work: dict = {}
        with pytest.raises(BudgetSpent, match="work budget") as e:
            serial_schedules(p, base, MARGIN, max_pairs=budget, work=work)
        assert budget < work["pairs"] < budget + 50_000  # stopped within one block of tests of the budget
    assert e.value.arm in ("a", "b") and e.value.fruit in {f.id for f in p.fruits}
    # with a budget it does not reach, the same schedule as with none
    full: dict = {}
    a = serial_schedules(p, base, MARGIN, work=full)
    b = serial_schedules(p, base, MARGIN, max_pairs=full["pairs"] + 1)
    assert _span(a) == _span(b)


def test_a_spent_budget_leaves_fruit_out_with_the_reason_never_hangs():
    """When coordination deadlocks (forced here by a coordination budget of one check) and
    taking turns runs out of work, taking turns leaves out the fruit it was fitting in, with the
    reason; the last resort (one arm at a time, a resting neighbour moved out of the way where
    it must) then harvests them all, and is kept because it leaves out fewer; once the
    fallback's whole budget is spent, the last resort at once -- never an endless search. The
    tight layout needs ~2 million pose-pair tests in one attempt (a quarter of the budget)."""
    import itertools

    from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated

    p = tight_problem()

    def run(pairs, time_limit=None):
        res = plan_coordinated(p, options=CoordinatedOptions(budget_checks=1, attempt_checks=1, checks_per_fruit=0, serial_pairs=pairs,
                                                             time_limit=time_limit))
        return res, [t for t in res.tried if t.get("fallback") == "serial"]

    res, fell = run(8_000_000)  # 2 million per attempt: enough
    assert [t["feasible"] for t in fell] == [True] and res.plan.status.value == "success"
    assert res.plan.metrics["harvested"] == 25 and res.verification.passed

    res, fell = run(4_000_000)  # 1 million per attempt: taking turns gives three fruit up ...
    assert [t["feasible"] for t in fell] == [False, False, False, True]
    left = fell[-1]["left_out"]
    assert len(left) == 3 and all("work budget (1,000,000 pose-pair tests)" in why for why in left.values())
    last = res.candidate  # ... and the last resort harvests them
    assert last.variant == "one_at_a_time" and res.plan.solver["fallback"] == "one_at_a_time" and last.left_out == {}
    assert res.plan.status.value == "success" and res.verification.passed and res.plan.metrics["harvested"] == 25

    res, fell = run(400_000)  # the whole budget spent in the first attempt: the last resort, at once
    assert fell[-1]["pairs"] <= 400_000 + 50_000
    last = res.candidate
    assert last.variant == "one_at_a_time" and res.plan.solver["fallback"] == "one_at_a_time"
    assert res.plan.status.value == "success" and res.verification.passed and res.plan.metrics["harvested"] == 25
    alone = [t for t in res.tried if t.get("fallback") == "one_at_a_time"][-1]
    assert alone["moved_out_of_the_way"] >= 1  # without moving a neighbour, fruit would be left out
    moving = [[(s.t0, s.t1) for s in sch.steps if s.kind.value != "wait"] for sch in last.schedules.values()]
    for a, b in itertools.combinations(moving, 2):  # still one arm at a time
        assert all(e1 <= s2 + 1e-9 or e2 <= s1 + 1e-9 for s1, e1 in a for s2, e2 in b)

    # a clock limit stops taking turns inside its attempt too, not only between attempts (on
    # cell_problem(106), `--time-limit 5` ran an attempt of 35 s): past it, the last resort at once
    res, fell = run(8_000_000, time_limit=0.0)
    assert [t["feasible"] for t in fell] == [False] and "before the time limit" in fell[0]["reason"]
    assert fell[0]["pairs"] < 50_000  # (the budget that let the first run above succeed: 2 million)
    assert res.plan.solver["fallback"] == "one_at_a_time" and res.candidate.variant == "one_at_a_time"
    assert res.plan.status.value == "success" and res.verification.passed and res.plan.metrics["harvested"] == 25


# cell_problem(56)'s middle and right arms: the middle arm's elbow passes 157 mm from the right
# arm's base whenever its shoulder turns past 0, which it must to carry f005 (on its left, which
# only it reaches) to its bin (down and left: the shoulder's limits keep it from turning past
# pi). The clearance and both link radii need 153 mm, so the passage is open, but not to the
# coordinator's planning buffer (15 mm more): every candidate deadlocked, the arms took turns and
# f005 was left out (on the three-arm cell, two fruit, 80 s of planning for a 24.6 s plan).
PASSAGE = {
    "name": "passage", "defaults": {"link_radius": 0.0409, "joint_limits": [[-3.135, 3.135], [-2.9751, 2.9751]],
                                    "home": [1.1178, 0.146]},
    "arms": [{"name": "r2", "base": [0.5674, 0.0], "links": [0.8696, 0.7002], "bin": [0.4302, -0.6418],
              "max_velocity": [2.83, 3.3068], "max_acceleration": [7.7918, 12.8645], "max_jerk": [124.6023, 112.5426]},
             {"name": "r3", "base": [1.5944, 0.0], "links": [1.0654, 0.892], "bin": [1.9105, -0.6928],
              "max_velocity": [2.6055, 3.5883], "max_acceleration": [13.776, 8.7451], "max_jerk": [111.6898, 141.9866]}],
    "fruits": [{"id": "f005", "position": [-0.2485, 1.1273]}, {"id": "f008", "position": [2.3136, 0.7789]}],
    "task": {"pick_dwell": 0.3304, "place_dwell": 0.2018, "clearance": 0.0716},
}


def test_a_buffer_wider_than_a_passage_is_dropped_before_the_arms_take_turns(monkeypatch):
    """When no candidate can be coordinated with the planning buffer, the same search runs with
    the clearance alone, and its plan is kept only where the verifier passes it."""
    from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated, planner
    from coplan.planners.coordinated.schedule import pair_distances
    from coplan.problem import problem_from_mapping

    p = problem_from_mapping(PASSAGE)
    arm, other = p.arms
    assert 0 < np.hypot(*np.subtract(other.base, arm.base)) - arm.links[0] - (
        p.task.clearance + arm.link_radius + other.link_radius) < 0.015  # the passage: open, narrower than the buffer
    res = plan_coordinated(p, options=CoordinatedOptions(margin=0.015))
    assert res.plan.status == PlanStatus.SUCCESS and res.verification.passed and res.plan.metrics["harvested"] == 2
    assert res.plan.solver["planning_margin"] == 0.0 and res.plan.solver["planning_margin_dropped"] == 0.015
    assert res.plan.solver["fallback"] is None and res.candidate.left_out == {}
    buffered = [t for t in res.tried if t.get("margin") is None and "feasible" in t]
    assert buffered and not any(t["feasible"] for t in buffered)  # every candidate with the buffer deadlocked
    assert {"margin": 0.0, "verified": True, "makespan": res.candidate.makespan} in res.tried
    least = float(np.min(pair_distances(p, res.plan.q["r2"], res.plan.q["r3"], 0, 1)))
    assert p.task.clearance - 1e-6 <= least < p.task.clearance + 0.015  # it used the passage

    plain = plan_coordinated(problem_from_mapping({**PASSAGE, "fruits": PASSAGE["fruits"][1:]}),
                             options=CoordinatedOptions(margin=0.015))
    assert plain.plan.solver["planning_margin"] == 0.015 and plain.plan.solver["planning_margin_dropped"] is None

    kept = plan_coordinated(p, options=CoordinatedOptions(margin=0.015, relax_margin=False))  # (a live stop's cell:
    assert kept.candidate.fallback and "f005" in kept.candidate.left_out  # its margin is its booking's clearance)
    assert kept.plan.solver["planning_margin"] == 0.015 and kept.plan.solver["planning_margin_dropped"] is None

    class Refused:  # the verifier refuses the plan made without the buffer: the arms take turns, as before
        passed = False

    monkeypatch.setattr("coplan.verify.verifier.verify", lambda problem, plan: Refused())
    turns = planner.find_coordinated(p, planner.AllocationMethod.MAKESPAN, CoordinatedOptions(margin=0.015),
                                     lambda m: None)[0]
    assert turns.fallback and turns.margin is None and "f005" in turns.left_out


def test_one_arm_at_a_time_is_the_sum_of_the_arms_alone_and_verified():
    """The last resort: each arm's fastest decoupled work in turn while the others rest. On
    greenhouse_row (arms far apart) nothing is left out, the plan passes the verifier, and the
    makespan is, analytically, the sum of the arms' own schedules (each ending over its bin)
    but for the last arm, which counts to its last place."""
    import itertools

    from coplan.planners.coordinated.planner import one_at_a_time
    from coplan.problem import default_problem_path

    p = load_problem(default_problem_path())
    al = allocate(p, "makespan")
    res = one_at_a_time(p, al, margin=0.015)
    assert res.left_out == {} and res.fallback
    alone = decoupled_schedules(p, al, return_home=False)
    busy = [a.name for a in p.arms if al.assignment[a.name]]
    expect = sum(alone[n].end for n in busy[:-1]) + alone[busy[-1]].last_place
    assert res.makespan == pytest.approx(expect, abs=1e-9)
    plan = _plan(p, res.alloc, res.schedules)
    assert verify(p, plan).passed and plan.metrics["harvested"] == len(p.reachable_ids())
    # one arm at a time: no two arms move at once
    moving = [[(s.t0, s.t1) for s in res.schedules[n].steps if s.kind.value != "wait"] for n in busy]
    for a, b in itertools.combinations(moving, 2):
        assert all(e1 <= s2 + 1e-9 or e2 <= s1 + 1e-9 for s1, e1 in a for s2, e2 in b)


def test_the_summary_says_which_fruit_were_left_out_and_why():
    """A plan leaving fruit out (here the last resort on the tight layout, with a 0.2 m margin:
    0.1 m kept at the samples, which leaves the neighbours no rest pose clear of most cycles) carries each one's reason in
    ``solver.left_out``, and ``coplan solve``'s summary prints them (the first five, then how
    many more)."""
    import io

    from rich.console import Console

    from coplan.cli.summary import print_summary
    from coplan.pipeline import SolveResult
    from coplan.plan import PlannerKind, finalize_plan
    from coplan.planners.coordinated.planner import one_at_a_time, schedules_plan

    p = tight_problem()
    last = one_at_a_time(p, allocate(p, "makespan"), margin=0.2)
    plan = schedules_plan(p, last.alloc, last.schedules, PlannerKind.COORDINATED, {"left_out": last.left_out})
    ver = verify(p, plan)
    plan = finalize_plan(plan, ver, len(p.reachable_ids()))
    left = plan.solver["left_out"]
    assert len(left) == 15 and plan.status.value == "partial"
    out = SolveResult(problem=p, plan=plan, verification=ver)  # what solve returns, to print
    buf = io.StringIO()
    print_summary(Console(file=buf, width=200), out)
    text = buf.getvalue()
    assert "left out          15 fruit:" in text and "... and 10 more (plan.json: solver.left_out)" in text
    first = next(iter(left))
    assert f"{first}" in text and "one arm working at a time" in text


@pytest.mark.parametrize("name, seed", [("cell", 106), ("random", 127), ("cell", 141)])
def test_the_last_resort_harvests_what_waiting_could_not(name, seed):
    """Layouts where leg-by-leg coordination deadlocks on every candidate (arms 1.06-1.21 m
    apart): one arm at a time, resting neighbours moved out of the way, harvests every fruit the
    screen does not prove unharvestable, and the independent verifier passes the plan."""
    from coplan.allocate.screen import screened
    from coplan.generate import cell_problem, random_problem, to_yaml
    from coplan.planners.coordinated.alone import one_at_a_time
    from coplan.problem import parse_problem

    gen = cell_problem if name == "cell" else random_problem
    p = parse_problem(to_yaml(gen(seed)), f"{name}-{seed}")
    res = one_at_a_time(p, allocate(p, "makespan"), margin=0.015)
    assert res.left_out == {}
    plan = _plan(p, res.alloc, res.schedules)
    ver = verify(p, plan)
    assert ver.passed
    harvestable = set(p.reachable_ids()) - set(screened(p).unharvestable)
    assert plan.metrics["harvested"] == len(harvestable) > 0


def test_a_question_asked_again_is_answered_alike_and_spends_the_budget_alike():
    """Taking turns remembers which poses of one sweep come too close to another's (a crowded
    6 m row asked 3,878 such questions, 2,722 of them new); a repeat gives the answer computed
    afresh, and spends the work budget as the first asking did, so the budget runs out where it
    did without the memory."""
    from coplan.planners.coordinated.serial import _Serial

    p = tight_problem()
    geo = _Serial(p, MARGIN, 200.0, 0.05, 0.05)
    a, b = p.arms
    home_a, home_b = tuple(map(float, a.home)), tuple(map(float, b.home))
    q, ok = kin.ik(np.array(p.fruits[0].position), a.links, a.base)
    target = tuple(map(float, q[int(np.argmax(ok))]))
    work = geo.sweep(0, home_a, [target])
    cands = geo.cands(1, own=False)
    p0 = geo.pairs
    first = geo.hits(1, cands, 0, work)
    spent = geo.pairs - p0
    again = geo.hits(1, cands, 0, work)
    assert spent > 0 and geo.pairs - p0 == 2 * spent
    assert np.array_equal(first, again) and np.array_equal(first, geo._hits(1, cands, 0, work, False))
    again[:] = ~again  # (a caller's change to its answer is not remembered)
    assert np.array_equal(geo.hits(1, cands, 0, work), first)
    assert geo.hits(0, work, 1, geo.sweep(1, home_b, []), first=True).shape == (len(work.levels[0][0]),)
