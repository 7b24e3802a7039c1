"""What another CPU changes, in-process: NumPy's and libm's transcendental functions giving
results a few ulps away (imported as ``from other_cpu import another_cpu``).

Another machine runs the same code with other SIMD kernels (NumPy dispatches at run time:
AVX-512, AVX2 and baseline builds of ``arctan2``, ``sin``, ``exp`` ... differ in the last
bits) and another BLAS kernel. Here every such function returns its own result nudged by -2
to +2 ulps, chosen by a hash of the result's bits: the same input always gives the same
output, as on one machine, but not the output this machine computes. A plan whose choices
survive this is a plan whose choices do not depend on the CPU.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np

_UFUNCS = ("sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "exp", "log", "cbrt", "power", "hypot")
_MATH = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "exp", "log", "pow", "cbrt", "hypot")


def nudge(x, ulps: int = 2, salt: int = 0):
    """``x`` moved by a deterministic pseudo-random number of ulps in [-ulps, ulps]."""
    a = np.asarray(x)
    if a.dtype != np.float64:
        return x
    bits = np.array(a, copy=True).view(np.uint64)  # C order, any shape (0-d too)
    with np.errstate(over="ignore"):  # a multiplicative hash wraps around on purpose
        h = (bits ^ np.uint64(salt)) * np.uint64(0x9E3779B97F4A7C15)
    steps = ((h >> np.uint64(40)) % np.uint64(2 * ulps + 1)).astype(np.int64) - ulps
    out = np.where(np.isfinite(a) & (a != 0), a + steps * np.spacing(np.abs(a)), a)
    return out if isinstance(x, np.ndarray) else out[()]


def _wrap_ufunc(uf, salt):
    def f(*args, **kw):
        out = kw.pop("out", None)
        res = nudge(uf(*args, **kw), salt=salt)
        if out is not None:
            target = out[0] if isinstance(out, tuple) else out
            target[...] = res
            return target
        return res

    f.__name__ = uf.__name__
    return f


def _wrap_math(fn, salt):
    def f(*args):
        return float(nudge(np.float64(fn(*args)), salt=salt))

    return f


@contextlib.contextmanager
def another_cpu(monkeypatch, salt: int = 1):
    """Within the block, NumPy's and ``math``'s transcendental functions answer as another
    CPU's kernels might (see the module docstring); ``salt`` picks which other CPU."""
    with monkeypatch.context() as m:
        for name in _UFUNCS:
            m.setattr(np, name, _wrap_ufunc(getattr(np, name), salt))
        for name in _MATH:
            if hasattr(math, name):
                m.setattr(math, name, _wrap_math(getattr(math, name), salt))
        yield
