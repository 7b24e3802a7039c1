"""Harvesting from a live vision feed: online re-planning with noisy, late-arriving fruit.

- :mod:`coplan.live.feed`: the feed file (detection events), validation, the seeded generator.
- :mod:`coplan.live.cell`: :class:`~coplan.live.cell.LiveCell`, the planner object for a real
  cell (detections and the current time in, committed motion out).
- :mod:`coplan.live.records`: its options and records (:class:`~coplan.live.records.LiveOptions`,
  tracks, re-plans), re-exported by :mod:`coplan.live.cell`.
- :mod:`coplan.live.motion`: cutting a plan at a rest instant; re-planned approaches (Ruckig).
- :mod:`coplan.live.sim`: the simulated cell (``coplan run``): executed plan, verification, run.json.

The ``coplan feed`` and ``coplan run`` commands are in :mod:`coplan.cli.live`.

This package's ``__init__`` imports nothing (``coplan --help`` stays light): import from the
modules.
"""
