"""Stage 4, verification: the independent check of any plan (coplan's or anyone's).

- :mod:`.verifier`: :func:`verify` (``coplan.verify.verify``): limits, picks and places,
  clearance, FCL cross-check; its result types
- :mod:`.clearance`: exact link distances with a certified bound between samples (its own
  segment distance, on purpose independent of the planners')
- :mod:`.fclcheck`: the FCL cross-check of the clearance
- :mod:`.verdict`: the result types (``Verification``, ``Violation``, ``VerifyOptions``)
- :mod:`.infer`: pick/place events inferred from the motion when a plan declares none

It imports nothing from :mod:`coplan.planners`.

``coplan.verify`` names this package and the stage's entry function at once, as
``coplan.allocate`` does: calling the package calls :func:`verify` (``coplan.verify(problem,
plan)``; it said "'module' object is not callable").
"""

import sys as _sys
import types as _types

from .verdict import Verification, VerifyOptions, Violation, ViolationKind
from .verifier import clearance_profile, verify

__all__ = ["Verification", "VerifyOptions", "Violation", "ViolationKind", "clearance_profile", "verify"]


class _Stage(_types.ModuleType):
    """This package, callable as its entry function (module docstring)."""

    def __call__(self, *args, **kwargs) -> Verification:
        return verify(*args, **kwargs)


_sys.modules[__name__].__class__ = _Stage
