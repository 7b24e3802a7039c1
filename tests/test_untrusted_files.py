"""Untrusted strings and plan files (issue 10): ids and names kept exactly as written (no YAML
1.1 coercion), CSV quoting of names, the plan-file size cap, ``plan.csv`` read back."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from coplan.errors import PlanFileError, ProblemError
from coplan.planners.heuristic import plan_heuristic
from coplan.plan import MAX_PLAN_BYTES, load_plan
from coplan.plancsv import CSV_PLANNER, csv_header
from coplan.problem import default_problem_path, parse_problem

PROBLEMS = default_problem_path().parent
SINGLE = (PROBLEMS / "single_arm.yaml").read_text()


def _with_ids(arm_name: str, problem_name: str, ids: list[str]) -> str:
    text = SINGLE.replace("name: single-arm", f"name: {problem_name}").replace("  - name: arm", f"  - name: {arm_name}")
    fruits = "".join(f"  - {{id: {fid}, position: [1.2, {0.8 - 0.05 * k:.2f}]}}\n" for k, fid in enumerate(ids))
    return text.replace("  - {id: pick, position: [1.2, 0.8]}\n", fruits)


# YAML 1.1 would read these as false, 16, 10 (octal), 1000, 750 (sexagesimal), a date, true
COERCED = ["no", "0x10", "012", "1_000", "12:30", "2024-01-01", "on", "1e3", "1.50", "+7"]


def test_ids_and_names_are_kept_exactly_as_written() -> None:
    p = parse_problem(_with_ids("yes", "off", COERCED))
    assert p.name == "off"
    assert [a.name for a in p.arms] == ["yes"]
    assert [f.id for f in p.fruits] == COERCED


def test_ids_that_only_coercion_made_equal_are_distinct_and_real_repeats_still_clash() -> None:
    # 0x10 and 16 were both the integer 16 (reported as a duplicate); as written they differ
    p = parse_problem(_with_ids("arm", "p", ["0x10", "16", "1.0", "1.00"]))
    assert [f.id for f in p.fruits] == ["0x10", "16", "1.0", "1.00"]
    with pytest.raises(ProblemError) as e:
        parse_problem(_with_ids("arm", "p", ["no", "'no'"]))
    assert [i.path for i in e.value.issues] == ["fruits[1].id"]
    assert "expected a unique fruit id, found 'no' again" in e.value.issues[0].message


def test_a_null_id_is_still_refused() -> None:
    with pytest.raises(ProblemError) as e:
        parse_problem(_with_ids("arm", "p", ["~"]))
    assert e.value.issues[0].path == "fruits[0].id" and "found null" in e.value.issues[0].message


def test_numbers_elsewhere_are_still_numbers() -> None:
    # keeping text is only for names and ids: a number written as 0x1 is still refused where a
    # float is expected only if it is not a number; links etc. are unaffected
    p = parse_problem(_with_ids("no", "p", ["f"]))
    assert p.arms[0].links == (1.0, 0.8) and p.task.pick_dwell == 0.3


@pytest.mark.parametrize("written, read", [("010", 10.0), ("0x10", 16.0), ("0o17", 15.0), ("8e1", 80.0), (".5", 0.5),
                                           ("+3", 3.0), ("1.5e+2", 150.0)])
def test_numbers_are_read_as_yaml_1_2_reads_them(written, read) -> None:
    """(YAML 1.1 read 010 as octal 8.)"""
    assert parse_problem(SINGLE.replace("pick_dwell: 0.3", f"pick_dwell: {written}")).task.pick_dwell == read


@pytest.mark.parametrize("written", ["1:30", "0_3", "1_000.5", "0b11"])
def test_yaml_1_1_number_forms_are_strings_refused_where_a_number_is_expected(written) -> None:
    """(``pick_dwell: 1:30`` was read as 90 s, base 60, and ``0_3`` as 3 s: a typo, a silent 10 x.)"""
    with pytest.raises(ProblemError, match=f"task.pick_dwell: expected a number, found string '{written}'"):
        parse_problem(SINGLE.replace("pick_dwell: 0.3", f"pick_dwell: {written}"))


def test_an_integer_of_hundreds_of_digits_is_refused_with_its_line_not_an_overflow() -> None:
    """(``links: [1000...0, 0.8]`` was an internal error: OverflowError, int too large to convert to float.)"""
    text = SINGLE.replace("links: [1.0, 0.8]", "links: [1" + "0" * 400 + ", 0.8]", 1)
    assert text != SINGLE
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "big.yaml")
    (issue,) = e.value.issues
    assert "expected a number coplan can hold, found an integer of 401 digits" in issue.message
    assert issue.line == next(i + 1 for i, ln in enumerate(text.splitlines()) if "0" * 400 in ln) and "links" in issue.path


@pytest.mark.parametrize("written", ["1e400", "-2.5e999"])
def test_a_number_beyond_a_float_s_range_is_refused_as_written_not_as_inf(written) -> None:
    """(``pick_dwell: 1e400`` became inf, and the message said "found number inf" of a value the
    file never held.) ``.inf`` itself is still infinity, refused by the key's own check."""
    with pytest.raises(ProblemError) as e:
        parse_problem(SINGLE.replace("pick_dwell: 0.3", f"pick_dwell: {written}"), "big.yaml")
    (issue,) = e.value.issues
    assert issue.path == "task.pick_dwell" and issue.line is not None
    assert f"expected a number coplan can hold, found {written} (beyond a float's range)" in issue.message
    with pytest.raises(ProblemError, match="task.pick_dwell: expected a finite number, found inf"):
        parse_problem(SINGLE.replace("pick_dwell: 0.3", "pick_dwell: .inf"))


def test_numbers_beyond_range_are_said_beside_the_file_s_other_mistakes() -> None:
    """(A ``1e400`` stopped reading the whole file: the other out-of-range numbers and every other
    mistake were said only once it was mended.) Each is said at its key path, with the rest."""
    text = (SINGLE.replace("pick_dwell: 0.3", "pick_dwell: 1e400")
            .replace("links: [1.0, 0.8]", "links: [1" + "0" * 40 + ", 0.8]", 1)
            .replace("place_dwell:", "place_dwel:", 1))
    assert text.count("1e400") == 1 and "0" * 40 in text and "place_dwel:" in text
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "big.yaml")
    said = {i.path: i.message for i in e.value.issues}
    assert "expected a number coplan can hold, found 1e400 (beyond a float's range)" in said["task.pick_dwell"]
    links = [p for p in said if p.startswith("arms[0].links")]
    assert links == ["arms[0].links[0]"] and "an integer of 41 digits" in said[links[0]]
    assert any("place_dwel" in p for p in said), said  # the typo, said in the same run
    assert not any("null" in m or "None" in m for m in said.values()), said  # (the placeholder is never shown)
    twice = SINGLE.replace("pick_dwell: 0.3", "pick_dwell: 1e400").replace("clearance: 0.05", "clearance: 0.05\n  clearance: 0.05")
    with pytest.raises(ProblemError) as e:  # (a duplicate key, refused before validation, hid it)
        parse_problem(twice, "big.yaml")
    assert {i.path for i in e.value.issues} >= {"task.pick_dwell", "task.clearance"}, e.value


# --------------------------------------------------------------------------- CSV
NASTY = ['a,b', 'say "hi"', "two\nlines", "car\rriage", "plain"]


def test_csv_header_quotes_names_and_round_trips() -> None:
    header = csv_header(NASTY)
    assert '"a,b_q1"' in header and '"say ""hi""_q1"' in header
    row = next(csv.reader(header.splitlines(keepends=True)))
    assert row == ["t"] + [f"{n}_q{k}" for n in NASTY for k in (1, 2)]


def test_plan_csv_with_hostile_arm_names_loads_back(tmp_path: Path, single_arm) -> None:
    plan = plan_heuristic(single_arm)
    q = plan.q["arm"]
    plan.q = {n: q + 0.01 * i for i, n in enumerate(NASTY)}
    paths = plan.save(tmp_path, "plan")
    back = load_plan(paths["csv"])
    assert list(back.q) == NASTY
    assert back.planner_name == CSV_PLANNER and back.events == [] and back.problem == ""
    np.testing.assert_allclose(back.time, plan.time, atol=1e-7)
    for n in NASTY:
        np.testing.assert_allclose(back.q[n], plan.q[n], atol=1e-7)
    # the JSON beside it holds the same names
    assert list(json.loads(paths["json"].read_text())["arms"]) == NASTY


@pytest.mark.parametrize("body, line, words", [
    ("x,arm_q1,arm_q2\n0,1,2\n", 1, "expected a header row 't,<arm>_q1,<arm>_q2,...', found first column 'x'"),
    ("t,arm_q1\n0,1\n", 1, "two columns per arm"),
    # (a column left out: which one, not "found 5 columns after t"; an export's not blamed on its valid columns)
    ("t,a_q1,a_q2,b_q1\n0,1,2,3\n", 1, "(two columns per arm), found it without 'b_q2'"),
    ("t,a_q1,a_q2,a_qd2,a_qdd1,a_qdd2\n" + ",".join(["0"] * 6) + "\n", 1,
     "expected an export's header row (t, per arm <arm>_q1 ... <arm>_qdd2, a row's carriage_x, carriage_v, carriage_a last), "
     "found it without 'a_qd1'"),
    ("t,a_q1,a_q2,a_qd1,a_qd2,a_qdd1,a_qdd2,carriage_v,carriage_a\n" + ",".join(["0"] * 9) + "\n", 1,
     "found it without 'carriage_x'"),
    ("t,arm_q1,other_q2\n0,1,2\n", 1, "expected a pair '<arm>_q1,<arm>_q2', found 'arm_q1', 'other_q2'"),
    ("arm,fruit,kind,t_start,t_end\nleft,f1,pick,0.1,0.6\n", 1, "found an export's events"),
    # (a column named twice: the message blamed the valid columns after it)
    ("t,a_q1,a_q2,a_qd1,a_qd2,a_qdd1,a_qdd2,a_q1,b_q2,b_qd1,b_qd2,b_qdd1,b_qdd2\n" + ",".join(["0"] * 13) + "\n", 1,
     "expected each column once in the header row, found 'a_q1' in columns 2, 8"),
    ("t,arm_q1,arm_q2\n0,1,2\n0.01,1,2,3\n", 3, "expected 3 values (t and two angles for each of 1 arm), found 4"),
    ("t,arm_q1,arm_q2\n0,1,2\n0.01,1,abc\n", 3, "expected numbers, found 'abc'"),
    ("t,arm_q1,arm_q2\n0,1,2\n0.01,1,nan\n", 3, "expected finite numbers, found nan"),
    ("t,arm_q1,arm_q2\n0,1,2\n0.01,1,2e5\n0.02,1,3e5\n", 3,
     "expected joint angles within +-1000 rad (coplan.plausible.MAX_PLAN_ANGLE), found 200000 (t = 0.010 s) and 1 more rows"),
    ("t,gantry_x,arm_q1,arm_q2\n0,0,1,2\n0.01,-1e300,1,2\n", 3,
     "expected carriage positions within +-10000 m (coplan.plausible.MAX_PLAN_COORD), found -1e+300 (t = 0.010 s)"),
    ("t,arm_q1,arm_q2\n0,1,2\n0.01,1,2\n0.03,1,2\n", 3, "expected a uniform grid with spacing 0.015 s, found a step of 0.01 s"),
    ("t,arm_q1,arm_q2\n0,1,2\n0.05,1,2\n", None, "expected a grid of 100 Hz or finer"),
])
def test_bad_plan_csv_is_refused_with_its_line(tmp_path: Path, body: str, line, words: str) -> None:
    p = tmp_path / "plan.csv"
    p.write_text(body)
    with pytest.raises(PlanFileError) as e:
        load_plan(p)
    it = e.value.issues[0]
    assert it.line == line and words in it.message, it
    if line == 1:  # the header row: named so (it was "<top>")
        assert it.path == "header" and "<top>" not in str(e.value), it
    if "numbers, found" in words or "within" in words:  # a bad value: its column's name is the key path
        assert it.path == ("gantry_x" if "carriage" in words else "arm_q2"), it


def test_plan_files_over_the_cap_are_refused_before_reading(tmp_path: Path, monkeypatch) -> None:
    def no_reading(*args, **kwargs):
        raise AssertionError("an oversized plan file was read")

    for name in ("big.json", "big.csv"):
        p = tmp_path / name
        with open(p, "wb") as f:  # a sparse file: no disk used
            f.truncate(MAX_PLAN_BYTES + 1)
        with monkeypatch.context() as m:
            m.setattr(Path, "read_text", no_reading)
            m.setattr(Path, "read_bytes", no_reading)
            with pytest.raises(PlanFileError) as e:
                load_plan(p)
        msg = e.value.issues[0].message
        assert f"expected a plan file of at most {MAX_PLAN_BYTES} bytes" in msg and f"found {MAX_PLAN_BYTES + 1} bytes" in msg
    small = tmp_path / "ok.json"
    small.write_text("{}")
    with pytest.raises(PlanFileError) as e:  # under the cap: read and checked as before
        load_plan(small)
    assert "bytes" not in str(e.value)


def test_a_plan_with_implausible_joint_angles_is_refused_with_the_row_and_time(tmp_path: Path, single_arm) -> None:
    """A plan angle beyond coplan.plausible.MAX_PLAN_ANGLE (1000 rad) is no motion: the plan is
    refused as a bad file (the key path, the row, its time and what was found), not verified into
    a clearance of -9e297 m printed in 300 digits. One just inside is verified as usual."""
    from coplan.plausible import MAX_PLAN_ANGLE
    from coplan.verify import verify

    plan = plan_heuristic(single_arm)
    name = next(iter(plan.q))
    q = np.array(plan.q[name], float)
    q[7, 0] = 1e300
    plan.q[name] = q
    with pytest.raises(PlanFileError) as e:
        verify(single_arm, plan)
    msg = str(e.value)
    assert f"arms.{name}.q[7]" in msg and "1e+300" in msg and f"{plan.time[7]:.3f} s" in msg and "1000 rad" in msg
    q[7, 0] = MAX_PLAN_ANGLE - 1.0
    assert not verify(single_arm, plan).passed  # far past the joint limit: verified, and refused as a plan


def test_a_row_plan_with_implausible_carriage_positions_is_refused_with_the_sample_and_time(tmp_path: Path) -> None:
    """(A plan.json with gantry.x[10] = 1e300 was verified into collisions between arms that ride
    on one carriage, from the rounding of their bases, and a 300-digit carriage speed.) Beyond
    coplan.plausible.MAX_PLAN_COORD the plan is refused as a bad file; a carriage merely off its
    rail is verified, and unsafe."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.plausible import MAX_PLAN_COORD
    from coplan.problem import parse_problem
    from coplan.row.plan import RowOptions, plan_row
    from coplan.verify import verify

    row = parse_problem(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)), "short.yaml")
    plan = plan_row(row, RowOptions(stops="fewest")).plan
    gx = np.array(plan.gantry_x, float)
    gx[10] = 1e300
    plan.gantry_x = gx
    with pytest.raises(PlanFileError) as e:
        verify(row, plan)
    msg = str(e.value)
    assert "gantry.x[10]" in msg and "1e+300" in msg and f"{plan.time[10]:.3f} s" in msg and "MAX_PLAN_COORD" in msg
    gx[10] = MAX_PLAN_COORD / 100  # off the rail, but a number: verified, and not safe
    assert not verify(row, plan).passed


def test_a_row_checked_against_a_plan_csv_without_its_carriage_column_says_which_column(tmp_path: Path) -> None:
    """(It read 'a plan for problem ''' and named plan.json's gantry.x only.)"""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem
    from coplan.row.plan import RowOptions, plan_row
    from coplan.verify import verify

    row = parse_problem(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)), "short.yaml")
    files = plan_row(row, RowOptions(stops="fewest")).plan.save(tmp_path)
    rows = list(csv.reader(files["csv"].open()))
    assert rows[0][1] == "gantry_x"
    bare = tmp_path / "bare.csv"
    with bare.open("w", newline="") as f:
        csv.writer(f).writerows([r[:1] + r[2:] for r in rows])
    with pytest.raises(PlanFileError) as e:
        verify(row, load_plan(bare))
    assert "in a plan.csv, the column gantry_x after t" in str(e.value) and "plan.csv replay (it names no problem)" in str(e.value)
    assert "problem ''" not in str(e.value)


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero on this system")
def test_a_device_is_refused_by_name_not_read_for_ever() -> None:
    """(``coplan check /dev/zero`` read until the kernel stopped it at 23 GB; a plan file given
    as a device was called a directory.)"""
    from coplan.problem import load_problem

    with pytest.raises(ProblemError, match="found a character device"):
        load_problem("/dev/zero")
    with pytest.raises(PlanFileError, match="found a character device"):
        load_plan("/dev/zero")


def test_a_pipe_is_read_no_further_than_the_cap(tmp_path: Path) -> None:
    """A pipe's size says nothing (0): it is read up to the cap and refused past it."""
    import os
    import threading

    from coplan.problem import load_problem
    from coplan.problem.yamlsafe import MAX_FILE_BYTES

    fifo = tmp_path / "p.yaml"
    os.mkfifo(fifo)

    def feed():
        with open(fifo, "wb") as f:
            try:
                f.write(b"#" * (MAX_FILE_BYTES + 10))
            except BrokenPipeError:
                pass

    t = threading.Thread(target=feed, daemon=True)
    t.start()
    with pytest.raises(ProblemError, match=f"at most {MAX_FILE_BYTES} bytes, found more"):
        load_problem(fifo)
    t.join(5)


def test_a_null_key_is_said_to_be_one_in_yaml_words() -> None:
    """(``~: 1`` was reported as 'None: expected a known key, found unknown key None'.)"""
    with pytest.raises(ProblemError) as e:
        parse_problem(SINGLE + "~: 1\n", "nk.yaml")
    assert "expected a key name, found null" in str(e.value) and "None" not in str(e.value)


@pytest.mark.parametrize("kind", ["json", "csv"])
def test_a_plan_from_a_pipe_is_read_as_a_problem_from_one_is(tmp_path: Path, kind: str, fifo) -> None:
    """(``cat plan.json | coplan verify P /dev/stdin`` was refused, "a pipe or other special
    file", while a problem from a pipe is read.) Read up to the cap, its kind from its text."""
    from coplan.planners.heuristic import plan_heuristic

    plan = plan_heuristic(parse_problem(SINGLE, "s.yaml"))
    plan.save(tmp_path / "run")
    got = load_plan(fifo((tmp_path / "run" / f"plan.{kind}").read_bytes()))
    assert got.events == (plan.events if kind == "json" else []) and abs(got.q["arm"] - plan.q["arm"]).max() < 1e-6
