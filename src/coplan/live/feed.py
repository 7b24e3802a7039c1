"""Vision feeds: what the camera reports, as a YAML file validated like problem files.

A feed (format ``coplan.feed/1``) is a list of detection events::

    format: coplan.feed/1
    problem: greenhouse-row          # optional: the problem it was made for (a warning if not)
    close_range: {distance: 0.1, sigma: 0.001}   # optional: when the gripper camera refines
    detections:
      - {t: 0.0, id: d001, position: [0.69, 0.74], sigma: 0.01, fruit: f04}
      - {t: 0.4, id: d002, position: [0.70, 1.29], sigma: 0.01, fruit: f09, after: f04}
      - {t: 3.1, id: d003, position: [1.02, 1.51], sigma: 0.01, fruit: null}   # a false positive

``t`` is when the detection arrives (s; with ``after``: s after that fruit's pick ends -- it was
hidden behind it); ``sigma`` the standard deviation of each coordinate (m); ``fruit`` (optional,
for simulation) which true fruit it is, ``null`` for a false detection. ``close_range``: when a
gripper's tip comes within ``distance`` (m) of its target, a refined measurement with standard
deviation ``sigma`` arrives.

:func:`make_feed` generates seeded feeds from a problem: a share known at t = 0, the rest
arriving at random times or after a neighbouring fruit is picked, Gaussian noise, false
positives and duplicate detections.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError, Issue, ProblemError, coplan_file_kind, finite_number, found, is_joint_csv
from ..problem.model import Problem
from ..problem.plausible import MAX_PLAN_SECONDS, field_issues
from ..problem.yamlsafe import MAX_FILE_BYTES, line_of, path_str, read_input_text, read_yaml

__all__ = ["FEED_FORMAT", "Detection", "Feed", "FeedError", "parse_feed", "load_feed", "detection_issues", "refinement_issues", "make_feed", "feed_yaml",
           "DEFAULT_CLOSE_DISTANCE", "DEFAULT_CLOSE_SIGMA"]

FEED_FORMAT = "coplan.feed/1"
DEFAULT_CLOSE_DISTANCE = 0.10  # m: the gripper camera sees the fruit from here
DEFAULT_CLOSE_SIGMA = 0.001  # m
#: The largest noise a detection may report (m): a metre of error is no measurement of a fruit.
MAX_FEED_SIGMA = 1.0
_ROW_KEYS = ("t", "id", "position", "sigma", "fruit", "after")
_TOP_KEYS = ("format", "problem", "close_range", "detections")
#: The plausible range of each close_range key, m (a feed file's, and ``coplan feed``'s options):
#: a gripper camera that measures from a metre away, or with 10 cm of error, is no close range.
CLOSE_RANGE_BOUNDS = {"distance": (0.005, 1.0), "sigma": (1e-6, 0.1)}


class FeedError(InputError):
    kind = "feed"


@dataclass(frozen=True)
class Detection:
    """One detection event: when it arrives, its id, the measured position and its noise."""

    t: float
    id: str
    position: tuple[float, float]
    sigma: float
    fruit: str | None = None  # the true fruit (simulation only); None: a false detection / unknown
    after: str | None = None  # arrives t s after this true fruit's pick ends (simulation only)
    line: int | None = field(default=None, compare=False)

    def to_dict(self) -> dict:
        out = {"t": round(self.t, 4), "id": self.id, "position": [round(self.position[0], 5), round(self.position[1], 5)],
               "sigma": self.sigma, "fruit": self.fruit}
        if self.after is not None:
            out["after"] = self.after
        return out


@dataclass(frozen=True)
class Feed:
    detections: tuple[Detection, ...]
    close_distance: float = DEFAULT_CLOSE_DISTANCE
    close_sigma: float = DEFAULT_CLOSE_SIGMA
    problem: str | None = None
    source: str | None = None
    digest: str | None = field(default=None, compare=False)  # sha256 of the YAML text it was read from

    def check_against(self, problem: Problem) -> None:
        """Raise :class:`FeedError` if a row names a fruit the problem does not have, or a fruit
        can never be revealed: hidden behind itself, or behind fruit hidden behind it."""
        ids = {f.id for f in problem.fruits}
        issues = []
        for i, d in enumerate(self.detections):
            for key in ("fruit", "after"):
                v = getattr(d, key)
                if v is not None and v not in ids:
                    issues.append(Issue(f"detections[{i}].{key}", f"expected a fruit id of problem {problem.name!r}, "
                                                                    f"found {v!r}", d.line))
        if not issues:
            issues = self._never_revealed()
        if not issues:
            issues = self._too_late(problem)
        if issues:
            raise FeedError(issues, self.source)

    def _too_late(self, problem: Problem) -> list[Issue]:
        """A detection so late that the run's plan -- at least that long, and then the problem's
        work (:func:`coplan.problem.plausible.plan_duration_bound`) -- would outgrow the longest
        plan coplan makes with this many arms (its file must read back)."""
        from ..problem.plausible import latest_report_time

        last, why = latest_report_time(problem)
        return [Issue(f"detections[{i}].t", f"expected a time of at most {math.floor(last * 10) / 10:g} s ({why}), found {d.t!r}", d.line)
                for i, d in enumerate(self.detections) if d.t > last][:5]

    def _never_revealed(self) -> list[Issue]:
        """Detections of a fruit every one of whose reports waits for a pick that waits for it:
        ``after`` itself, or a loop of fruit each hidden behind the next."""
        behind: dict[str, set[str]] = {}
        free = set()
        for d in self.detections:
            if d.fruit is None:
                continue
            if d.after is None:
                free.add(d.fruit)
            else:
                behind.setdefault(d.fruit, set()).add(d.after)
        for f in free:
            behind.pop(f, None)  # some report of it comes on its own: it is revealed
        issues = []
        for i, d in enumerate(self.detections):
            if d.fruit is None or d.after is None or d.fruit not in behind:
                continue
            seen, todo = set(), [d.after]
            while todo:  # the fruit this one waits for, and theirs
                g = todo.pop()
                if g in seen:
                    continue
                seen.add(g)
                todo += behind.get(g, ())
            if d.fruit in seen:
                what = "itself" if d.after == d.fruit else f"{d.after!r}, which waits for {d.fruit!r} in turn"
                issues.append(Issue(f"detections[{i}].after", f"expected a fruit picked before {d.fruit!r} can be seen, "
                                                               f"found {d.after!r}: {d.fruit!r} would wait for {what} "
                                                               "and never be revealed", d.line))
        return issues


def parse_feed(text: str, source: str | None = None) -> Feed:
    """A :class:`Feed` from YAML text; every problem at once as :class:`FeedError`."""
    n = len(text.encode("utf-8", errors="replace"))
    if n > MAX_FILE_BYTES:
        raise FeedError([Issue("", f"expected at most {MAX_FILE_BYTES} bytes of YAML, found {n} bytes")], source)
    try:
        data, lines = read_yaml(text, source, expected="a mapping with key 'detections' (a coplan.feed/1 file)")
    except ProblemError as e:  # the YAML itself: the same checks as for problem files
        raise FeedError(e.issues, source) from None
    issues: list[Issue] = []

    def bad(loc: tuple, msg: str) -> None:
        path = ""
        for part in loc:
            path += f"[{part}]" if isinstance(part, int) else ("." if path else "") + str(part)
        issues.append(Issue(path, msg, line_of(lines, loc)))

    if is_joint_csv(data):  # coplan's plan CSV or an export CSV
        raise FeedError([Issue("", "expected a feed file (format coplan.feed/1, key 'detections'), found a CSV of joint "
                                   "samples (t,<arm>_q1,...: a plan.csv or an export); were the arguments swapped?", 1)], source)
    if not isinstance(data, dict):
        shown = found(data, list_length=True)
        shown = shown if len(shown) <= 80 else shown[:77] + "..."
        raise FeedError([Issue("", f"expected a mapping with key 'detections', found {shown}", line_of(lines, ()))], source)
    if "detections" not in data and {"arms", "fruits"} <= set(data):
        raise FeedError([Issue("", "expected a feed file (format coplan.feed/1, key 'detections'), found a problem file "
                                   "(keys arms, fruits); were the problem and the feed swapped?", line_of(lines, ()))], source)
    fmt = data.get("format")
    kind = coplan_file_kind(data)
    if kind is not None and kind != "feed":  # another kind of coplan file: say only that (another version: below)
        raise FeedError([Issue("", f"expected a feed file (format {FEED_FORMAT}, key 'detections'), found a coplan {kind} file "
                                   f"(format {fmt!r}); were the arguments swapped?", line_of(lines, ("format",)))], source)
    for key in data:
        if key not in _TOP_KEYS:
            bad((key,), f"expected one of {', '.join(_TOP_KEYS)}, found unknown key {key!r}")
    if "format" in data and data["format"] != FEED_FORMAT:
        bad(("format",), f"expected {FEED_FORMAT!r}, found {found(data['format'], list_length=True)}")
    problem = data.get("problem")
    if problem is not None and not isinstance(problem, str):
        bad(("problem",), f"expected the problem's name (a string), found {found(problem, list_length=True)}")
        problem = None
    dist, sig = _close_range(data.get("close_range"), bad)
    rows = data.get("detections")
    out: list[Detection] = []
    if "detections" not in data:
        bad(("detections",), "expected a list of detections, found nothing (required field)")
        rows = []
    elif not isinstance(rows, list):
        bad(("detections",), f"expected a list of detections, found {found(rows, list_length=True)}")
        rows = []
    seen: dict[str, int] = {}
    for i, row in enumerate(rows):
        loc = ("detections", i)
        if not isinstance(row, dict):
            bad(loc, f"expected a mapping {{t, id, position, sigma[, fruit, after]}}, found {found(row, list_length=True)}")
            continue
        det = _detection(row, loc, seen, bad, lines)
        if det is not None:
            out.append(det)
    if issues:
        raise FeedError(issues, source)
    import hashlib

    return Feed(tuple(out), float(dist), float(sig), problem, source, hashlib.sha256(text.encode("utf-8")).hexdigest())


def _close_range(cr, bad) -> tuple[float, float]:
    """A feed's ``close_range`` (None: the defaults): its distance and sigma, each default where
    missing or refused (``bad(loc, message)`` collects the issues)."""
    dist, sig = DEFAULT_CLOSE_DISTANCE, DEFAULT_CLOSE_SIGMA
    if cr is not None:
        if not isinstance(cr, dict):
            bad(("close_range",), f"expected a mapping {{distance, sigma}}, found {found(cr, list_length=True)}")
        else:
            for key, v in cr.items():
                if key not in ("distance", "sigma"):
                    bad(("close_range", key), f"expected distance or sigma, found unknown key {key!r}")
                elif not finite_number(v) or not CLOSE_RANGE_BOUNDS[key][0] <= v <= CLOSE_RANGE_BOUNDS[key][1]:
                    lo, hi = CLOSE_RANGE_BOUNDS[key]
                    bad(("close_range", key), f"expected a number in [{lo:g}, {hi:g}] m (as coplan feed's --close-{key}), "
                                              f"found {found(v, list_length=True)}")
            dist = cr.get("distance", dist) if finite_number(cr.get("distance", dist)) else dist
            sig = cr.get("sigma", sig) if finite_number(cr.get("sigma", sig)) else sig
    return dist, sig


def _detection(row: dict, loc: tuple, seen: dict[str, int], bad, lines) -> Detection | None:
    """One of a feed's ``detections`` (a mapping, at ``loc``), or None where refused (each issue
    to ``bad(loc, message)``); ``seen``: the ids so far -> their index (this one's added)."""
    ok = True
    for key in row:
        if key not in _ROW_KEYS:
            bad(loc + (key,), f"expected one of {', '.join(_ROW_KEYS)}, found unknown key {key!r}")
            ok = False
    for key in ("t", "id", "position", "sigma"):
        if key not in row:
            bad(loc + (key,), "expected a value, found nothing (required field)")
            ok = False
    if not ok:
        return None
    t, rid, pos, sigma = row["t"], row["id"], row["position"], row["sigma"]
    if not finite_number(t) or t < 0 or t > MAX_PLAN_SECONDS:
        bad(loc + ("t",), f"expected a time in [0, {MAX_PLAN_SECONDS:g}] s (within the longest plan coplan makes, "
                          f"coplan.plausible.MAX_PLAN_SECONDS), found {found(t, list_length=True)}")
        ok = False
    if not isinstance(rid, str) or not rid.strip():
        bad(loc + ("id",), f"expected a non-empty string, found {found(rid, list_length=True)}")
        ok = False
    elif rid in seen:
        bad(loc + ("id",), f"expected a unique id, found {rid!r} again (first in detections[{seen[rid]}])")
        ok = False
    else:
        seen[rid] = loc[1]
    if not isinstance(pos, list) or len(pos) != 2 or not all(finite_number(x) for x in pos):
        what = (f"[{', '.join(found(x) for x in pos)}]" if isinstance(pos, list) and len(pos) == 2
                else found(pos, list_length=True))
        bad(loc + ("position",), f"expected [x, y] (two finite numbers, m), found {what}")
        ok = False
    else:  # (as a problem file's fruit: 1e300 was accepted, and NumPy's overflow warning reached the user)
        for where, msg in field_issues("position", pos, loc + ("position",)):
            bad(where, msg)
            ok = False
    if not finite_number(sigma) or not 0 < sigma <= MAX_FEED_SIGMA:
        bad(loc + ("sigma",), f"expected a positive number of at most {MAX_FEED_SIGMA:g} (m), "
                              f"found {found(sigma, list_length=True)}")
        ok = False
    for key in ("fruit", "after"):
        v = row.get(key)
        if v is not None and (not isinstance(v, str) or not v.strip()):
            bad(loc + (key,), f"expected a fruit id (string) or null, found {found(v, list_length=True)}")
            ok = False
    if not ok:
        return None
    return Detection(float(t), rid, (float(pos[0]), float(pos[1])), float(sigma), row.get("fruit"), row.get("after"),
                     line_of(lines, loc))


def _found_pair(pos) -> str:
    """How a message names a position that is not two finite numbers: a short list with its
    values ("found a list of 2" hid a NaN)."""
    return found(pos, list_length=True) + (f" {pos!r}" if isinstance(pos, list) and len(pos) <= 4 else "")


def detection_issues(detections, seen: set[str], now: float | None = None) -> list[Issue]:
    """What is wrong with ``detections`` (:class:`Detection` objects, given in Python: to
    :meth:`coplan.live.cell.LiveCell.observe`), as a feed file's rows are checked: a finite arrival
    time from 0 to ``now``, a non-empty id not in ``seen`` nor repeated, a plausible
    position (two finite numbers within a problem's coordinates), a noise in (0, 1] m. Key paths
    ``detections[i].<key>``."""
    issues: list[Issue] = []
    ids = set(seen)
    for i, d in enumerate(detections):
        loc = ("detections", i)
        at = f"detections[{i}]"
        if not isinstance(d, Detection):
            issues.append(Issue(at, f"expected a Detection(t, id, position, sigma), found {type(d).__name__}"))
            continue
        hi = MAX_PLAN_SECONDS if now is None else now
        if not finite_number(d.t) or not 0.0 <= d.t <= hi:
            issues.append(Issue(f"{at}.t", f"expected a time in [0, {hi:g}] s (it has arrived by now), "
                                           f"found {found(d.t, list_length=True)}"))
        if not isinstance(d.id, str) or not d.id.strip():
            issues.append(Issue(f"{at}.id", f"expected a non-empty string, found {found(d.id, list_length=True)}"))
        elif d.id in ids:
            issues.append(Issue(f"{at}.id", f"expected a unique id, found {d.id!r} again"))
        else:
            ids.add(d.id)
        pos = list(d.position) if isinstance(d.position, (tuple, list, np.ndarray)) else d.position
        if not isinstance(pos, list) or len(pos) != 2 or not all(finite_number(x) for x in pos):
            issues.append(Issue(f"{at}.position", f"expected (x, y) (two finite numbers, m), found {_found_pair(pos)}"))
        else:
            issues += [Issue(path_str(where), msg) for where, msg in field_issues("position", pos, loc + ("position",))]
        if not finite_number(d.sigma) or not 0 < d.sigma <= MAX_FEED_SIGMA:
            issues.append(Issue(f"{at}.sigma", f"expected a positive number of at most {MAX_FEED_SIGMA:g} (m), "
                                               f"found {found(d.sigma, list_length=True)}"))
    return issues


def now_issues(now, last: float, name: str = "now") -> list[Issue]:
    """What is wrong with the time of a call to a live cell (``observe``, ``retry``, ``refine``):
    a finite number no earlier than the last call's, ``last`` s (the cell re-plans from its
    committed motion at that time; an earlier one would re-plan the past)."""
    if finite_number(now) and now >= last:
        return []
    return [Issue(name, f"expected a time no earlier than the last call's ({last:g} s), found {found(now)}")]


def refinement_issues(now, track_id, tracks: list[str], position, sigma, last: float = 0.0) -> list[Issue]:
    """What is wrong with a close-range measurement given in Python (to
    :meth:`coplan.live.cell.LiveCell.refine`), as :func:`detection_issues` checks a detection: a
    finite time no earlier than ``last`` (the last call's, :func:`now_issues`), the id of one of
    ``tracks``, a position of two finite numbers (or None: nothing there) and, with a position, a
    positive noise."""
    issues: list[Issue] = now_issues(now, last)
    if not isinstance(track_id, str) or track_id not in tracks:
        known = ", ".join(tracks[:8]) + (", ..." if len(tracks) > 8 else "")
        issues.append(Issue("track_id", f"expected the id of a track ({known or 'none yet'}), found {found(track_id)}"))
    pos = list(position) if isinstance(position, (tuple, list, np.ndarray)) else position
    if pos is not None and not (isinstance(pos, list) and len(pos) == 2 and all(finite_number(x) for x in pos)):
        issues.append(Issue("position", f"expected (x, y) (two finite numbers, m) or None (nothing there), found "
                                        f"{_found_pair(pos)}"))
    if pos is not None and (not finite_number(sigma) or not sigma > 0):
        issues.append(Issue("sigma", f"expected a positive number (m), found {found(sigma)}"))
    return issues


def load_feed(path: str | Path) -> Feed:
    """Load and validate a feed file (raises :class:`FeedError`)."""
    return parse_feed(read_input_text(path, FeedError), str(Path(path)))


def cell_only(problem, what: str) -> None:
    """Refuse a row (a problem with a gantry) where only a stationary cell is meant: a feed file
    and a live cell are a stationary cell's; a row's camera is simulated by the live row."""
    if not isinstance(problem, Problem):
        raise TypeError(f"{what}: expected a Problem (coplan.load_problem(...)), found {type(problem).__name__}")
    if problem.gantry is not None:
        raise ValueError(f"{what}: {problem.name!r} is a row (it has a gantry); feeds and live cells are a stationary "
                         f"cell's: a row is run live, its camera simulated, by coplan.row.live.run_live_row (coplan run ROW)")


def make_feed(problem: Problem, known: float = 0.5, sigma: float = 0.01, false_rate: float = 0.0,
              duplicate_rate: float = 0.0, seed: int = 0, reveal_by: float | None = None, after_pick: float = 0.25,
              close_distance: float = DEFAULT_CLOSE_DISTANCE, close_sigma: float = DEFAULT_CLOSE_SIGMA) -> Feed:
    """A seeded feed for ``problem``: the detections a camera might report.

    A share ``known`` of the fruit is detected at t = 0; of the rest, a share ``after_pick`` is
    hidden behind a neighbouring fruit some arm reaches (within 0.35 m, detected at t = 0 or at a time) and
    detected 0-0.5 s after that one is picked, the others at uniform times in
    ``(0, reveal_by]`` (default: half the problem's makespan lower bound). Every measurement has
    Gaussian noise ``sigma`` per coordinate. Each true detection is followed, with probability
    ``duplicate_rate``, by a second one of the same fruit 0.2-3 s later (fresh noise), and
    with probability ``false_rate`` by a false detection at a random reachable point at least
    0.1 m from every fruit.
    """
    cell_only(problem, "make_feed")
    if not 0.0 <= known <= 1.0 or not 0.0 <= false_rate <= 1.0 or not 0.0 <= duplicate_rate <= 1.0:
        raise ValueError("known, false_rate and duplicate_rate must lie in [0, 1]")
    if not sigma > 0:
        raise ValueError("sigma must be positive")
    rng = np.random.default_rng(seed)
    fruits = list(problem.fruits)
    order = rng.permutation(len(fruits))
    n_known = int(round(known * len(fruits)))
    if reveal_by is None:  # only late fruit and false detections need it
        from ..allocate.allocation import lower_bound

        late = n_known < len(fruits) or false_rate > 0
        reveal_by = 0.5 * lower_bound(problem) if late and problem.fruits else 1.0
    reveal_by = max(float(reveal_by), 1e-3)
    truth: list[tuple[float, str, str | None]] = []  # (t, fruit, after)
    visible: list[int] = []
    # an occluder is a fruit some arm reaches: one no arm picks would hide its fruit for good
    # (a reachable fruit behind the out-of-reach f01 was "never revealed", the run partial)
    picked = set(problem.reachable_ids()) if after_pick > 0 else set()
    for k, j in enumerate(order):
        f = fruits[j]
        if k < n_known:
            truth.append((0.0, f.id, None))
            visible.append(j)
            continue
        near = [i for i in visible if math.dist(fruits[i].position, f.position) < 0.35]
        hides = [i for i in near if fruits[i].id in picked]
        if near and rng.random() < after_pick and hides:  # (the same draws as before: the other fruit's feed unchanged)
            occluder = fruits[min(hides, key=lambda i: math.dist(fruits[i].position, f.position))]
            truth.append((float(rng.uniform(0.0, 0.5)), f.id, occluder.id))
        else:
            truth.append((float(rng.uniform(0.0, reveal_by)), f.id, None))
            visible.append(j)
    pos = {f.id: np.asarray(f.position, float) for f in fruits}
    rows: list[tuple[float, str | None, str | None, np.ndarray]] = []
    for t, fid, after in truth:
        rows.append((t, fid, after, pos[fid] + rng.normal(0.0, sigma, 2)))
        if rng.random() < duplicate_rate:
            rows.append((t + float(rng.uniform(0.2, 3.0)), fid, after, pos[fid] + rng.normal(0.0, sigma, 2)))
        if rng.random() < false_rate:
            p = _false_point(problem, rng)
            if p is not None:
                rows.append((float(rng.uniform(0.0, reveal_by)), None, None, p))
    rows.sort(key=lambda r: (r[2] is not None, r[0]))
    width = max(3, len(str(len(rows))))
    dets = tuple(Detection(round(t, 4), f"d{k + 1:0{width}d}", (round(float(p[0]), 5), round(float(p[1]), 5)), float(sigma), fid, after)
                 for k, (t, fid, after, p) in enumerate(rows))
    return Feed(dets, float(close_distance), float(close_sigma), problem.name)


def _false_point(problem: Problem, rng: np.random.Generator) -> np.ndarray | None:
    """A random point some arm can reach, at least 0.1 m from every fruit (None after 200 tries)."""
    pts = problem.fruit_positions
    lo = pts.min(axis=0) - 0.2 if len(pts) else np.array([-1.0, 0.5])
    hi = pts.max(axis=0) + 0.2 if len(pts) else np.array([1.0, 1.5])
    for _ in range(200):
        p = rng.uniform(lo, hi)
        if (len(pts) == 0 or np.min(np.hypot(*(pts - p).T)) >= 0.1) and any(
                a.can_reach(p, problem.task.reach_margin) for a in problem.arms):
            return p
    return None


def feed_yaml(feed: Feed) -> str:
    """The feed as YAML text (one detection per line), readable by :func:`parse_feed`."""
    import yaml

    head = {"format": FEED_FORMAT, "problem": feed.problem,
            "close_range": {"distance": feed.close_distance, "sigma": feed.close_sigma}}
    text = yaml.safe_dump(head, sort_keys=False, default_flow_style=None)
    text += "detections:\n" if feed.detections else "detections: []\n"  # (a bare key reads back as null)
    for d in feed.detections:
        text += "  - " + yaml.safe_dump(d.to_dict(), sort_keys=False, default_flow_style=True, width=400).strip() + "\n"
    return text
