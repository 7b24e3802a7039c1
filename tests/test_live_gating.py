"""Filing detections into tracks (coplan.live.gating): the vectorised index against the rule
written out track by track, on seeded random bursts."""

from __future__ import annotations

import numpy as np
import pytest

from coplan.live.cell import LiveCell, LiveOptions, Track
from coplan.live.feed import Detection
from coplan.live.gating import TrackIndex
from coplan.problem import load_problem
from coplan.problem.load import default_problem_path


def reference_nearest(tracks: list[Track], p, sigma: float, t: float, gate: float):
    """The gating rule, one track at a time (LiveCell.merge's loop before the index)."""
    best, best_d = None, np.inf
    for tr in tracks:
        if tr.pick_end is not None and tr.pick_end <= t:
            continue
        dist = float(np.hypot(*(tr.position - np.asarray(p, float))))
        g = 3.0 * float(np.hypot(tr.sigma, sigma))
        if dist <= (g if tr.refined else max(gate, g)) and dist < best_d:
            best, best_d = tr, dist
    return best, best_d


@pytest.mark.parametrize("seed", range(5))
def test_index_finds_the_track_the_rule_names(seed: int) -> None:
    rng = np.random.default_rng(seed)
    tracks = [Track(f"t{i}", rng.uniform(0, 0.5, 2), float(rng.choice([0.001, 0.01, 0.03])), 0.0,
                    refined=bool(rng.random() < 0.3), pick_end=float(rng.uniform(0, 2)) if rng.random() < 0.3 else None)
              for i in range(60)]
    tracks.append(Track("twin", tracks[0].position.copy(), tracks[0].sigma, 0.0))  # a tie: the first opened wins
    index = TrackIndex(tracks, 0.03)
    hits = 0
    for _ in range(300):
        p, s, t = rng.uniform(-0.05, 0.55, 2), float(rng.choice([0.002, 0.01, 0.02])), float(rng.uniform(0, 2))
        ref, ref_d = reference_nearest(tracks, p, s, t, 0.03)
        i, d = index.nearest(p, s, t)
        assert (index.tracks[i] if i >= 0 else None) is ref
        assert d == ref_d
        hits += ref is not None
    assert 50 < hits < 300  # both outcomes were exercised


def test_index_grows_and_rereads_tracks() -> None:
    index = TrackIndex([], 0.03)
    assert index.nearest((0.0, 0.0), 0.01, 0.0) == (-1, np.inf)
    made = [Track(f"t{i}", np.array([float(i), 0.0]), 0.01, 0.0) for i in range(40)]
    for tr in made:
        index.add(tr)
    assert len(index) == 40 and index.nearest((39.0, 0.01), 0.01, 0.0)[0] == 39
    made[5].position = np.array([100.0, 0.0])
    index.update(5)
    assert index.nearest((5.0, 0.0), 0.01, 0.0)[0] == -1
    assert index.nearest((100.0, 0.0), 0.01, 0.0)[0] == 5


def test_a_burst_is_filed_as_one_detection_at_a_time_would_be() -> None:
    """observe() files a batch through one index kept current; merging the same detections one
    call at a time (a fresh index each) opens the same tracks with the same estimates."""
    problem = load_problem(default_problem_path())
    rng = np.random.default_rng(3)
    fruit = np.array([f.position for f in problem.fruits])
    dets = [Detection(0.0, f"d{i}", tuple(fruit[i % len(fruit)] + rng.normal(0, 0.01, 2)), 0.01) for i in range(3 * len(fruit))]
    dets += [Detection(0.0, f"x{i}", tuple(rng.uniform(fruit.min(0), fruit.max(0))), 0.01) for i in range(400)]
    one_by_one = LiveCell(problem, LiveOptions())
    for d in dets:
        one_by_one.merge(d)
    batch = LiveCell(problem, LiveOptions())
    batch.observe(0.0, dets)
    assert list(batch.tracks) == list(one_by_one.tracks)
    for k, tr in one_by_one.tracks.items():
        assert batch.tracks[k].detections == tr.detections
        assert np.array_equal(batch.tracks[k].position, tr.position) and batch.tracks[k].sigma == tr.sigma
    assert len(batch.merges) == len(dets) - len(batch.tracks) > 0
