"""JSON Schemas of the problem and plan formats: shipped files equal what the models export,
shipped problems and a solved plan.json validate, and the problem schema agrees with the
loader on seeded mutations."""

from __future__ import annotations

import copy
import json
import random

import jsonschema
import pytest
import yaml
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import ProblemError
from coplan.kinds import SchemaKind
from coplan.problem import parse_problem, shipped_problems
from coplan.schema import json_schema, schema_text, shipped_path


def validator(kind: SchemaKind) -> jsonschema.Draft202012Validator:
    schema = json.loads(shipped_path(kind).read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


@pytest.mark.parametrize("kind", list(SchemaKind))
def test_shipped_schema_files_equal_what_the_models_export(kind):
    assert shipped_path(kind).read_text() == schema_text(kind), "regenerate with: python -m coplan.schema"
    assert json.loads(shipped_path(kind).read_text()) == json_schema(kind)


@pytest.mark.parametrize("path", shipped_problems(), ids=lambda p: p.stem)
def test_shipped_problems_validate(path):
    errors = [e.message for e in validator(SchemaKind.PROBLEM).iter_errors(yaml.safe_load(path.read_text()))]
    assert errors == []


def test_a_solved_plan_validates(tmp_path, problems_dir):
    res = CliRunner().invoke(app, ["solve", str(problems_dir / "crossing_paths.yaml"), "--planner", "coordinated",
                                   "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "plan.json").read_text())
    v = validator(SchemaKind.PLAN)
    assert [e.message for e in v.iter_errors(doc)] == []
    broken = copy.deepcopy(doc)
    broken["events"][0]["kind"] = "grab"
    del broken["time"]
    assert {e.validator for e in v.iter_errors(broken)} == {"enum", "required"}


def test_every_metric_coplan_writes_is_described_in_the_plan_schema(tmp_path, problems_dir):
    """(plan.json's metrics were a bare object: nothing said that ``throughput`` is fruit per
    second -- a sweep's table column of that name is fruit per minute -- or that
    ``gap_to_lower_bound`` is a ratio.) An optimal cell plan, its baseline and a row plan."""
    import coplan
    from coplan.problem import load_problem, shipped_rows

    schema = json.loads(shipped_path(SchemaKind.PLAN).read_text())["$defs"]
    described = schema["PlanMetrics"]["properties"]
    assert all(v.get("description") for v in described.values())
    assert "SECOND" in described["throughput"]["description"] and "RATIO" in described["gap_to_lower_bound"]["description"]
    from coplan.generate import gantry_row

    cell = coplan.solve(problems_dir / "greenhouse_row.yaml", out_dir=tmp_path / "cell")
    row = coplan.solve(load_problem(next(p for p in shipped_rows() if p.stem == "sparse_row")), planner="coordinated")
    moving = coplan.solve(gantry_row(length=6.0, n_arms=2, density=1.0, seed=1), gantry="continuous")
    docs = [json.loads((tmp_path / "cell" / n).read_text()) for n in ("plan.json", "baseline.json")] + [
        json.loads(json.dumps(r.plan.to_dict())) for r in (row, moving)]
    rows = schema["RowMetrics"]["properties"]
    assert all(v.get("description") for v in rows.values())
    for doc in docs:
        assert set(doc["metrics"]) <= set(described), set(doc["metrics"]) - set(described)
        assert set(doc["metrics"].get("row") or {}) <= set(rows), set(doc["metrics"]["row"]) - set(rows)
        for arm in doc["metrics"]["per_arm"].values():
            assert set(arm) <= set(schema["ArmMetrics"]["properties"])
        assert [e.message for e in validator(SchemaKind.PLAN).iter_errors(doc)] == []
    assert cell.plan.metrics["throughput"] == pytest.approx(cell.plan.metrics["harvested"] / cell.plan.metrics["makespan"])


def _mutations(doc: dict, rng: random.Random):
    """Edits that make a problem file invalid, each with where it applies."""
    arm = rng.randrange(len(doc["arms"]))
    fruit = rng.randrange(len(doc["fruits"])) if doc.get("fruits") else None
    yield "drop name", lambda d: d.pop("name")
    yield "drop task", lambda d: d.pop("task")
    yield "drop arm base", lambda d: d["arms"][arm].pop("base")
    yield "unknown top key", lambda d: d.__setitem__("optoins", {})
    yield "unknown arm key", lambda d: d["arms"][arm].__setitem__("speed", 1.0)
    yield "unknown task key", lambda d: d["task"].__setitem__("dwell", 1.0)
    yield "negative dwell", lambda d: d["task"].__setitem__("pick_dwell", -rng.uniform(0.01, 5))
    yield "three-number base", lambda d: d["arms"][arm].__setitem__("base", [0.0, 0.0, 0.0])
    yield "text as a number", lambda d: d["task"].__setitem__("clearance", "five cm")
    yield "no arms", lambda d: d.__setitem__("arms", [])
    if fruit is not None:
        yield "fruit without position", lambda d: d["fruits"][fruit].pop("position")
        yield "empty fruit id", lambda d: d["fruits"][fruit].__setitem__("id", "")
        yield "blank fruit id", lambda d: d["fruits"][fruit].__setitem__("id", "   ")
    yield "blank arm name", lambda d: d["arms"][0].__setitem__("name", "  ")
    yield "gantry null", lambda d: d.__setitem__("gantry", None)  # (the schema took it; coplan: a gantry is a mapping)


@pytest.mark.parametrize("seed", range(3))
def test_the_problem_schema_and_the_loader_agree_on_mutations(seed):
    """Cross-check of the two: every mutation is refused by both, the originals accepted by both."""
    rng = random.Random(seed)
    v = validator(SchemaKind.PROBLEM)
    for path in shipped_problems():
        doc = yaml.safe_load(path.read_text())
        parse_problem(yaml.safe_dump(doc))
        assert v.is_valid(doc)
        for what, edit in _mutations(doc, rng):
            bad = copy.deepcopy(doc)
            edit(bad)
            assert not v.is_valid(bad), (path.name, what)
            with pytest.raises(ProblemError):
                parse_problem(yaml.safe_dump(bad))


def test_generated_feeds_validate_and_the_feed_schema_refuses_what_the_loader_refuses():
    """The vision feed's schema (for a camera pipeline writing feeds): feeds ``coplan feed``
    makes validate, an empty one too; each edit the schema refuses, the loader refuses."""
    from coplan.live.feed import FEED_FORMAT, Feed, FeedError, feed_yaml, make_feed, parse_feed
    from coplan.problem import default_problem_path, load_problem

    assert json_schema(SchemaKind.FEED)["properties"]["format"]["anyOf"][0]["const"] == FEED_FORMAT
    v = validator(SchemaKind.FEED)
    problem = load_problem(default_problem_path())
    feeds = [make_feed(problem, false_rate=0.3, duplicate_rate=0.3, seed=s) for s in range(3)]
    feeds.append(Feed((), feeds[0].close_distance, feeds[0].close_sigma, feeds[0].problem))
    for feed in feeds:
        doc = yaml.safe_load(feed_yaml(feed))
        assert [e.message for e in v.iter_errors(doc)] == []
    doc = yaml.safe_load(feed_yaml(feeds[0]))
    edits = {
        "a negative time": lambda d: d["detections"][0].__setitem__("t", -1.0),
        "one coordinate": lambda d: d["detections"][0].__setitem__("position", [0.5]),
        "no sigma": lambda d: d["detections"][0].pop("sigma"),
        "a zero sigma": lambda d: d["detections"][0].__setitem__("sigma", 0.0),
        "an unknown key": lambda d: d["detections"][0].__setitem__("colour", "red"),
        "a number as id": lambda d: d["detections"][0].__setitem__("id", 7),
        "another format": lambda d: d.__setitem__("format", "coplan.feed/2"),
        "a far close range": lambda d: d.__setitem__("close_range", {"distance": 2.0}),
        "no detections": lambda d: d.pop("detections"),
        "an unknown top key": lambda d: d.__setitem__("camera", "zed"),
    }
    for what, edit in edits.items():
        bad = copy.deepcopy(doc)
        edit(bad)
        assert not v.is_valid(bad), what
        with pytest.raises(FeedError):
            parse_feed(yaml.safe_dump(bad))


@pytest.mark.parametrize("kind", ["problem", "plan", "feed"])
def test_cli_schema_prints_the_shipped_file(kind):
    res = CliRunner().invoke(app, ["schema", kind])
    assert res.exit_code == 0 and res.stdout == shipped_path(kind).read_text()
    assert CliRunner().invoke(app, ["schema", "options"]).exit_code == 2


def _accepted_edits(doc: dict):
    """Edits coplan's loader accepts, each with what it is (the schema refused each)."""
    yield "a number as the name", lambda d: d.__setitem__("name", 5)
    yield "a number as the description", lambda d: d.__setitem__("description", 12)
    yield "a number as an arm name", lambda d: d["arms"][0].__setitem__("name", 12)
    yield "true as the name and the description", lambda d: d.update(name=True, description=True)  # (kept as written: 'true')
    yield "false as an arm name", lambda d: d["arms"][0].__setitem__("name", False)
    if doc.get("fruits"):
        yield "a number as a fruit id", lambda d: d["fruits"][0].__setitem__("id", 2.5)


@pytest.mark.parametrize("path", shipped_problems(), ids=lambda p: p.stem)
def test_what_the_loader_accepts_the_schema_accepts(path):
    v = validator(SchemaKind.PROBLEM)
    doc = yaml.safe_load(path.read_text())
    for what, edit in _accepted_edits(doc):
        ok = copy.deepcopy(doc)
        edit(ok)
        parse_problem(yaml.safe_dump(ok))  # accepted by coplan ...
        assert v.is_valid(ok), (what, [e.message for e in v.iter_errors(ok)])  # ... and by the schema
    none = copy.deepcopy(doc)
    none["fruits"] = None  # (coplan: nothing to harvest, exit 4 at solve; the schema said "None is not of type 'array'")
    parse_problem(yaml.safe_dump(none))
    assert v.is_valid(none)


def test_a_plan_with_more_keys_in_its_gantry_validates_as_coplan_reads_it(tmp_path):
    """(``gantry: {x: [...], extra: 1}`` was refused by the schema and verified by coplan.)"""
    v = validator(SchemaKind.PLAN)
    doc = {"format": "coplan.plan/1", "problem": "p", "time": [0.0, 0.01], "arms": {"a": {"q": [[0, 0], [0, 0]]}},
           "events": [], "gantry": {"x": [0.0, 0.0], "note": "from my tool"}}
    assert v.is_valid(doc), [e.message for e in v.iter_errors(doc)]
