"""The interactive plan viewer (``coplan view``, ``solve --html``, ``coplan.view``).

Fast checks of the page and its embedded data in Python, then a real browser: the Debian
Chromium driven by Playwright's Python API (never Playwright's own browser download). Without
a browser these browser tests are skipped locally; with CI=true a missing browser fails them.
"""

from __future__ import annotations

import copy
import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import coplan
from coplan.cli import app
from coplan.kinds import EventKind
from coplan.problem import load_problem, shipped_problems
from coplan.verify import verify
from coplan.viz import arm_colors
from coplan.viz.viewer import decode_array, read_viewer_data, render_html, write_html

PROBLEMS = Path(shipped_problems()[0]).parent
GREENHOUSE = PROBLEMS / "greenhouse_row.yaml"
CROSSING = PROBLEMS / "crossing_paths.yaml"
CHROMIUM = os.environ.get("COPLAN_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"  # env: another build
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
SVG_NAMESPACE = "http://www.w3.org/2000/svg"  # an XML namespace name in the script, never fetched


@pytest.fixture(scope="module")
def greenhouse():
    prob = load_problem(GREENHOUSE)
    coord = coplan.solve(prob, planner="coordinated")
    heur = coplan.solve(prob, planner="heuristic")
    return prob, coord, heur


@pytest.fixture(scope="module")
def planted(greenhouse):
    """The coordinated plan with one joint-limit violation planted at t = 6.0 s (center, joint 2)."""
    prob, coord, _ = greenhouse
    plan = copy.deepcopy(coord.plan)
    k = int(round(6.0 / plan.dt))
    plan.q["center"][k, 1] = prob.arm("center").joint_limits[1][1] + 0.2
    ver = verify(prob, plan)
    limit = [v for v in ver.violations if v.kind.value == "joint_limit"]
    assert len(limit) == 1 and limit[0].t == pytest.approx(6.0)
    return prob, plan, ver


# --------------------------------------------------------------------------- the page itself
def test_greenhouse_page_is_small_self_contained_and_offline(greenhouse):
    prob, coord, heur = greenhouse
    page = render_html(prob, heur.plan, coord.plan)
    assert len(page.encode()) < 3_000_000
    assert "default-src 'none'" in page  # the browser itself refuses any network request
    urls = set(re.findall(r"https?://[^\s\"'<>)]+", page))
    assert urls <= {SVG_NAMESPACE}, urls
    assert not re.search(r"\b(src|href)\s*=\s*[\"']?(https?:)?//", page)
    assert "@import" not in page and "url(http" not in page
    assert page.count("<script") == 2 and page.count("</script>") == 2


def test_embedded_data_round_trips(greenhouse):
    prob, coord, _ = greenhouse
    data = read_viewer_data(render_html(prob, coord.plan, verification=coord.verification))
    assert data["format"] == "coplan.viewer/1"
    d = data["plans"][0]
    names = [a.name for a in prob.arms]
    exact = decode_array(d["exact"]["q"])
    assert exact.dtype == np.int32 and exact.shape == (3, coord.plan.time.size, 2) and d["exact"]["scale"] == 1e-7
    for i, a in enumerate(names):  # the readouts' data: plan.json's values, to its 1e-7 rad
        np.testing.assert_array_equal(exact[i], np.round(coord.plan.q[a] / 1e-7))
        np.testing.assert_allclose(exact[i] * 1e-7, coord.plan.q[a], rtol=0, atol=5.1e-8)
    track = decode_array(d["display"]["q"])
    times = np.arange(d["display"]["n"]) / d["display"]["rate"]
    assert d["display"]["rate"] == 50.0 and times[-1] <= coord.plan.duration < times[-1] + 0.02
    ref = coord.plan.sample(times)
    for i, a in enumerate(names):
        np.testing.assert_allclose(track[i], ref[a], atol=1e-6)  # float32 of Plan.sample
    assert [(e["arm"], e["fruit"], e["kind"], e["t_start"]) for e in d["events"]] == sorted(
        [(e.arm, e.fruit, e.kind.value, e.t_start) for e in coord.plan.events], key=lambda r: (r[3], r[0]))
    # the clearance: least per display step of the verifier's own 1 kHz profile
    for c, pair in zip(d["clearance"], coord.verification.pairs):
        assert c["arms"] == list(pair.arms)
        assert float(decode_array(c["d"]).min()) == pytest.approx(pair.min_clearance, abs=2e-4)
    assert d["verdict"]["passed"] and d["violations"] == []
    assert d["lower_bound"] == pytest.approx(coord.plan.metrics["lower_bound"])
    fruit = {f["id"]: f for f in data["problem"]["fruits"]}
    assert fruit["f01"]["unreachable"].startswith("f01: out of every arm's reach: ")  # the screen's sentence
    assert all("unreachable" not in f for k, f in fruit.items() if k != "f01")


def test_the_clearance_track_is_the_same_computed_in_pieces(greenhouse, monkeypatch):
    """A long plan's clearance is reduced piece by piece (a 2 h plan's whole 1 kHz profile took
    2.2 GB): pieces of 7 plan intervals give the page the same track as one piece."""
    import coplan.verify.clearance as cl
    from coplan.viz.viewer import viewer_data

    prob, coord, _ = greenhouse
    whole = viewer_data(prob, [coord.plan], [coord.verification])["plans"][0]["clearance"]
    monkeypatch.setattr(cl, "CHUNK_INTERVALS", 7)
    pieces = viewer_data(prob, [coord.plan], [coord.verification])["plans"][0]["clearance"]
    assert len(whole) == len(pieces) == len(prob.neighbour_pairs())
    for a, b in zip(whole, pieces):
        assert a["arms"] == b["arms"]
        np.testing.assert_array_equal(decode_array(a["d"]), decode_array(b["d"]))


def test_every_violation_is_embedded(greenhouse, planted):
    prob, _, heur = greenhouse
    d = read_viewer_data(render_html(prob, heur.plan))["plans"][0]
    ver = verify(prob, heur.plan)
    assert not ver.passed and d["verdict"]["violation_count"] == len(ver.violations) == len(d["violations"])
    assert {v["kind"] for v in d["violations"]} == {v.kind.value for v in ver.violations}
    _, plan, pver = planted
    vs = read_viewer_data(render_html(prob, plan, verification=pver))["plans"][0]["violations"]
    assert [v for v in vs if v["kind"] == "joint_limit"][0]["arms"] == ["center"]


def test_waits_say_what_they_are_for():
    prob = load_problem(CROSSING)
    res = coplan.solve(prob, planner="coordinated")
    d = read_viewer_data(render_html(prob, res.plan, verification=res.verification))["plans"][0]
    for arm, segs in d["segments"].items():
        idle = [(s["t0"], s["t1"]) for s in segs if s["phase"] == "idle"]
        assert [(w["t0"], w["t1"]) for w in d["waits"][arm]] == idle  # every wait is explained
    notes = [w for ws in d["waits"].values() for w in ws]
    assert any(w["for"].startswith(("before going to pick", "holding")) for w in notes)
    last = {arm: ws[-1] for arm, ws in d["waits"].items() if ws and ws[-1]["t1"] == pytest.approx(res.plan.duration)}
    assert all(w["for"].startswith("done") for w in last.values())


def test_untrusted_names_cannot_break_out_of_the_page(greenhouse):
    prob, coord, _ = greenhouse
    plan = copy.deepcopy(coord.plan)
    plan.planner = "</script><script>alert(1)</script>&amp;"
    page = render_html(prob, plan, verification=coord.verification)
    assert "alert(1)</script>" not in page and page.count("</script>") == 2
    assert read_viewer_data(page)["plans"][0]["planner"] == plan.planner


def test_compare_needs_a_plan_of_the_same_problem(greenhouse):
    prob, coord, _ = greenhouse
    other = coplan.solve(load_problem(CROSSING), planner="heuristic").plan
    with pytest.raises(coplan.PlanFileError, match="same problem"):
        render_html(prob, coord.plan, other)


def test_a_plan_drawn_over_an_edited_problem_shows_that_problem_s_bound_not_the_file_s(greenhouse, tmp_path):
    """(From a new user's trial: a plan viewed with ``-p`` an edited problem -- slower shoulders --
    showed the lower bound its file recorded, 12.883 s, where the problem's is 14.061 s.) A plan
    planned from this very text keeps its own bound; drawn over another text, the page gives that
    problem's bound and reachable count."""
    from coplan.allocate.allocation import bound_details
    from coplan.viz.viewer import viewer_data

    prob, coord, _ = greenhouse
    out = tmp_path / "run"
    res = coplan.solve(GREENHOUSE, planner="coordinated", out_dir=out)
    own = viewer_data(prob, [res.plan])
    assert own["plans"][0]["lower_bound"] == pytest.approx(res.plan.metrics["lower_bound"])
    slow_text = GREENHOUSE.read_text().replace("max_velocity: [3.0, 4.0]", "max_velocity: [2.0, 4.0]")
    assert slow_text != GREENHOUSE.read_text()
    (tmp_path / "slow.yaml").write_text(slow_text)
    slow = load_problem(tmp_path / "slow.yaml")
    data = viewer_data(slow, [res.plan])
    assert data["lower_bound"] == data["plans"][0]["lower_bound"] == pytest.approx(bound_details(slow).value)
    assert data["lower_bound"] > res.plan.metrics["lower_bound"] + 1.0


def test_an_acceleration_step_is_unbounded_jerk_on_the_page_and_its_size_in_rad_s2(greenhouse):
    """(From a new user's trial: beside the heuristic's violations the page said "RMS / peak jerk
    left 62 / 1051 rad/s^3", where the summary, compare and coplan verify say its jerk is
    unbounded, and gave an acceleration step's size and limit in rad/s^3.)"""
    from coplan.viz.viewer import viewer_data

    prob, _, heur = greenhouse
    pl = viewer_data(prob, [heur.plan])["plans"][0]
    steps = heur.verification.acceleration_steps()
    assert steps and {a for a, j in pl["verdict"]["jerk"].items() if j["unbounded"]} == set(steps)
    stepped = [v for v in pl["violations"] if v["step"]]
    assert stepped and all("acceleration discontinuity" in v["message"] for v in stepped)


def test_a_plan_file_whose_own_figures_are_not_its_motion_s_says_so_on_the_page(greenhouse):
    """(From a new user's trial: a plan.json edited to claim 9 s and 12 fruit -- the terminal said
    its figures were not the motion's, the page showed the measured ones without a word.)"""
    from coplan.plan import plan_from_dict
    from coplan.viz.viewer import viewer_data

    prob, coord, _ = greenhouse
    doc = coord.plan.to_dict()
    doc["metrics"] = dict(doc["metrics"], makespan=9.0)
    lie = plan_from_dict(json.loads(json.dumps(doc)))
    notes = viewer_data(prob, [lie])["plans"][0]["verdict"]["notes"]
    assert len(notes) == 1 and "makespan 9 stated" in notes[0]
    assert viewer_data(prob, [coord.plan])["plans"][0]["verdict"]["notes"] == []


def test_the_page_s_harvest_and_jerk_are_the_motion_s_for_a_plan_csv_and_an_edited_plan_json(greenhouse, tmp_path):
    """(From a user's trial: a plan.csv's page said "fruit harvested -/4" and "RMS / peak jerk
    rad/s^3" with no number; an edited plan.json's RMS jerk was shown as the file stated it.)"""
    from coplan.plan import jerk_figures, load_plan, plan_from_dict
    from coplan.viz.viewer import viewer_data

    prob, coord, _ = greenhouse
    coord.plan.save(tmp_path, "p")
    csv = load_plan(tmp_path / "p.csv")
    page = viewer_data(prob, [csv])["plans"][0]
    ver = verify(prob, coord.plan)
    assert page["harvested"] == ver.measured["harvested"] == len(prob.reachable_ids())
    motion = jerk_figures(coord.plan)
    assert set(page["verdict"]["jerk"]) == {a.name for a in prob.arms}
    for a, v in page["verdict"]["jerk"].items():
        assert v["rms"] == pytest.approx(motion[a]["rms_jerk"], rel=1e-3) and v["peak"] == pytest.approx(motion[a]["peak_jerk"], rel=1e-3)
    doc = coord.plan.to_dict()
    arm = prob.arms[0].name
    doc["metrics"]["per_arm"][arm]["rms_jerk"] = 1.0
    page = viewer_data(prob, [plan_from_dict(json.loads(json.dumps(doc)))])["plans"][0]
    assert page["verdict"]["jerk"][arm]["rms"] == pytest.approx(motion[arm]["rms_jerk"], rel=1e-6)


def test_view_of_a_plan_json_takes_its_recorded_problem_file_only_while_unchanged(tmp_path):
    """``coplan.view(plan.json)`` finds the problem file the plan records; once that file has
    changed it says so (pass the problem) rather than show the shipped problem of the same name,
    which may be another; once it is gone, the shipped problem of that name."""
    mine = tmp_path / "crossing.yaml"
    mine.write_text(CROSSING.read_text())
    coplan.solve(load_problem(mine), planner="coordinated", out_dir=tmp_path / "run")
    plan_json = tmp_path / "run" / "plan.json"
    assert coplan.view(plan_json).page  # the recorded file, unchanged
    shown = repr(coplan.view(plan_json))  # (a plain REPL printed the whole page, 147,000 characters)
    assert shown.startswith("PlanView(") and len(shown) < 200 and "characters" in shown, shown
    mine.write_text(CROSSING.read_text().replace("clearance: 0.05", "clearance: 0.06"))
    with pytest.raises(coplan.PlanFileError, match="has changed since"):
        coplan.view(plan_json)
    assert coplan.view(plan_json, problem=mine).page  # given: taken as it is
    mine.unlink()
    with pytest.warns(UserWarning, match="records no problem file that still exists: taken to be the shipped problem"):
        data = read_viewer_data(coplan.view(plan_json).page)  # gone: the shipped problem of its name, said
    assert data["problem"]["task"]["clearance"] == pytest.approx(0.05)


def test_view_of_a_plan_whose_file_is_gone_refuses_a_shipped_problem_of_another_text(tmp_path):
    """(``coplan view PLAN`` refused it; ``coplan.view(plan)`` showed the shipped problem of the
    same name with a warning, though its text -- here its clearance -- is not the one planned.)
    Both follow one rule (``coplan.problem.recorded.recorded_problem``)."""
    twin = tmp_path / "twin.yaml"
    twin.write_text(CROSSING.read_text().replace("clearance: 0.05", "clearance: 0.06"))
    coplan.solve(load_problem(twin), planner="coordinated", out_dir=tmp_path / "run")
    twin.unlink()
    plan_json = tmp_path / "run" / "plan.json"
    with pytest.raises(coplan.PlanFileError, match="which is gone; the shipped problem 'crossing-paths' is another text"):
        coplan.view(plan_json)
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["view", str(plan_json), "--out", str(tmp_path / "v.html")])
    assert r.exit_code == 2 and "is another text" in " ".join(r.output.split()), r.output
    assert not (tmp_path / "v.html").exists()


def test_view_of_a_plan_of_a_problem_built_in_python_says_it_shows_the_shipped_one():
    """(From a user's trial: coplan.view(plan) of a problem changed in Python showed the shipped
    problem of the same name without a word, where coplan view notes it.) A UserWarning says so;
    the SolveResult, which carries its problem, shows it silently."""
    import dataclasses
    import warnings

    q = load_problem("crossing_paths")
    moved = dataclasses.replace(q, arms=(q.arms[0], dataclasses.replace(q.arms[1], base=(0.85, 0.0), bin=(0.85, -0.5))))
    res = coplan.solve(moved, planner="coordinated")
    with pytest.warns(UserWarning, match="records no problem file: taken to be the shipped problem 'crossing-paths'"):
        coplan.view(res.plan)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_viewer_data(coplan.view(res).page)["problem"]["arms"][1]["base"][0] == pytest.approx(0.85)


def test_view_compare_takes_a_plan_csv_and_refuses_a_plan_of_another_problem_text(tmp_path):
    """(From a user's trial.) ``--compare`` with a plan.csv (it names no problem) was refused as
    "a plan of ''"; a plan planned from another text of the same problem (a longer dwell) was
    checked against the first plan's problem and shown as failed."""
    from coplan.problem import default_problem_path

    gh = load_problem(default_problem_path())
    coplan.solve(gh, planner="coordinated", out_dir=tmp_path / "gh")
    runner = CliRunner(env={"COLUMNS": "300"})
    r = runner.invoke(app, ["view", str(tmp_path / "gh" / "plan.json"), "-p", str(gh.source), "--compare",
                            str(tmp_path / "gh" / "plan.csv"), "-o", str(tmp_path / "a.html")])
    assert r.exit_code == 0 and (tmp_path / "a.html").exists(), r.output
    slow = tmp_path / "slow.yaml"
    slow.write_text(Path(gh.source).read_text().replace("pick_dwell: 0.3", "pick_dwell: 0.6"))
    coplan.solve(load_problem(slow), planner="coordinated", out_dir=tmp_path / "slow")
    r = runner.invoke(app, ["view", str(tmp_path / "slow" / "plan.json"), "--compare", str(tmp_path / "gh" / "plan.json"),
                            "-o", str(tmp_path / "b.html")])
    assert r.exit_code == 2 and "same problem text" in r.output and not (tmp_path / "b.html").exists(), r.output


def test_notebook_view_is_an_inline_page(greenhouse):
    prob, coord, heur = greenhouse
    v = coplan.view(coord, compare=heur)
    frame = v._repr_html_()
    assert frame.startswith("<iframe srcdoc=") and "&lt;script" in frame and "<script" not in frame
    data = read_viewer_data(v.page)
    assert [p["planner"] for p in data["plans"]] == ["coordinated", "heuristic"]


def test_cli_view_and_solve_html(tmp_path):
    runner = CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None})
    out = tmp_path / "run"
    res = runner.invoke(app, ["solve", str(GREENHOUSE), "--planner", "coordinated", "--out", str(out), "--html"])
    assert res.exit_code == 0, res.output
    assert (out / "plan.html").is_file() and f"wrote             {out / 'plan.html'}" in res.output
    assert read_viewer_data((out / "plan.html").read_text())["plans"][0]["planner"] == "coordinated"
    heur = tmp_path / "heur"
    runner.invoke(app, ["solve", str(GREENHOUSE), "--planner", "heuristic", "--out", str(heur)])
    res = runner.invoke(app, ["view", str(heur / "plan.json"), "--compare", str(out / "plan.json"), "--out", str(tmp_path / "v.html")])
    assert res.exit_code == 0, res.output
    data = read_viewer_data((tmp_path / "v.html").read_text())
    assert [p["planner"] for p in data["plans"]] == ["heuristic", "coordinated"]
    res = runner.invoke(app, ["view", str(heur / "plan.json")])
    assert res.exit_code == 0 and (heur / "plan.html").is_file()
    res = runner.invoke(app, ["view", str(heur / "plan.json"), "--out", str(tmp_path / "v.txt")])
    # a usage error, as plot's and animate's --out of the wrong kind (it was exit 3, a bad input file)
    assert res.exit_code == 2 and ".html" in res.output and "Traceback" not in res.output
    # a plan of another problem to compare with is named by its file (the message named the option)
    single = tmp_path / "single"
    runner.invoke(app, ["solve", str(GREENHOUSE.with_name("single_arm.yaml")), "--planner", "coordinated", "--out", str(single)])
    res = runner.invoke(app, ["view", str(out / "plan.json"), "--compare", str(single / "plan.json"), "--out", str(tmp_path / "x.html")])
    said = " ".join(res.output.split())
    assert res.exit_code == 2 and f"--compare {single / 'plan.json'}: expected a plan of the same problem" in said, said
    # a plan file that says success, which the verifier fails: the page shows the verdict, and a note says so (as plot)
    doc = json.loads((heur / "plan.json").read_text())
    doc["status"] = "success"
    (tmp_path / "liar.json").write_text(json.dumps(doc))
    res = runner.invoke(app, ["view", str(tmp_path / "liar.json"), "--problem", str(GREENHOUSE), "--out", str(tmp_path / "l.html")])
    assert res.exit_code == 0 and "note: the plan file says success; verified, it is unsafe" in " ".join(res.output.split())
    assert read_viewer_data((tmp_path / "l.html").read_text())["plans"][0]["status"] == "unsafe"
    # one that claims nothing (no status key, as an external planner's): it "carries no verdict" (it said "says unverified")
    doc = json.loads((out / "plan.json").read_text())
    doc.pop("status")
    (tmp_path / "mute.json").write_text(json.dumps(doc))
    res = runner.invoke(app, ["view", str(tmp_path / "mute.json"), "--problem", str(GREENHOUSE), "--out", str(tmp_path / "m.html")])
    said = " ".join(res.output.split())
    assert res.exit_code == 0 and "note: the plan file carries no verdict (unverified); verified, it is success" in said, said


# --------------------------------------------------------------------------- in a real browser
@pytest.fixture(scope="module")
def browser():
    missing = None
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        missing = "Playwright is not installed (pip install playwright)"
    if missing is None and not Path(CHROMIUM).exists():
        missing = f"no Chromium at {CHROMIUM} (apt-get install chromium)"
    if missing is not None:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true and the browser tests cannot run: {missing}")
        pytest.skip(missing)
    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def pages(greenhouse, planted, tmp_path_factory):
    prob, coord, heur = greenhouse
    folder = tmp_path_factory.mktemp("viewer")
    _, plan, pver = planted
    return {
        "coord": write_html(folder / "coord.html", prob, coord.plan, verification=coord.verification),
        "heur": write_html(folder / "heur.html", prob, heur.plan, verification=heur.verification),
        "planted": write_html(folder / "planted.html", prob, plan, verification=pver),
        "compare": write_html(folder / "compare.html", prob, coord.plan, heur.plan),
    }


def _open(browser, path: Path, fragment: str = ""):
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    log = {"errors": [], "requests": []}
    page.on("console", lambda m: log["errors"].append(m.text) if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: log["errors"].append(str(e)))
    page.on("request", lambda r: log["requests"].append(r.url))
    page.goto(path.as_uri() + fragment)
    _wait_until(page, "window.coplanViewer !== undefined")
    return page, log


def _wait_until(page, expression: str, timeout: float = 15.0) -> None:
    """Poll ``expression`` in the page until it is true. Not ``page.wait_for_function``: when
    its first check is false it polls by compiling the predicate inside the page, which the
    viewer's content-security policy (no eval) refuses with an EvalError. ``page.evaluate``
    runs through the debugging protocol, outside the page's policy."""
    import time

    end = time.monotonic() + timeout
    while not page.evaluate(expression):
        if time.monotonic() > end:
            raise AssertionError(f"the page never made {expression!r} true within {timeout:g} s")
        page.wait_for_timeout(20)


def test_page_loads_without_errors_or_network(browser, pages, greenhouse):
    prob, _, heur = greenhouse
    for key in ("coord", "heur", "compare"):
        page, log = _open(browser, pages[key])
        page.wait_for_timeout(300)
        assert log["errors"] == [], log["errors"]
        assert log["requests"] == [pages[key].as_uri()], log["requests"]
        if key == "heur":  # every violation the verifier reports is on the timeline
            ver = heur.verification
            assert page.locator("svg.timeline .violation").count() == sum(len(v.arms) for v in ver.violations) > 0
            assert "FAILED verification" in page.locator(".panel h3").inner_text()
        page.close()


def _pixel(page, x, y):
    return page.evaluate("""([x, y]) => { const c = document.querySelector('canvas.cell'), r = c.getBoundingClientRect();
        const k = c.width / r.width, d = c.getContext('2d').getImageData(Math.round((x - r.left) * k), Math.round((y - r.top) * k), 1, 1).data;
        return [d[0], d[1], d[2]]; }""", [x, y])


def test_arms_are_drawn_where_the_plan_puts_them(browser, pages, greenhouse):
    prob, coord, _ = greenhouse
    arm = prob.arm("center")
    colour = np.array([int(h, 16) for h in re.findall("..", arm_colors(prob)["center"][1:])])
    shots, mids = [], []
    for t in (1.0, 5.0):
        page, _ = _open(browser, pages["coord"], f"#t={t}")
        assert page.evaluate("coplanViewer.time()") == pytest.approx(t)
        q = coord.plan.sample([t])["center"][0]
        elbow = np.add(arm.base, arm.links[0] * np.array([np.cos(q[0]), np.sin(q[0])]))
        mid = (np.asarray(arm.base) + elbow) / 2
        x, y = page.evaluate("([x, y]) => coplanViewer.clientPoint(0, x, y)", mid.tolist())
        px = np.array(_pixel(page, x, y))
        assert np.abs(px - colour).max() < 40, (t, px, colour)  # the link's core line, in the arm's colour
        mids.append((x, y))
        shots.append(page.locator("canvas.cell").screenshot())
        page.close()
    assert np.hypot(mids[0][0] - mids[1][0], mids[0][1] - mids[1][1]) > 20
    assert shots[0] != shots[1]


def test_play_advances_the_time_and_the_address(browser, pages):
    import time

    page, log = _open(browser, pages["coord"], "#t=2")
    start = time.monotonic()
    page.click("#play")
    page.wait_for_timeout(800)
    t, playing = page.evaluate("[coplanViewer.time(), coplanViewer.playing()]")
    assert 2.2 < t <= 2 + (time.monotonic() - start) + 0.05 and playing  # at 1x, never ahead of real time
    page.click("#play")
    t = page.evaluate("coplanViewer.time()")
    assert re.search(r"#t=([0-9.]+)$", page.url) and float(page.url.rsplit("=", 1)[1]) == pytest.approx(t, abs=1e-3)
    page.locator("#time").fill("7.5")
    assert page.evaluate("coplanViewer.time()") == pytest.approx(7.5) and page.url.endswith("#t=7.5")
    page.select_option("#speed", "8")  # 8x: the clock runs eight times faster than real time
    page.click("#play")
    page.wait_for_timeout(400)
    # (read at once: on a busy machine the 400 ms can outlast the plan, which then stops at its end --
    # and a click on play there would start it again from 0)
    t, playing, end = page.evaluate("[coplanViewer.time(), coplanViewer.playing(), coplanViewer.duration]")
    assert t > 7.5 + 8 * 0.2 and (playing or t == end)
    assert log["errors"] == []
    page.close()


def test_layers_change_the_picture(browser, pages):
    page, log = _open(browser, pages["coord"], "#t=2")
    cell = page.locator("canvas.cell")
    plain = cell.screenshot()
    for layer in ("#layer-manip", "#layer-reach"):
        page.locator(layer).check()
        shot = cell.screenshot()
        assert shot != plain, layer
        page.locator(layer).uncheck()
        assert cell.screenshot() == plain
    assert log["errors"] == []
    page.close()


def test_a_planted_violation_is_on_the_timeline_and_a_click_goes_there(browser, pages, planted):
    page, log = _open(browser, pages["planted"])
    marker = page.locator('svg.timeline .violation[data-kind="joint_limit"]')
    assert marker.count() == 1
    marker.locator("path").click()
    assert page.evaluate("coplanViewer.time()") == pytest.approx(6.0)
    assert float(page.locator("#time").input_value()) == pytest.approx(6.0)
    assert page.url.endswith("#t=6")
    marker.locator("path").hover()
    assert "joint_limit" in page.locator("#tip").inner_text()
    summary = page.locator("details.violations summary")  # Space on it opens the list (it played the plan)
    assert re.match(r"\d+ violations?: click one", summary.inner_text())
    summary.focus()
    page.keyboard.press(" ")
    assert page.evaluate("document.querySelector('details.violations').open")
    assert not page.evaluate("coplanViewer.playing()")
    page.evaluate("coplanViewer.setTime(0)")
    row = page.locator("tr.violation-row", has_text="joint_limit")  # by keyboard: focusable, Enter goes to its time
    assert row.locator("td").nth(5).inner_text() == "rad"  # its value's unit (the table gave none)
    row.focus()
    page.keyboard.press("Enter")
    assert page.evaluate("coplanViewer.time()") == pytest.approx(6.0) == float(row.get_attribute("data-t"))
    assert not page.evaluate("coplanViewer.playing()")
    assert page.evaluate("coplanViewer.placed(0)") == sum(  # the running count beside the clock: placed by then
        e.kind == EventKind.PLACE and e.t_end <= 6.0 for e in planted[1].events)
    page.keyboard.press("ArrowRight")  # the arrows stay the page's, a control focused (they did nothing after a click)
    assert page.evaluate("coplanViewer.time()") == pytest.approx(6.1)
    page.locator("#play").click()
    page.locator("#play").click()
    t0 = page.evaluate("coplanViewer.time()")
    page.keyboard.press("ArrowRight")
    assert page.evaluate("coplanViewer.time()") == pytest.approx(t0 + 0.1)
    assert log["errors"] == []
    page.close()


def _contrast(a, b) -> float:
    def lum(c):
        v = [x / 255 for x in c]
        v = [x / 12.92 if x <= 0.03928 else ((x + 0.055) / 1.055) ** 2.4 for x in v]
        return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]

    hi, lo = sorted((lum(a), lum(b)), reverse=True)
    return (hi + 0.05) / (lo + 0.05)


def _rgb(css: str) -> tuple[int, int, int]:
    if css.startswith("#"):
        h = "".join(c * 2 for c in css[1:]) if len(css) == 4 else css[1:]
        return tuple(int(h[i:i + 2], 16) for i in (0, 2, 4))
    return tuple(int(float(x)) for x in re.findall(r"[\d.]+", css)[:3])


def test_the_page_speaks_to_a_keyboard_and_a_screen_reader(browser, pages, greenhouse):
    """(From a user's trial of the page with a screen reader's eyes: the animation was a canvas with
    no text, the slider read "5.6", the charts read as a list of numbers, each violation row as
    one long button, a fruit's reason for being out of reach was in a hover tip only, and the
    fruit ids on the timeline (white on the arm's orange) and the arms' names (their colour on
    white) were 2.0-2.5:1 against the 4.5:1 text needs.)"""
    prob, coord, heur = greenhouse
    page, log = _open(browser, pages["coord"])
    page.evaluate("coplanViewer.setTime(6)")
    _wait_until(page, "document.querySelector('canvas.cell').getAttribute('aria-label').includes('t = 6.00 s')")
    canvas = page.locator("canvas.cell")
    placed = sum(e.kind == EventKind.PLACE and e.t_end <= 6.0 for e in coord.plan.events)
    assert canvas.get_attribute("role") == "img" and f"placed {placed}/" in canvas.get_attribute("aria-label")
    assert page.locator("#time").get_attribute("aria-valuetext") == f"6.00 s of {coord.plan.duration:.2f} s"
    for kind in ("timeline", "clearance"):
        svg = page.locator(f"svg.{kind}")
        assert svg.get_attribute("role") == "img" and len(svg.get_attribute("aria-label")) > 30
    out = [f for f in prob.fruits if f.id not in prob.reachable_ids()]
    items = page.locator("details.unreachable-list li")
    assert out and items.count() == len(out) and all(f.id in items.nth(k).text_content() for k, f in enumerate(out))
    # every fruit id on a bar and every arm's name reads at 4.5:1 at least
    pairs = page.evaluate("""Array.from(document.querySelectorAll('svg.timeline text[fill]'))
        .map(function (t) { return [t.getAttribute('fill'), t.previousElementSibling.getAttribute('fill')]; })""")
    assert pairs and all(_contrast(_rgb(a), _rgb(b)) >= 4.5 for a, b in pairs), pairs
    assert log["errors"] == []
    page.close()
    page, log = _open(browser, pages["heur"])  # (the heuristic's plan fails: a table of violations)
    rows = page.locator("tr.violation-row")
    assert rows.count() == len(heur.verification.violations) and rows.first.get_attribute("role") is None
    assert "Enter" in page.locator("table.vtable caption").text_content()
    assert log["errors"] == []
    page.close()


def test_hover_shows_a_fruits_facts(browser, pages, greenhouse):
    prob, coord, _ = greenhouse
    pick = min((e for e in coord.plan.events if e.kind == EventKind.PICK), key=lambda e: e.t_start)
    place = next(e for e in coord.plan.events if e.kind == EventKind.PLACE and e.fruit == pick.fruit)
    page, _ = _open(browser, pages["coord"], "#t=0")
    x, y = page.evaluate("([x, y]) => coplanViewer.clientPoint(0, x, y)", list(prob.fruit(pick.fruit).position))
    page.mouse.move(x, y)
    tip = page.locator("#tip")
    tip.wait_for(state="visible")
    text = tip.inner_text()
    assert f"fruit {pick.fruit}" in text and f"arm: {pick.arm}" in text
    assert f"pick {pick.t_start:.2f}\u2013{pick.t_end:.2f} s" in text and f"place {place.t_start:.2f}\u2013{place.t_end:.2f} s" in text
    # an arm: its phase, joint values and replay velocities at the current time
    t = 5.003
    page.evaluate(f"coplanViewer.setTime({t})")
    arm = prob.arm("center")
    k = int(np.floor(t / coord.plan.dt))
    q = coord.plan.sample([t])["center"][0]
    qd = (coord.plan.q["center"][k + 1] - coord.plan.q["center"][k]) / coord.plan.dt
    assert np.abs(qd).max() > 0.05  # the arm moves then
    elbow = np.add(arm.base, arm.links[0] * np.array([np.cos(q[0]), np.sin(q[0])]))
    x, y = page.evaluate("([x, y]) => coplanViewer.clientPoint(0, x, y)", ((np.asarray(arm.base) + 2 * elbow) / 3).tolist())
    page.mouse.move(x, y)
    _wait_until(page, "document.getElementById('tip').textContent.includes('arm center')")
    text = tip.inner_text()
    assert f"q1 = {q[0]:.4f} rad" in text and f"q2 = {q[1]:.4f} rad" in text
    assert f"q\u03071 = {qd[0]:.3f} rad/s" in text and f"q\u03072 = {qd[1]:.3f} rad/s" in text
    # every line inside the box (a long one ran out of it, off the screen: the arm's fruit, placed so far)
    assert page.evaluate("Array.from(document.querySelectorAll('#tip .r')).every(r => r.scrollWidth <= r.clientWidth + 1)")
    # an unreachable fruit says why
    x, y = page.evaluate("([x, y]) => coplanViewer.clientPoint(0, x, y)", list(prob.fruit("f01").position))
    page.mouse.move(x, y)
    assert "unreachable: " in tip.inner_text()
    page.close()


def test_a_resting_pointer_s_tip_follows_the_clock(browser, pages, greenhouse):
    """The tip is worked out again from every new drawing: with the pointer left on a moving
    arm, changing the time (keys, playback, setTime) shows the joints at the new time -- not
    what was under the pointer before (which also made the hover test fail now and then: a
    mouse move arriving before the next frame found the arm where it had been)."""
    prob, coord, _ = greenhouse
    page, _ = _open(browser, pages["coord"], "#t=5.003")
    arm = prob.arm("center")
    q = coord.plan.sample([5.003])["center"][0]
    elbow = np.add(arm.base, arm.links[0] * np.array([np.cos(q[0]), np.sin(q[0])]))
    x, y = page.evaluate("([x, y]) => coplanViewer.clientPoint(0, x, y)", ((np.asarray(arm.base) + 2 * elbow) / 3).tolist())
    page.mouse.move(x, y)
    _wait_until(page, "document.getElementById('tip').textContent.includes('arm center')")
    t2 = 5.013  # the arm moves by a few mrad: the pointer stays on its first link
    q2 = coord.plan.sample([t2])["center"][0]
    assert abs(q2[0] - q[0]) > 1e-3
    page.evaluate(f"coplanViewer.setTime({t2})")  # no mouse event
    _wait_until(page, f"document.getElementById('tip').textContent.includes('q1 = {q2[0]:.4f} rad')")
    page.close()


def test_compare_view_shows_two_cells_on_one_clock(browser, pages, greenhouse):
    _, coord, heur = greenhouse
    page, log = _open(browser, pages["compare"], "#t=3")
    assert page.locator("canvas.cell").count() == 2 and page.locator("section.panel").count() == 2
    head = page.locator("#summary").inner_text()
    assert f"{coord.plan.metrics['makespan']:.3f} s" in head and f"{heur.plan.metrics['makespan']:.3f} s" in head
    assert f"lower bound {coord.plan.metrics['lower_bound']:.3f} s" in head
    assert float(page.locator("#time").get_attribute("max")) == pytest.approx(max(coord.plan.duration, heur.plan.duration))
    a, b = (page.locator("canvas.cell").nth(k).screenshot() for k in range(2))
    assert a != b  # two plans, two pictures at the same instant
    assert log["errors"] == []
    page.close()


# --------------------------------------------------------------------------- a row
@pytest.fixture(scope="module")
def row_page(tmp_path_factory):
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    prob = parse_problem(to_yaml(gantry_row(length=12.0, density=3.0, seed=3)))
    res = coplan.solve(prob, stops="fewest")
    return prob, res, write_html(tmp_path_factory.mktemp("row") / "row.html", prob, res.plan, verification=res.verification)


def test_the_row_view_follows_the_carriage(browser, row_page):
    """The cell is drawn where the carriage is: at a time the carriage moves, the page's carriage
    equals the plan's and an arm's link is drawn at its base shifted by it; the strip of the whole
    row is there; nothing is fetched."""
    prob, res, path = row_page
    plan = res.plan
    moving = np.flatnonzero(np.abs(np.diff(plan.gantry_x)) > 1e-9)
    t = float(plan.time[moving[len(moving) // 2]])
    page, log = _open(browser, path, f"#t={t}")
    x = float(np.interp(t, plan.time, plan.gantry_x))
    assert page.evaluate("coplanViewer.carriage(0)") == pytest.approx(x, abs=0.02)
    assert page.locator("canvas.rowstrip").count() == 1 and page.locator("canvas.rowstrip").bounding_box()["height"] > 100
    head = " ".join(page.locator("section.panel h3").first.inner_text().split())
    r = plan.metrics["row"]
    assert f"row time {plan.metrics['makespan']:.3f} s" in head and f"{r['fruit_per_hour']:.0f} fruit/h" in head, head
    assert f"{r['stops']} stop" in head and "% of the harvestable fruit harvested" in head, head
    arm = prob.arms[1]
    q = plan.sample([t])[arm.name][0]
    base = np.array([arm.base[0] + x, arm.base[1]])
    elbow = base + arm.links[0] * np.array([np.cos(q[0]), np.sin(q[0])])
    cx, cy = page.evaluate("([x, y]) => coplanViewer.clientPoint(0, x, y)", ((base + elbow) / 2).tolist())
    colour = np.array([int(h, 16) for h in re.findall("..", arm_colors(prob)[arm.name][1:])])
    assert np.abs(np.array(_pixel(page, cx, cy)) - colour).max() < 40
    assert log["errors"] == []
    assert len(log["requests"]) == 1 and log["requests"][0].startswith(path.as_uri())  # the page itself, nothing else
    page.close()


def test_a_row_plan_file_s_grower_figures_are_shown_as_measured(row_page):
    """(From a new user's trial: a plan.json edited to say 9999 fruit/h and a row time of 300 s
    -- the page's note said "the measured figures are shown" beside the file's 9999 fruit/h, and a
    plan whose events for some fruit were cut said 100 % harvested; the gantt plot's title too.)"""
    from coplan.cli.figures import checked
    from coplan.plan import plan_from_dict
    from coplan.viz.viewer import viewer_data

    prob, res, _ = row_page
    doc = res.plan.to_dict()
    doc["metrics"]["row"] = dict(doc["metrics"]["row"], fruit_per_hour=9999.0, row_time=300.0)
    cut = sorted({e["fruit"] for e in doc["events"]})[:3]
    doc["events"] = [e for e in doc["events"] if e["fruit"] not in cut]
    lie = plan_from_dict(json.loads(json.dumps(doc)))
    ver = verify(prob, lie)
    got, span = ver.measured["harvested"], ver.measured["makespan"]
    assert got == res.plan.metrics["harvested"] - 3
    row = viewer_data(prob, [lie], [ver])["plans"][0]["row"]
    assert row["fruit_per_hour"] == pytest.approx(3600 * got / span) and row["row_time"] == pytest.approx(span)
    assert row["share_harvested"] == pytest.approx(got / res.plan.metrics["row"]["harvestable"]) and row["share_harvested"] < 1
    checked(prob, lie)  # what the CLI's figures draw (the gantt plot's title said 9999 fruit/h)
    assert lie.metrics["row"]["fruit_per_hour"] == pytest.approx(3600 * got / span) and lie.metrics["harvested"] == got


def test_a_row_plan_s_stops_and_bound_in_the_viewer_data():
    """The row strip's stops are where the carriage stood still for a pick: as many as the stop
    rule made stop and go, none on the move at a constant speed; a live row's plan (no row
    metrics of its own) is shown against the row's lower bound, not a cell's."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem
    from coplan.allocate.row_bound import row_bounds
    from coplan.row.continuous import MovingOptions
    from coplan.row.live import LiveRowOptions, run_live_row
    from coplan.viz.viewer import viewer_data

    prob = parse_problem(to_yaml(gantry_row(length=10.0, density=3.0, seed=3)))
    stop = coplan.solve(prob, stops="fewest")
    moving = coplan.solve(prob, gantry="continuous", options=MovingOptions(profile="constant", level=0.2))
    data = viewer_data(prob, [stop.plan, moving.plan])
    assert len(data["problem"]["row"]["stops"][0]) == stop.plan.metrics["row"]["stops"]
    on_move = data["problem"]["row"]["stops"][1]  # (only where the carriage stood: its end, a hold)
    picks = sum(e.kind == EventKind.PICK for e in moving.plan.events)
    x = moving.plan.gantry_x
    rest = x[1:][np.abs(np.diff(x)) < 1e-12]
    assert sum(len(s["fruit"]) for s in on_move) < picks / 2
    assert all(np.abs(rest - s["x"]).min() < 1e-9 for s in on_move)
    # on the move those are rests, not stops (the strip said "1 stop" where the summary says 0)
    assert data["problem"]["row"]["moving"] == [False, True]
    # a grower's figures beside each plan, as the summary gives them
    for p, res in zip(data["plans"], (stop, moving)):
        r = res.plan.metrics["row"]
        assert p["row"] == {k: r[k] for k in ("mode", "fruit_per_hour", "share_harvested", "row_time", "stops")}
    # why a fruit was left: the planner's reason, shown on hover (it said only "not harvested by this plan")
    dense = parse_problem(to_yaml(gantry_row(length=10.0, n_arms=3, density=6.0, seed=1)))
    fast = coplan.solve(dense, gantry="continuous", options=MovingOptions(profile="constant", level=0.3))
    left = fast.plan.solver["row"]["left_out"]
    got = {e.fruit for e in fast.plan.events}
    assert [f for f in left if f not in got], "the fast row should leave fruit out"
    assert viewer_data(dense, [fast.plan])["plans"][0]["left_out"] == left
    # which plan moved how: in each panel's label and the page's title (both were "coordinated")
    assert [p["label"] for p in data["plans"]] == ["coordinated (stop and go, fewest stops)", "coordinated (on the move)"]
    assert [p["planner"] for p in data["plans"]] == ["coordinated", "coordinated"]
    from coplan.viz.viewer import render_html
    page = render_html(prob, stop.plan, compare=moving.plan)
    assert "coordinated (stop and go, fewest stops) vs coordinated (on the move)</title>" in page
    live = run_live_row(prob, LiveRowOptions(speed=0.2, seed=1))
    bound = row_bounds(prob).any_plan
    assert viewer_data(prob, [live.plan])["lower_bound"] == pytest.approx(bound)
    assert live.plan.metrics["makespan"] >= bound - 1e-6 and live.plan.metrics["lower_bound"] == pytest.approx(bound)


def test_notebook_view_of_a_row_plan_file_finds_its_problem(tmp_path):
    """(coplan.view(load_plan('plan.json')) of a row plan asked for a shipped cell's name; the
    CLI found the row from the file the plan records, or the shipped rows.)"""
    from coplan.generate import gantry_row, to_yaml
    from coplan.plan import load_plan
    from coplan.problem.load import shipped_rows

    f = tmp_path / "short.yaml"
    f.write_text(to_yaml(gantry_row(length=6.0, density=2.0, seed=1, name="short")))
    coplan.solve(f, stops="fewest", out_dir=tmp_path / "run")
    plan = load_plan(tmp_path / "run" / "plan.json")
    assert read_viewer_data(coplan.view(plan).page)["problem"]["name"] == "short"  # the file it records
    f.write_text(f.read_text() + "# changed since\n")
    with pytest.raises(coplan.errors.PlanFileError, match="which has changed since"):
        coplan.view(plan)
    sparse = next(p for p in shipped_rows() if p.stem == "sparse_row")
    plan.problem_file, plan.problem = None, load_problem(sparse).name  # a shipped row, by its name (said)
    with pytest.warns(UserWarning, match="taken to be the shipped problem 'sparse-row'"):
        assert read_viewer_data(coplan.view(plan).page)["problem"]["name"] == "sparse-row"


def test_a_plan_the_verifier_fails_is_never_shown_as_a_success(planted, tmp_path):
    """(The viewer, `coplan plot` and `coplan animate` took the status from the file: "success"
    beside "FAILED verification".)"""
    from coplan.viz.viewer import viewer_data

    prob, plan, ver = planted
    assert plan.status.value == "success" and not ver.passed  # the file's word, and the verdict
    assert viewer_data(prob, [plan], [ver])["plans"][0]["status"] == "unsafe"
    path = tmp_path / "planted.json"
    plan.save(path)  # (saved as it is, unverified: its verdict was of another motion) -- a file that says success:
    path.write_text(path.read_text().replace('"status":"unverified"', '"status":"success"', 1))
    for cmd in (["plot", str(path), "--kind", "gantt", "-o", str(tmp_path / "g.png")],
                ["view", str(path), "-o", str(tmp_path / "v.html")]):
        res = CliRunner().invoke(app, cmd)
        assert res.exit_code == 0, res.output
    res = CliRunner().invoke(app, ["plot", str(path), "--kind", "gantt", "-o", str(tmp_path / "g2.png")])
    said = " ".join(res.output.split())
    assert "the plan file says success; verified, it is unsafe (" in said and "joint_limit" in said
    assert '"status":"unsafe"' in (tmp_path / "v.html").read_text()


def test_view_open_without_a_browser_says_where_the_page_is(tmp_path, monkeypatch):
    """(``coplan view --open`` with no browser wrote the page, opened nothing and said nothing.)"""
    import webbrowser

    monkeypatch.setattr(webbrowser, "open", lambda url: False)
    runner = CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None})
    out = tmp_path / "run"
    assert runner.invoke(app, ["solve", str(GREENHOUSE), "--planner", "coordinated", "--out", str(out)]).exit_code == 0
    res = runner.invoke(app, ["view", str(out / "plan.json"), "--open", "--out", str(tmp_path / "v.html")])
    said = " ".join(res.output.split())
    assert res.exit_code == 0 and "no web browser could be opened here" in said and (tmp_path / "v.html").as_uri() in said


def test_a_plan_viewed_against_another_problem_text_says_so_and_counts_a_missed_pick_unharvested(tmp_path):
    """(``coplan view plan.json --problem OTHER``, whose fruit a1 had moved: no word that the file
    differed, where ``coplan verify`` says it, and "fruit harvested 4/4" beside the pick_missed
    verdict.)"""
    mine = tmp_path / "crossing.yaml"
    mine.write_text(CROSSING.read_text())
    coplan.solve(load_problem(mine), planner="coordinated", out_dir=tmp_path / "run")
    moved = CROSSING.read_text().replace("{id: a1, position: [0.45, 0.35]}", "{id: a1, position: [0.40, 0.55]}")
    other = tmp_path / "other.yaml"
    other.write_text(moved)
    assert load_problem(other).fruit("a1").position != load_problem(mine).fruit("a1").position
    r = CliRunner().invoke(app, ["view", str(tmp_path / "run" / "plan.json"), "--problem", str(other), "--out",
                                 str(tmp_path / "v.html")])
    said = " ".join(r.output.split())
    assert "is not that text (another file, or changed since: its sha256 differs)" in said, said
    data = read_viewer_data((tmp_path / "v.html").read_text())
    (pl,) = data["plans"]
    assert any(v["kind"] == "pick_missed" and v["fruit"] == "a1" for v in pl["violations"])
    assert pl["harvested"] == 3, pl["harvested"]  # a1's pick missed it


def test_a_live_rows_headline_gives_its_row_figures():
    """(A live row's viewer said only its makespan: no fruit per hour, share or stops, which a
    planned row's headline gives.)"""
    from coplan.generate import gantry_row, to_yaml
    from coplan.kinds import GantryMode
    from coplan.row.live import run_live_row
    from coplan.row.sensing import LiveRowOptions

    row = coplan.parse_problem(to_yaml(gantry_row(length=6.0, density=1.0, seed=1)))
    res = run_live_row(row, LiveRowOptions(mode=GantryMode.STOP_AND_GO, seed=1))
    rw = read_viewer_data(render_html(row, res.plan))["plans"][0]["row"]
    assert rw["fruit_per_hour"] == pytest.approx(res.metrics["fruit_per_hour"]) and rw["stops"] == res.metrics["stops"]
    assert rw["share_harvested"] == pytest.approx(res.metrics["harvested"] / res.plan.metrics["reachable"])
    assert rw["row_time"] == pytest.approx(res.metrics["row_time"])  # (the headline gave the last place as the row time)


def test_view_checks_its_arguments_when_called():
    """(From a trial: height="big" failed only when the page was shown, display_rate="30" and
    problem=3 raised from inside.)"""
    res = coplan.solve("crossing_paths", planner="heuristic")
    for kw, err, words in (({"height": "big"}, ValueError, "height: expected a whole number of pixels"),
                           ({"height": -5}, ValueError, "height: expected a whole number of pixels"),
                           ({"display_rate": "30"}, ValueError, "display_rate: expected frames per second"),
                           ({"problem": 3}, TypeError, "problem: expected a Problem")):
        with pytest.raises(err, match=words):
            coplan.view(res, **kw)
    assert coplan.view(res, height=600, display_rate=25)._repr_html_().startswith("<iframe srcdoc=")
