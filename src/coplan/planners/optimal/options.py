"""The optimal planner's options (:class:`OptimalOptions`), also from a YAML file
(``coplan solve --options FILE``), validated like problem files.

Every field of :class:`OptimalOptions` (documented path: ``coplan.optimal.OptimalOptions``) may
be set; keys left out keep their defaults. The coordinated planner takes its margin, budget
(``coordination_checks``) and time limit from the same file. ``ipopt`` is a mapping of IPOPT settings passed through to CasADi
(e.g. ``ipopt.max_iter: 500``). Example::

    search_work: 200000       # more search than the default
    search_temperature: 0.5
    polish: true              # also the joint NLP (off by default)
    ipopt: {ipopt.tol: 1.0e-7}

Bad values raise :class:`OptionsError` naming the file, line and key, what was expected and what
was found ("did you mean" for a misspelt key) -- never a traceback.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from ...errors import Issue, OptionsError, ProblemError, check_fields, coplan_file_kind, field_issue, found, is_joint_csv, known_fields, plain_scalars
from ...problem.yamlsafe import MAX_FILE_BYTES, line_of, read_input_text, read_yaml
from ...workers import default_workers, settle_workers, workers_issue

__all__ = ["OptimalOptions", "OptionsError", "load_options", "parse_options"]

#: The OptimalOptions fields the coordinated planner takes, by their CoordinatedOptions names
#: (:func:`coplan.pipeline.solve` makes its options of them); the rest steer only the optimal planner.
COORDINATED_FIELDS = {"margin": "margin", "coordination_checks": "budget_checks", "time_limit": "time_limit"}


@known_fields
@dataclass(frozen=True)
class OptimalOptions:
    """Solver options (separate from the problem).

    margin : extra clearance the planners keep (m), so that the dense, certified check passes
    coordination_checks : work budget of the coordinated planner's candidate search
    search_work : work budget of the search (conflict checks over all its coordinator runs;
        some thousands a second on one core: 2,000-3,600 measured on dense_overlap and crossing_paths);
        0 turns the search off
    search_evaluations : cap on the search's coordinator runs
    search_patience : after this many evaluations without improving on its start's best the
        search starts afresh, alternately from the lower bound's own allocation (held for that
        start) and from the coordinated plan (its random moves going on elsewhere)
    search_starts : such fresh starts before the search stops for lack of progress (it stops
        earlier when ``search_work`` is spent)
    search_temperature : the search accepts a slower state with probability exp(-dt / T), T
        falling linearly from this (s) to 0 over the first 30000 checks of ``search_work``
        (annealing; the rest is descent and fresh starts); 0 for pure descent
    seed : seed of the search's moves
    workers : processes the search runs in (:mod:`coplan.planners.optimal.portfolio`): worker
        w searches with seed ``seed + w``, each with the whole ``search_work``, and the best
        wins (least makespan, then least work, then lowest index), so the same input, options
        and workers give the same plan. 1 (the default) is the search in this process: the plan
        then depends on nothing about the machine, not even its number of cores; ``auto`` in an
        options file, as on the command line: this machine's cores, at most 8
    retime : retime the coordinated plan and the search's best with CP-SAT (the same moves,
        every start chosen together instead of leg by leg); kept only when verified and faster;
        false also turns the refinement off
    retime_work : CP-SAT's deterministic time limit per retiming (its own work unit, about
        seconds on one core; the same result on any machine)
    refine_retimes : after the search, go on from its best with the same moves, each neighbour
        ranked by its retimed makespan (:mod:`coplan.planners.optimal.refine`); this many
        retimings at most; 0 turns it off (then the search's best alone is retimed)
    refine_fruit : refine only problems with at most this many fruit to plan (each retiming
        of a long row takes seconds); longer ones get the bounded retiming instead
    retime_shift : on problems with more than ``refine_fruit`` fruit, retiming lets every move
        start at most this many seconds later than it does now (and as early as its own arm
        allows): pairs of moves that can never overlap then need no constraint, and a 200-600
        fruit row is retimed in seconds instead of running out of time
    retime_rounds : bounded retimings in a row, each from the last one's result, while each
        gains (more than 10 ms) and is kept
    polish : also run the joint NLP from the incumbent when it still waits (off by default:
        since retiming and refinement, it has not improved a verified plan on any benchmark
        problem -- retiming chooses every wait of the same moves together, and does it better:
        crossing_paths 6.22 s against the NLP's 6.29 s -- while it costs 5-40 s; on
        dense_overlap it took 37 s to return 14.99 s, which the verifier refused). When no
        coordinated plan can be verified at all, the NLP runs anyway, as the last resort
    polish_iterations : IPOPT iterations the whole polish may spend (every round, window and
        retry; checked before each solve, and each solve is capped at 200 unless ``ipopt`` sets
        ``ipopt.max_iter``); when they are spent, the last solution is offered to the verifier
    polish_windows : polish only schedules the NLP solves in at most this many receding windows
        (on longer ones the windows' cuts pin the timing and the polish has not paid)
    polish_rounds : refinement rounds of each polishing window (``max_rounds`` for the last resort)
    widen : the widening stage (:mod:`coplan.planners.optimal.widen`), last: one joint
        CasADi/IPOPT program over all arms at the incumbent's makespan, the order of events
        across arms kept, that widens the least room between neighbours (beyond the required
        clearance), then smooths the jerk; kept only when verified, no slower and with a
        certified margin no smaller. (Not ``margin``, the coordinator's planning buffer.)
    widen_goal : plans whose certified margin (least certified clearance less the required)
        is already this much (m) are only smoothed (their room held), or left as they are
        when proven optimal
    widen_cap : the most extra room (m) the widening asks for
    widen_iterations : IPOPT iterations the widening may spend over all its solves
    widen_knots : plans whose knot grid is longer are not widened (one program over the whole plan)
    widen_ease : the widening program starts from each arm's rest spread over its moves
        (:mod:`coplan.planners.optimal.ease`; should it give nothing to keep, the program is
        solved again from the plan's own schedules)
    regroup : after the widening, where the plan still keeps less certified margin than the
        widening's goal (twice the margin it started from, at most ``widen_goal``), the planner
        runs again on the problem with its clearance raised by the shortfall (other allocation,
        order and events: :mod:`coplan.planners.optimal.regroup`); its plan is kept when
        verified at the problem's clearance, no slower, harvesting as much and with more room
    tolerance : a makespan this close to the lower bound (s) is proven optimal (at most 0.01 s: one sample)
    screen : initial NLP constraint points where the schedule's links are within this (m)
    screen_shift : ... also when one arm of a pair runs up to this much (s) earlier or later
    h_target : target knot spacing (s)
    max_rounds : NLP solves per window while adding constraint points
    band : when the dense check finds a dip, points are also added wherever links come within
        ``band`` (m) of the refinement threshold
    window : receding-window length (s of schedule); schedules shorter than 1.5 windows are
        solved as one NLP
    overlap : each window is solved this much (s) past its cut and kept only up to it
    window_time_limit : optional wall-clock cap of each IPOPT solve (s); by default IPOPT's
        iteration cap bounds it (the same on any machine)
    time_limit : wall-clock limit for the whole planner (s); None for none. At the limit the
        incumbent is returned.
    check_rate : rate of the planner's own dense clearance check (Hz)
    """

    margin: float = 0.015
    coordination_checks: int = 3000
    search_work: int = 100_000
    search_evaluations: int = 5_000
    search_patience: int = 200
    search_starts: int = 3
    search_temperature: float = 0.3
    seed: int = 0
    workers: int = 1
    retime: bool = True
    retime_work: float = 5.0
    refine_retimes: int = 100
    refine_fruit: int = 40
    retime_shift: float = 1.5
    retime_rounds: int = 4
    polish: bool = False
    polish_iterations: int = 400
    polish_rounds: int = 5
    polish_windows: int = 1
    widen: bool = True
    widen_goal: float = 0.05
    widen_cap: float = 0.10
    widen_iterations: int = 300
    widen_knots: int = 600
    widen_ease: bool = True
    regroup: bool = True
    tolerance: float = 1e-3
    screen: float = 0.25
    h_target: float = 0.06
    max_rounds: int = 6
    band: float = 0.03
    screen_shift: float = 0.0
    window: float = 12.0
    overlap: float = 2.5
    time_limit: float | None = None
    window_time_limit: float | None = None
    check_rate: float = 1000.0
    ipopt: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        # built in Python as in a file: every value checked (``workers="auto"``: this machine's cores, at most 8)
        # every bad field at once (search_work='x' beside workers=0 was said only after workers was mended)
        plain_scalars(self)
        issues = settle_workers(self, collect=True)
        try:
            check_fields(self, _POSITIVE, found=issues)
        except OptionsError as e:
            issues = list(e.issues)
        if not {"widen_goal", "widen_cap"} & {i.path for i in issues}:
            # (the key the user changed is the one blamed: its default beside it is not what they wrote)
            bad = _goal_issue(self.widen_goal, self.widen_cap, frozenset(
                {"widen_goal"} if self.widen_goal != type(self).widen_goal or self.widen_cap == type(self).widen_cap else set()))
            if bad is not None:
                issues.append(Issue(*bad))
        if self.ipopt and "ipopt" not in {i.path for i in issues}:  # names and values as CasADi and IPOPT take them
            issues += ipopt_issues(self.ipopt)  # (else: an internal error, minutes in)
        if issues:
            raise OptionsError(issues, type(self).__name__)


# fields that must be > 0 (the others of their type must be >= 0)
_POSITIVE = {"workers", "h_target", "window", "check_rate", "time_limit", "window_time_limit", "retime_work", "retime_shift", "retime_rounds",
             "polish_iterations", "polish_rounds", "max_rounds",  # (0 of the last three crashed the polish: nothing to solve)
             "widen_iterations"}  # (0 was reported as "IPOPT did not converge"; widen: false turns the stage off)

#: The most extra room (m) the widening may ask for: more than any 2R cell's neighbours can use,
#: and each pair's separation points grow with it (a cap of 1e6 m: 1,756 points against 128, a
#: 55 s solve and 22 mm of margin against 70 mm at the default 0.1 m).
WIDEN_CAP_MAX = 1.0


def _goal_issue(goal: float, cap: float, given: frozenset = frozenset({"widen_goal"})) -> tuple[str, str] | None:
    """``(key, message)`` when ``widen_goal`` exceeds ``widen_cap`` (the program asks for at most
    the cap, so a larger goal could never be met) or the cap exceeds :data:`WIDEN_CAP_MAX`, or
    None. The key is the one the user gave (``given``): a file with only ``widen_cap: 0`` was told
    of ``widen_goal``, which it never wrote."""
    if cap > WIDEN_CAP_MAX:
        return "widen_cap", (f"expected at most {WIDEN_CAP_MAX:g} m (more room than neighbouring arms can use; "
                             f"each pair's separation points grow with it), found {cap:g}")
    if goal > cap:
        if "widen_goal" not in given:
            return "widen_cap", (f"expected at least widen_goal ({goal:g} m, its default): the widening asks for at most "
                                 f"widen_cap of extra room, so a goal above it is never met; found {cap:g}")
        return "widen_goal", (f"expected at most widen_cap ({cap:g} m): the widening asks for at most widen_cap of extra "
                              f"room, so a larger goal is never met; found {goal:g}")
    return None


def _check(name: str, kind: str, v: Any) -> str | None:
    """The message for a bad value of field ``name`` (type ``kind``), or None if it is good."""
    return field_issue(name, kind, v, name in _POSITIVE)


def parse_options(text: str, source: str | None = None, base: OptimalOptions | None = None) -> OptimalOptions:
    """Options from YAML text (the keys given replace ``base``'s, default the defaults)."""
    n = len(text.encode("utf-8", errors="replace"))
    if n > MAX_FILE_BYTES:
        raise OptionsError([Issue("", f"expected at most {MAX_FILE_BYTES} bytes of YAML, found {n} bytes")], source)
    if all(not ln.strip() or ln.lstrip().startswith("#") for ln in text.splitlines()):
        return base or OptimalOptions()  # nothing but comments: the defaults
    try:
        data, lines = read_yaml(text, source, expected="a mapping of option names to values")
    except ProblemError as e:  # the YAML itself: the same checks as for problem files
        raise OptionsError(e.issues, source) from None
    other = ("a coplan plan CSV (a replay of joint samples: t,<arm>_q1,...)" if is_joint_csv(data) else
             f"a coplan {coplan_file_kind(data)} file (format {data.get('format')!r})" if coplan_file_kind(data) else
             "a problem file (keys arms, fruits)" if isinstance(data, dict) and {"arms", "fruits"} <= set(data) else None)
    if other is not None:  # another file given here: one sentence, not a list of unknown keys
        raise OptionsError([Issue("", f"expected an options file (option names such as search_work, widen, time_limit), "
                                      f"found {other}; were the arguments swapped?", 1)], source)
    if not isinstance(data, dict):
        raise OptionsError([Issue("", f"expected a mapping of option names to values, found {found(data)}", line_of(lines, ()))],
                           source)
    kinds = {f.name: str(f.type) for f in fields(OptimalOptions)}
    issues, values = [], {}
    for key, v in data.items():
        if key not in kinds:
            near = difflib.get_close_matches(str(key), list(kinds), n=1, cutoff=0.5)
            hint = f"; did you mean {near[0]!r}?" if near else f"; allowed keys: {', '.join(kinds)}"
            issues.append(Issue(str(key), f"expected a known option, found unknown key {key!r}{hint}", line_of(lines, (key,))))
            continue
        if key == "workers":  # as on the command line: a whole number of processes, or auto
            msg = workers_issue(v)
            if msg is None:
                values[key] = default_workers() if isinstance(v, str) else int(v)
                continue
        else:
            msg = _check(key, kinds[key], v)
        if msg is not None:
            issues.append(Issue(str(key), msg, line_of(lines, (key,))))
            continue
        if key == "ipopt":  # each setting on its own line
            bad = ipopt_issues(v, lines)
            if bad:
                issues += bad
                continue
        values[key] = (int(v) if kinds[key] == "int" else float(v) if kinds[key].startswith("float") and v is not None
                       else dict(v) if kinds[key] == "dict" else v)
    if not issues:
        start = base or OptimalOptions()
        bad = _goal_issue(values.get("widen_goal", start.widen_goal), values.get("widen_cap", start.widen_cap),
                          frozenset(values))
        if bad is not None:
            issues.append(Issue(bad[0], bad[1], line_of(lines, (bad[0],))))
    if issues:
        raise OptionsError(issues, source)
    return replace(base or OptimalOptions(), **values)


def ipopt_issues(settings: dict, lines=None) -> list[Issue]:
    """Issues for the IPOPT settings CasADi or IPOPT refuse (:mod:`.ipopt_options`), each named
    ``ipopt.<key>`` (with its line in an options file's ``lines``)."""
    from .ipopt_options import ipopt_option_issues

    return [Issue(f"ipopt.{k}", msg, line_of(lines, ("ipopt", k)) if lines is not None else None)
            for k, msg in ipopt_option_issues(settings)]


def load_options(path: str | Path, base: OptimalOptions | None = None) -> OptimalOptions:
    """Load and validate an options file (raises :class:`OptionsError`)."""
    return parse_options(read_input_text(path, OptionsError), str(Path(path)), base)
