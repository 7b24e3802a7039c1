"""Plan files: ``coplan.plan/1`` JSON written, read back and replayed; bad files named precisely."""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from coplan.errors import PlanFileError
from coplan.planners.heuristic import plan_heuristic
from coplan.plan import PLAN_FORMAT, EventKind, Plan, PlanStatus, load_plan
from coplan.problem import Problem

ISSUE_KEYS = {"format", "problem", "planner", "status", "time", "arms", "events", "unreachable", "metrics"}
EXTRA_KEYS = {"allocation", "solver", "verification", "software"}  # optional fields beside the issue's


@pytest.fixture(scope="module")
def plan(greenhouse: Problem) -> Plan:
    return plan_heuristic(greenhouse)


@pytest.fixture(scope="module")
def saved(plan: Plan, tmp_path_factory) -> dict[str, Path]:
    return plan.save(tmp_path_factory.mktemp("plan"))


@pytest.fixture(scope="module")
def doc(saved: dict[str, Path]) -> dict:
    return json.loads(saved["json"].read_text())


# --------------------------------------------------------------------------- the written file
def test_plan_json_has_the_issues_keys_and_format(doc: dict, greenhouse: Problem) -> None:
    assert ISSUE_KEYS <= set(doc) and set(doc) - ISSUE_KEYS <= EXTRA_KEYS
    assert doc["format"] == PLAN_FORMAT == "coplan.plan/1"
    assert doc["problem"] == "greenhouse-row" and doc["planner"] == "heuristic"
    assert doc["status"] in {s.value for s in PlanStatus}
    assert set(doc["arms"]) == {"left", "center", "right"}
    assert all(set(v) == {"q"} for v in doc["arms"].values())
    assert doc["unreachable"] == ["f01"]
    for e in doc["events"]:
        assert set(e) == {"arm", "fruit", "kind", "t_start", "t_end"}
        assert e["kind"] in ("pick", "place") and e["t_start"] <= e["t_end"]
    assert len(doc["events"]) == 2 * 11
    assert doc["allocation"]["right"] == ["f02", "f03", "f08", "f10", "f12"]


def test_time_grid_is_uniform_100hz_from_zero_and_every_arm_has_every_sample(doc: dict) -> None:
    t = np.array(doc["time"])
    assert t[0] == 0.0
    dt = np.diff(t)
    assert np.allclose(dt, dt[0], atol=1e-9) and dt[0] <= 0.01 + 1e-12
    for a, v in doc["arms"].items():
        q = np.array(v["q"])
        assert q.shape == (t.size, 2), a
        assert np.isfinite(q).all()
    # the grid covers every event
    assert t[-1] >= max(e["t_end"] for e in doc["events"])


def test_makespan_is_the_end_of_the_last_place(doc: dict) -> None:
    last_place = max(e["t_end"] for e in doc["events"] if e["kind"] == "place")
    assert doc["metrics"]["makespan"] == last_place
    last_pick = max(e["t_end"] for e in doc["events"] if e["kind"] == "pick")
    assert last_pick < last_place < doc["time"][-1]  # the arms still fly home afterwards


def test_save_writes_csv_and_npz_beside_and_no_temporary(saved: dict[str, Path], plan: Plan) -> None:
    assert {p.name for p in saved["json"].parent.iterdir()} == {"plan.json", "plan.csv", "plan.npz"}
    csv = np.loadtxt(saved["csv"], delimiter=",", skiprows=1)
    header = saved["csv"].read_text().splitlines()[0]
    assert header == "t,left_q1,left_q2,center_q1,center_q2,right_q1,right_q2"
    assert csv.shape == (plan.time.size, 7)
    np.testing.assert_allclose(csv[:, 0], plan.time, atol=1e-7)
    np.testing.assert_allclose(csv[:, 5:7], plan.q["right"], atol=1e-7)
    npz = np.load(saved["npz"])
    np.testing.assert_array_equal(npz["time"], plan.time)
    np.testing.assert_array_equal(npz["q_center"], plan.q["center"])


def test_save_to_a_json_file_name_writes_beside_it(plan: Plan, tmp_path: Path) -> None:
    """(plan.save("my_plan.json") made a folder named my_plan.json.) A file name ending .json
    writes my_plan.json, .csv and .npz beside it, each whole (no temporary file left)."""
    paths = plan.save(tmp_path / "my_plan.json")
    assert {k: p.name for k, p in paths.items()} == {"json": "my_plan.json", "csv": "my_plan.csv", "npz": "my_plan.npz"}
    assert {p.name for p in tmp_path.iterdir()} == {"my_plan.json", "my_plan.csv", "my_plan.npz"}
    assert all(p.is_file() for p in paths.values())
    np.testing.assert_allclose(load_plan(paths["json"]).q["left"], plan.q["left"], atol=5.1e-8)
    np.testing.assert_allclose(load_plan(paths["csv"]).q["left"], plan.q["left"], atol=1e-7)
    (tmp_path / "folder.json").mkdir()  # an existing folder is a folder, whatever its name
    assert plan.save(tmp_path / "folder.json")["json"] == tmp_path / "folder.json" / "plan.json"


# --------------------------------------------------------------------------- round trip
def test_save_load_round_trip(saved: dict[str, Path], plan: Plan) -> None:
    back = load_plan(saved["json"])
    assert back.problem == plan.problem and back.planner == plan.planner and back.status == plan.status
    np.testing.assert_allclose(back.time, plan.time, atol=1e-9)
    assert list(back.q) == list(plan.q)
    for a in plan.q:
        np.testing.assert_allclose(back.q[a], plan.q[a], atol=6e-8)  # 7 decimals written
    assert back.events == plan.events  # floats are written exactly
    assert back.allocation == plan.allocation and back.unreachable == plan.unreachable
    assert back.metrics["makespan"] == plan.metrics["makespan"]
    assert back.metrics["per_arm"]["left"]["fruit"] == 4
    assert back.metrics["harvested"] == 11 and back.metrics["reachable"] == 11


@pytest.mark.parametrize("status", list(PlanStatus))
def test_every_status_round_trips(plan: Plan, status: PlanStatus, tmp_path: Path) -> None:
    p = plan.with_status(status)
    assert load_plan(p.save(tmp_path)["json"]).status == status


def test_replay_is_linear_between_samples(saved: dict[str, Path]) -> None:
    back = load_plan(saved["json"])
    i = 123
    mid = (back.time[i] + back.time[i + 1]) / 2
    s = back.sample(np.array([back.time[i], mid, -1.0, 1e9]))
    for a, q in back.q.items():
        np.testing.assert_allclose(s[a][0], q[i], atol=1e-12)
        np.testing.assert_allclose(s[a][1], (q[i] + q[i + 1]) / 2, atol=1e-12)
        np.testing.assert_array_equal(s[a][2], q[0])  # clamped before the start
        np.testing.assert_array_equal(s[a][3], q[-1])  # and after the end
    assert back.dt == pytest.approx(0.01)


def test_a_row_plan_replays_its_carriage_too(tmp_path: Path, saved: dict[str, Path]) -> None:
    """(plan.sample(t) of a row gave the joint angles only: the bases' positions were the
    carriage's, read from gantry_x by hand.)"""
    import coplan
    from coplan.generate import gantry_row

    res = coplan.solve(gantry_row(length=6.0, density=2.0, seed=1), stops="fewest", out_dir=tmp_path / "row")
    back = load_plan(tmp_path / "row" / "plan.json")
    x = back.gantry_x
    i = int(np.argmax(np.abs(np.diff(x)) > 1e-6))  # a sample while the carriage moves
    mid = (back.time[i] + back.time[i + 1]) / 2
    c = back.carriage(np.array([back.time[i], mid, -1.0, 1e9]))
    np.testing.assert_allclose(c, [x[i], (x[i] + x[i + 1]) / 2, x[0], x[-1]], atol=1e-12)
    assert x[i] != x[i + 1] and c[2] == res.problem.gantry.start
    with pytest.raises(ValueError, match="a stationary cell's plan has no carriage"):
        load_plan(saved["json"]).carriage(np.array([0.0]))
    for bad in (np.nan, [0.0, np.inf]):  # a time that is not a number: refused, not answered with NaN
        with pytest.raises(ValueError, match="t: expected finite times in s, found"):
            back.carriage(bad)
        with pytest.raises(ValueError, match="t: expected finite times in s, found"):
            back.sample(bad)
    for bad in ("1.0", ["0.5"], None):  # (a string was read as its number)
        with pytest.raises(ValueError, match=r"t: expected times in s \(numbers\), found"):
            back.sample(bad)


def test_loaded_events_are_usable(saved: dict[str, Path]) -> None:
    back = load_plan(saved["json"])
    picks = back.events_of("center", EventKind.PICK)
    assert [e.fruit for e in picks] == ["f04", "f09"]


# --------------------------------------------------------------------------- bad files
def _bad(tmp_path: Path, doc: dict, mutate=None, raw: str | None = None) -> PlanFileError:
    d = copy.deepcopy(doc)
    if mutate is not None:
        mutate(d)
    path = tmp_path / "bad.json"
    path.write_text(raw if raw is not None else json.dumps(d))
    with pytest.raises(PlanFileError) as ei:
        load_plan(path)
    assert str(ei.value).startswith(f"{path}: ")
    return ei.value


def _set(path: list, value):
    def f(d):
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] = value
    return f


BAD = [
    ("wrong-format", _set(["format"], "coplan.plan/2"), "format", "expected 'coplan.plan/1', found string 'coplan.plan/2'"),
    ("no-format", lambda d: d.pop("format"), "format", "found nothing"),
    ("missing-time", lambda d: d.pop("time"), "time", "required field"),
    ("ragged-q", lambda d: d["arms"]["left"]["q"].__setitem__(5, [0.1]), "arms.left.q[5]", "expected a [t1, t2] pair"),
    ("short-q", lambda d: d["arms"]["center"]["q"].pop(), "arms.center.q", "one per time"),
    ("nan-q", lambda d: d["arms"]["right"]["q"].__setitem__(7, [float("nan"), 0.0]), "arms.right.q[7][0]", "expected a finite number, found nan"),
    ("inf-time", lambda d: d["time"].__setitem__(4, float("inf")), "time[4]", "expected a finite number, found inf"),
    ("string-in-q", lambda d: d["arms"]["left"]["q"].__setitem__(2, [0.1, "0.2"]), "arms.left.q[2][1]", "expected a number, found string '0.2'"),
    ("bool-in-time", lambda d: d["time"].__setitem__(1, True), "time[1]", "found boolean True"),
    ("non-uniform", lambda d: d["time"].__setitem__(10, d["time"][10] + 0.004), "time[10]", "expected a uniform grid with spacing 0.01 s, found a step of 0.014 s"),
    ("not-increasing", lambda d: d["time"].__setitem__(10, d["time"][9]), "time[10]", "expected strictly increasing times"),
    ("coarse", lambda d: d.update(time=[2 * x for x in d["time"]]), "time", "expected a grid of 100 Hz or finer"),
    ("late-start", lambda d: d.update(time=[x + 0.5 for x in d["time"]]), "time[0]", "expected 0, found 0.5"),
    ("empty-time", _set(["time"], []), "time", "found an empty one"),
    ("unknown-arm", lambda d: d["events"][3].update(arm="ghost"), "events[3].arm", "expected one of the plan's arms ['left', 'center', 'right'], found 'ghost' (arms has no samples of 'ghost': missing, or the event misnames its arm; 1 event names it)"),
    # (an arm cut from arms: one issue, not one per event -- hundreds on a row)
    ("arm-cut", lambda d: d["arms"].pop("right"), "events[2].arm", "found 'right' (arms has no samples of 'right'"),
    ("bad-kind", lambda d: d["events"][0].update(kind="grab"), "events[0].kind", "expected 'pick' or 'place', found string 'grab'"),
    ("nan-event", lambda d: d["events"][2].update(t_start=float("nan")), "events[2].t_start", "expected a finite time"),
    ("reversed-event", lambda d: d["events"][1].update(t_end=0.0), "events[1].t_end", "expected t_end >= t_start"),
    ("event-missing-key", lambda d: d["events"][4].pop("fruit"), "events[4].fruit", "required field"),
    ("event-extra-key", lambda d: d["events"][4].update(colour="red"), "events[4].colour", "unknown key 'colour'"),
    ("event-not-object", lambda d: d["events"].__setitem__(0, 5), "events[0]", "found number 5"),
    ("arms-empty", _set(["arms"], {}), "arms", "expected an object mapping arm names"),
    ("arm-without-q", _set(["arms", "left"], {"qq": []}), "arms.left", "expected an object with key 'q'"),
    ("bad-planner", _set(["planner"], 5), "planner", "expected the planner's name (a non-empty string), found number 5"),
    ("bad-allocation", _set(["allocation"], [1, 2]), "allocation", "found array [1, 2]"),
    ("bad-unreachable", _set(["unreachable"], 5), "unreachable", "expected an array of fruit ids"),
    ("bad-metrics", _set(["metrics"], [1]), "metrics", "expected an object"),
]


@pytest.mark.parametrize("mutate,path,fragment", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_plan_files_name_the_key_path(tmp_path: Path, doc: dict, mutate, path: str, fragment: str) -> None:
    err = _bad(tmp_path, doc, mutate)
    assert [it.path for it in err.issues] == [path], str(err)  # exactly one issue: no cascades
    assert fragment in err.issues[0].message
    assert err.issues[0].message.startswith("expected ")


def test_several_bad_fields_are_all_reported(tmp_path: Path, doc: dict) -> None:
    def mutate(d):
        d["planner"] = ""
        d["time"][3] += 0.004
        d["events"][0]["arm"] = "ghost"
        d["arms"]["right"]["q"][1] = [None, 0.0]

    err = _bad(tmp_path, doc, mutate)
    assert [it.path for it in err.issues] == ["planner", "time[3]", "arms.right.q[1][0]", "events[0].arm"]


@pytest.mark.parametrize(
    "raw,line,fragment",
    [('{"format": "coplan.plan/1",\n  oops}', 2, "expected JSON, found a syntax error"), ("", None, "expected a JSON plan (an object with keys format, problem, time, arms, events), found an empty file"),
     ("[1, 2]", None, "expected a JSON object, found array [1, 2]")],
    ids=["syntax", "empty", "array"],
)
def test_not_a_json_object(tmp_path: Path, doc: dict, raw: str, line, fragment: str) -> None:
    err = _bad(tmp_path, doc, raw=raw)
    (it,) = err.issues
    assert fragment in it.message and it.line == line


def test_missing_file_and_directory(tmp_path: Path) -> None:
    with pytest.raises(PlanFileError, match="found no file at this path"):
        load_plan(tmp_path / "none.json")
    with pytest.raises(PlanFileError, match="found a directory"):
        load_plan(tmp_path)


def test_a_sample_missing_from_the_grid_is_measured_against_the_usual_step():
    """(One sample of a 100 Hz plan deleted: 'expected spacing 0.0100106 s', the mean step.)"""
    from coplan.plan import time_grid_issues

    t = np.delete(np.arange(1000) / 100.0, 100)
    assert time_grid_issues(t) == [(100, "expected a uniform grid with spacing 0.01 s, found a step of 0.02 s")]


def test_a_plan_read_back_equals_the_plan_and_a_rows_npz_keeps_the_carriage(tmp_path):
    """(``load_plan(path) == plan`` raised on the NumPy arrays; a row's plan.npz had no gantry_x.)"""
    import coplan
    from coplan.generate import gantry_row

    res = coplan.solve(gantry_row(length=6.0, n_arms=2, density=2.0, seed=3), out_dir=tmp_path / "row")
    back = load_plan(tmp_path / "row" / "plan.json")
    assert back == res.plan and back == load_plan(tmp_path / "row" / "plan.json") and back != 3
    back.events = back.events[:-1]
    assert back != res.plan
    npz = np.load(tmp_path / "row" / "plan.npz")
    assert sorted(npz) == ["gantry_x", "q_arm1", "q_arm2", "time"]
    assert np.array_equal(npz["gantry_x"], res.plan.gantry_x)


def test_a_plan_file_records_the_software_that_made_it_and_keeps_it(tmp_path, problems_dir):
    """(A reproducibility trial found no version in plan.json: pyproject asks only for minimum
    versions, so a later install may plan differently, and COPLAN_OPENBLAS_CORETYPE=native may.)"""
    import json
    from dataclasses import replace

    import coplan
    from coplan.plan import load_plan

    res = coplan.solve(problems_dir / "crossing_paths.yaml", planner="coordinated", out_dir=tmp_path / "a")
    data = json.loads((tmp_path / "a" / "plan.json").read_text())
    sw = data["software"]
    import os

    assert sw["coplan"] == coplan.__version__ and sw["openblas_coretype"] == os.environ.get("OPENBLAS_CORETYPE")
    # the commit where coplan runs from a git checkout (the version alone named a thousand commits), else none
    import subprocess

    root = Path(coplan.__file__).resolve().parents[2]
    if (root / ".git").exists() and (root / "src" / "coplan").is_dir():
        described = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=root, capture_output=True, text=True).stdout.strip()
        assert sw["source"] == described and described
    else:  # (an installed copy, as CI's)
        assert sw["source"] is None
    import numpy, casadi  # noqa: E401
    assert sw["numpy"] == numpy.__version__ and sw["casadi"] == casadi.__version__
    plan = load_plan(tmp_path / "a" / "plan.json")
    assert plan.software == sw
    # a plan read back and written again keeps what made it, not what wrote it
    replace(plan, software=dict(sw, numpy="0.0-elsewhere")).save(tmp_path / "b")
    assert json.loads((tmp_path / "b" / "plan.json").read_text())["software"]["numpy"] == "0.0-elsewhere"
    assert res.plan.software == sw  # (set when the plan was made and verified, here)
    assert plan == replace(plan, software=dict(sw, numpy="0.0-elsewhere"))  # (one plan, whatever made it)
    # a plan made elsewhere (a plan.csv replay) is not stamped with this process's versions
    from coplan.plan import load_plan as _load

    csv_plan = _load(tmp_path / "a" / "plan.csv")
    csv_plan.save(tmp_path / "c")
    assert csv_plan.software is None and "software" not in json.loads((tmp_path / "c" / "plan.json").read_text())


def test_a_plan_changed_after_its_verdict_is_saved_unverified(greenhouse: Problem, tmp_path: Path) -> None:
    """(A plan edited in place -- its joints moved 5 rad -- was saved still "success" with its
    verdict, and ``coplan verify`` then failed it; then still with the verdict's certified
    margin and the old motion's jerk in its metrics.) Its file says ``unverified``, no verdict,
    metrics of the motion it has; unchanged, it keeps both."""
    from coplan.planners.coordinated import plan_coordinated

    p = plan_coordinated(greenhouse).plan
    assert p.status == PlanStatus.SUCCESS and not p.changed_since_verified()
    assert p.to_dict()["status"] == "success" and p.to_dict()["verification"]["passed"]
    arm = next(iter(p.q))
    p.q[arm][:] = p.q[arm][0] + 5.0
    assert p.changed_since_verified()
    assert p.metrics["margin"] > 0 and p.metrics["margin_per_pair"]
    p.q[arm][5:8] += 0.001  # (a jerk the old motion did not have)
    back = load_plan(p.save(tmp_path)["json"])
    assert back.status == PlanStatus.UNVERIFIED and back.verification is None
    assert "margin" not in back.metrics and "margin_per_pair" not in back.metrics
    assert back.metrics["per_arm"][arm]["peak_jerk"] > p.metrics["per_arm"][arm]["peak_jerk"]
    assert back.metrics["harvested"] == p.metrics["harvested"] and back.metrics["lower_bound"] == p.metrics["lower_bound"]


def test_a_plan_read_from_its_file_then_edited_is_saved_unverified(greenhouse: Problem, tmp_path: Path) -> None:
    """(A plan read with load_plan, its joints moved, was saved "success" with the verdict of
    the motion it no longer has: load_plan recorded nothing of what the verdict was about.)"""
    import dataclasses

    from coplan.planners.coordinated import plan_coordinated

    path = plan_coordinated(greenhouse).plan.save(tmp_path / "a")["json"]
    read = load_plan(path)
    assert read.status == PlanStatus.SUCCESS and not read.changed_since_verified()
    assert load_plan(read.save(tmp_path / "same")["json"]).status == PlanStatus.SUCCESS  # unchanged: its verdict kept
    arm = next(iter(read.q))
    moved = dataclasses.replace(read, q={**read.q, arm: read.q[arm] + 0.3})
    read.q[arm][300:, 0] += 0.3
    for p, where in ((read, "edited"), (moved, "replaced")):
        assert p.changed_since_verified()
        back = load_plan(p.save(tmp_path / where)["json"])
        assert back.status == PlanStatus.UNVERIFIED and back.verification is None


def test_the_verifier_holds_a_plan_made_in_python_to_a_plan_file_s_time_grid(single_arm: Problem) -> None:
    """(A plan made in Python on a 10 Hz grid passed verification -- its limits read on
    differences ten times as coarse -- though the same motion at 100 Hz is 10 x over its
    acceleration limit; and one whose times started at 1 s. A plan file with either is refused.)"""
    from coplan.errors import PlanFileError
    from coplan.planners.coordinated import plan_coordinated
    from coplan.verify.verifier import verify

    p = plan_coordinated(single_arm).plan
    for time, q, words in ((p.time[::10], {a: v[::10] for a, v in p.q.items()}, "expected a grid of 100 Hz or finer"),
                           (p.time + 1.0, p.q, "expected 0, found 1.0")):
        coarse = Plan(problem=p.problem, planner="mine", status=PlanStatus.UNVERIFIED, time=time, q=q, events=[],
                      allocation={}, unreachable=[])
        with pytest.raises(PlanFileError, match=words):
            verify(single_arm, coarse)


def test_two_solves_of_one_problem_are_the_same_motion_though_their_timings_differ(greenhouse: Problem) -> None:
    """(A researcher checked "the same input gives the same plan" with ``==``, which compares the
    files, wall-clock timings included: never equal.)"""
    from coplan.planners.coordinated import plan_coordinated

    a, b = plan_coordinated(greenhouse).plan, plan_coordinated(greenhouse).plan
    assert a.same_motion(b)
    arm = next(iter(b.q))
    b.q[arm][10, 0] += 1e-9
    assert not a.same_motion(b)


def test_a_plans_per_arm_queries_name_an_unknown_arm_or_kind():
    """(From a trial: events_of('lefft') and events_of('left', 'grab') returned [], busy('lefft')
    raised a bare KeyError.)"""
    import coplan

    plan = coplan.solve("crossing_paths", planner="heuristic").plan
    for call in (lambda: plan.events_of("lefft"), lambda: plan.busy("lefft")):
        with pytest.raises(KeyError, match=r"no arm named 'lefft' in the plan; arms are \['left', 'right'\]"):
            call()
    with pytest.raises(ValueError, match="event kind: expected one of 'pick', 'place'; found 'grab'"):
        plan.events_of("left", "grab")
    assert plan.events_of("left", "pick") == plan.events_of("left", EventKind.PICK) != []


def test_save_names_a_bad_destination(tmp_path):
    """(plan.save(5) raised Python's 'expected str, bytes or os.PathLike object, not int'.)"""
    import coplan

    plan = coplan.solve("single_arm", planner="heuristic").plan
    with pytest.raises(TypeError, match="save: expected a folder or a .json file name"):
        plan.save(5)
    assert set(plan.save(tmp_path / "p.json")) == {"json", "csv", "npz"}
    # a file in the way, or a name ending as one of the other two files: said, nothing written
    # (FileExistsError from pathlib; "p.csv" made a folder of that name)
    from coplan.output import OutputError
    from coplan.viz.plots import save_comparison_figures

    (tmp_path / "notes.txt").write_text("mine")
    for where, said in ((tmp_path / "notes.txt", "expected a folder or a file name ending .json (the plan is written "
                                                 "as .json, .csv and .npz together), found a file"),
                        (tmp_path / "notes.txt" / "sub", "found the file"),
                        (tmp_path / "p.csv", "found a name ending .csv")):
        with pytest.raises(OutputError, match=re.escape(said)):
            plan.save(where)
    with pytest.raises(OutputError, match="save_comparison_figures: out_dir .*: expected a folder, found a file"):
        save_comparison_figures(coplan.load_problem("single_arm"), {"heuristic": plan}, tmp_path / "notes.txt")
    assert (tmp_path / "notes.txt").read_text() == "mine" and not (tmp_path / "p.csv").is_dir()
    # a .json name in a new folder whose name ends .csv is a .json name (the folder is made)
    assert plan.save(tmp_path / "new.csv" / "run.json")["json"] == tmp_path / "new.csv" / "run.json"


@pytest.mark.parametrize("cut", [0.31, 0.5, 0.97])
def test_a_plan_file_cut_short_is_called_cut_short(tmp_path: Path, doc: dict, cut: float) -> None:
    """A plan.json that ends part way (a copy or a write that did not finish) is refused as cut
    short, wherever the cut falls (in a string, after a comma, in a number); a syntax error
    inside a whole file is not."""
    text = json.dumps(doc, indent=1)
    err = _bad(tmp_path, doc, raw=text[: int(cut * len(text))])
    (it,) = err.issues
    assert "expected JSON, found a syntax error" in it.message and "it looks cut short" in it.message
    whole = _bad(tmp_path, doc, raw=text.replace('"format"', "format", 1))
    assert "cut short" not in whole.issues[0].message


def test_a_plan_json_with_a_byte_order_mark_reads_as_without(tmp_path: Path, saved: dict[str, Path], plan: Plan) -> None:
    """(An editor's BOM made it a JSON syntax error, while a plan.csv with one read.)"""
    f = tmp_path / "bom.json"
    f.write_bytes(b"\xef\xbb\xbf" + saved["json"].read_bytes())
    got = load_plan(f)
    assert got.events == load_plan(saved["json"]).events and np.array_equal(got.time, load_plan(saved["json"]).time)


def test_a_fine_grid_that_runs_fast_or_whose_first_step_is_off_is_not_uniform():
    """(Each step was allowed 1e-4 h + 1e-6 s off the mean and the checks divided by the first step:
    a 10 kHz grid whose steps after the first were 1 % short passed the verifier with velocities
    1.01 x, jerk 1.03 x the limits; one whose first step alone was 0.99 us short got 82 limit
    violations on a plan that kept its limits.)"""
    from coplan.plan import grid_step, time_grid_issues

    fast = np.r_[0.0, 1e-4 + 0.99e-4 * np.arange(1000)]
    (i, msg), = time_grid_issues(fast)
    assert i == 1 and msg.startswith("expected a uniform grid with spacing 9.9e-05 s, found a step of 0.0001 s"), msg
    first = np.r_[0.0, 0.99e-4 + 1e-4 * np.arange(1000)]
    (i, msg), = time_grid_issues(first)
    assert i == 1 and "found a step of 9.9e-05 s" in msg, msg
    # a grid rounded to the microseconds plan.json keeps is uniform, at its mean step
    third = np.round(np.arange(3001) / 3000.0, 6)
    assert time_grid_issues(third) == [] and grid_step(third) == pytest.approx(1.0 / 3000.0, rel=1e-9)
    assert np.max(np.abs(np.diff(third) - 1.0 / 3000.0)) > 3e-7  # (its steps differ by the rounding)


def test_the_verifier_refuses_a_fine_grid_that_runs_fast():
    """The samples of a 1 kHz plan on a grid 1 % fast after its first step are refused for their
    grid, with the step it found (the verifier had passed such a plan at 10 kHz)."""
    from coplan.problem import load_problem
    from coplan.verify import verify

    problem = load_problem("crossing_paths")
    n = 2001
    q = {a.name: np.tile(np.asarray(a.home, float), (n, 1)) for a in problem.arms}
    fast = Plan(problem.name, "coordinated", PlanStatus.UNVERIFIED, np.r_[0.0, 1e-3 + 0.99e-3 * np.arange(n - 1)], q, [], {}, [])
    assert fast.dt == pytest.approx((1e-3 + 0.99e-3 * (n - 2)) / (n - 1))
    with pytest.raises(PlanFileError, match=r"time\[1\]: expected a uniform grid with spacing 0.00099 s, found a step of 0.001 s"):
        verify(problem, fast)


def test_a_one_arm_plan_s_margin_is_none_in_python_as_in_its_file(tmp_path) -> None:
    """(With no pair of neighbours ``plan.metrics["margin"]`` was inf in Python and null in plan.json.)"""
    import coplan

    plan = coplan.solve("single_arm", planner="coordinated").plan
    assert plan.metrics["margin"] is None and plan.metrics["margin_per_pair"] == {}
    plan.save(tmp_path)
    assert load_plan(tmp_path / "plan.json").metrics["margin"] is None
    two = coplan.solve("crossing_paths", planner="coordinated").plan  # (with neighbours it is a number, in both)
    assert math.isfinite(two.metrics["margin"])
    two.save(tmp_path / "two")
    assert load_plan(tmp_path / "two" / "plan.json").metrics["margin"] == pytest.approx(two.metrics["margin"])
