"""When an arm holds on a target: the test a pick or a place must pass over each interval.

Shared by the verifier's event check (:mod:`coplan.verify.verifier`) and the events it infers
for a plan that declares none (:mod:`coplan.verify.infer`), so that an inferred event is one
the check then passes. Over a plan interval ``[t_k, t_k+1]`` the arm *holds* on the target when
its tip stays within ``position_tolerance`` of it -- ``(d_k + d_k+1 + V dt) / 2`` with ``V`` a
bound on the tip's speed inside the interval -- and is *still*:

* a cell's pick, or a place (over a bin, which rides with the carriage): no point of the arm
  faster than ``still_speed`` relative to the carriage (``V`` is that bound);
* a pick in a row (``row_frame``): the tip still in the row frame, the carriage's motion
  included (a pick on the move), its row-frame displacement over the interval below
  ``still_speed``; ``V`` adds the most its velocity ``J(q) qd`` can turn within the interval at
  constant joint rates, ``l1 w1^2 + l2 (w1 + w2)^2``, times ``dt / 2``.
"""

from __future__ import annotations

import numpy as np

from ..plan import grid_step
from .clearance import ArmMotion

__all__ = ["holds_on", "bin_track"]


def holds_on(m: ArmMotion, tip: np.ndarray, time: np.ndarray, target, n: np.ndarray, opts, row_frame: bool = False) -> np.ndarray:
    """(len(n),) whether arm ``m`` holds on ``target`` over each interval ``n`` (module docstring).

    ``tip``: (N, 2) the tip at every sample (in the row frame for a row); ``target``: a point, or
    one per sample (N, 2) (a bin riding on the carriage)."""
    target = np.asarray(target, float)
    dt = grid_step(time)
    t0, t1 = (target, target) if target.ndim == 1 else (target[n], target[n + 1])
    d0, d1 = np.hypot(*(tip[n] - t0).T), np.hypot(*(tip[n + 1] - t1).T)
    if not row_frame:
        speed = still = m.speed[n]
    else:
        w1, w12 = m.qd[n, 0], m.qd[n, 0] + m.qd[n, 1]
        still = np.hypot(*(tip[n + 1] - tip[n]).T) / dt
        speed = still + (m.links[0] * w1 ** 2 + m.links[1] * w12 ** 2) * dt / 2
    return ((d0 + d1 + speed * dt) / 2 <= opts.position_tolerance) & (still <= opts.still_speed)


def bin_track(bin_xy, gantry_x) -> np.ndarray:
    """Where an arm's bin is: the point ``bin_xy`` in a cell (``gantry_x`` None); in a row, (N, 2)
    at every sample, riding with the carriage (``bin_xy`` is in its frame)."""
    b = np.asarray(bin_xy, float)
    if gantry_x is None:
        return b
    x = np.asarray(gantry_x, float)
    return b + np.c_[x, np.zeros(x.size)]
