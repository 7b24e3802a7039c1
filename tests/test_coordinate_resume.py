"""Resuming a coordinator run from a recorded one (coplan.planners.coordinated.trace).

Cross-check: every resumed run equals the same run from scratch, step for step (times, poses,
kinds, fruit) and in its wait/yield counts or its ConflictError; and resuming really happens
(the test would pass vacuously otherwise).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from coplan.allocate.allocation import allocate
from coplan.generate import row_problem, to_yaml
from coplan.planners.coordinated.coordinate import coordinate
from coplan.planners.coordinated.schedule import ConflictError, decoupled_schedules
from coplan.planners.coordinated.trace import Trace, resume_point
from coplan.problem import load_problem, parse_problem

MARGIN = 0.015


def _steps(schedules):
    return {n: [(s.kind, s.t0, s.duration, s.q0, s.q1, s.fruit) for s in sch.steps] for n, sch in schedules.items()}


def _run(problem, alloc, **kw):
    work: dict = {}
    try:
        out = coordinate(problem, decoupled_schedules(problem, alloc), MARGIN, max_checks=600, work=work, **kw)
    except ConflictError as e:
        return ("error", str(e)), work
    return (_steps(out[0]), out[1], out[2]), work


def _variants(alloc, rng, n):
    """Seeded changes of one arm's order each: a stretch reversed from a random place on."""
    names = [a for a, seq in alloc.assignment.items() if len(seq) > 2]
    for _ in range(n):
        a = names[int(rng.integers(len(names)))]
        seq = list(alloc.assignment[a])
        i = int(rng.integers(len(seq) - 1))
        j = int(rng.integers(i + 2, len(seq) + 1))
        seq[i:j] = seq[i:j][::-1]
        yield replace(alloc, assignment={**alloc.assignment, a: seq})


@pytest.mark.parametrize("name", ["dense_overlap", "row"])
def test_a_resumed_run_equals_the_run_from_scratch(problems_dir, name):
    if name == "row":
        problem = parse_problem(to_yaml(row_problem(4, 28, seed=3, reachable_only=True)))
    else:
        problem = load_problem(problems_dir / f"{name}.yaml")
    base = allocate(problem, "makespan")
    rng = np.random.default_rng(7)
    traces: list[Trace] = []
    resumed = compared = 0
    alloc = base
    for alloc in _variants(base, rng, 14):
        scratch, _ = _run(problem, alloc)
        trace = Trace()
        again, work = _run(problem, alloc, trace=trace, resume=traces[::-1])
        assert again == scratch
        compared += 1
        resumed += work.get("resumed_turns", 0)
        if scratch[0] != "error":
            traces.append(trace)
    assert compared == 14 and len(traces) >= 3
    assert resumed > 0  # some runs really started part-way


def test_resume_point_rules(problems_dir):
    problem = load_problem(problems_dir / "dense_overlap.yaml")
    alloc = allocate(problem, "makespan")
    trace = Trace()
    first, _ = _run(problem, alloc, trace=trace)
    assert first[0] != "error" and trace.turns
    legs = trace.legs
    last = len(trace.turns) - 1 if trace.barrier is None else trace.barrier
    # the same legs: every turn up to the first barrier can be taken over, with the same result
    assert resume_point(trace, trace.key, legs, 1e9) == last > 0
    same, work = _run(problem, alloc, resume=trace)
    assert same == first and work["resumed_turns"] == last
    # another priority order, or a horizon that the recorded run passed: from the start / there
    assert resume_point(trace, ((9,) + trace.key[0][1:],) + trace.key[1:], legs, 1e9) == 0
    assert resume_point(trace, trace.key, legs, -1.0) == 0
    # the first leg of an arm changed: only turns before that arm books it are taken over
    j = next(i for i, lg in enumerate(legs) if len(lg) > 1)
    changed = [list(lg) for lg in legs]
    changed[j][0] = replace(changed[j][0], target=(changed[j][0].target[0] + 0.01, changed[j][0].target[1]))
    e = resume_point(trace, trace.key, changed, 1e9)
    assert trace.turns[e].arm == j and trace.turns[e].done(j) == 0
    assert all(t.arm != j for t in trace.turns[:e])
