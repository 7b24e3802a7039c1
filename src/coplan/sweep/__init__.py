"""Design sweeps: many problems solved on Dask, one table row per problem.

* :mod:`coplan.sweep.spec` -- the sweep file (validated with key paths and lines) and its
  expansion into concrete problems (:func:`load_sweep`, :class:`SweepSpec`, :class:`SweepItem`);
* :mod:`coplan.sweep.run` -- :func:`run_sweep`: a ``LocalCluster`` of worker processes (one
  thread each) or an existing scheduler; retries, time limits, resume by key;
* :mod:`coplan.sweep.cluster` -- its Dask side: connecting and closing, Ctrl-C, the wait for results;
* :mod:`coplan.sweep.table` -- the row schema, the row journal and the Parquet/CSV table;
* :mod:`coplan.sweep.report` -- :func:`sweep_report`: counts, medians, worst cases, figures.

The ``coplan sweep`` and ``coplan sweep-report`` commands are in :mod:`coplan.cli.sweep`.
This package's ``__init__`` imports nothing heavy (``coplan --help`` stays light).
"""

_EXPORTS = {"load_sweep": "spec", "parse_sweep": "spec", "SweepSpec": "spec", "SweepItem": "spec", "run_sweep": "run",
            "read_table": "table", "sweep_report": "report"}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    # the entry points (``from coplan.sweep import run_sweep``), imported when first used
    import importlib

    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
