"""Solving a built :class:`coplan.planners.optimal.nlp_data.NLP` with IPOPT (MUMPS).

:func:`solve_nlp` expands the problem to SX with every pinned variable substituted, so IPOPT
only sees the free ones; an iteration callback (:class:`_Monitor`) keeps the best iterate,
honours Ctrl-C (within an iteration) and a wall-clock limit; IPOPT's return status is mapped
to :class:`~coplan.planners.optimal.nlp_data.SolverStatus`. IPOPT never reads an ``ipopt.opt`` file (the options
set ``option_file_name`` to empty).
"""

from __future__ import annotations

import signal
import time as _time

import casadi as ca
import numpy as np

from .nlp_data import NLP, NLPSolution, SolverStatus, map_status

__all__ = ["solve_nlp"]


class _Monitor(ca.Callback):
    """IPOPT iteration callback: keeps the best iterate, honours Ctrl-C and a wall-clock limit."""

    def __init__(self, nx: int, ng: int, lbg, ubg, lbx, ubx, deadline: float | None):
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.lbg, self.ubg, self.lbx, self.ubx = lbg, ubg, lbx, ubx
        self.deadline = deadline
        self.best: tuple[float, float, np.ndarray] | None = None
        self.interrupted = False
        self.iterations = 0
        self.construct("coplan_monitor", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = ca.nlpsol_out(i)
        if n in ("f",):
            return ca.Sparsity.scalar()
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        self.iterations += 1
        x = np.asarray(arg[0]).ravel()
        f = float(arg[1])
        gv = np.asarray(arg[2]).ravel()
        viol = max(
            float(np.max(np.maximum(self.lbg - gv, gv - self.ubg), initial=0.0)),
            float(np.max(np.maximum(self.lbx - x, x - self.ubx), initial=0.0)),
        )
        if self.best is None or (viol, f) < (self.best[0], self.best[1]) or (viol < 1e-6 and f < self.best[1]):
            self.best = (viol, f, x.copy())
        if self.deadline is not None and _time.perf_counter() > self.deadline:
            return [1]
        return [1 if self.interrupted else 0]


def solve_nlp(nlp: NLP, names: list[str], time_limit: float | None = None) -> NLPSolution:
    """Solve a built NLP with IPOPT. Ctrl-C stops within an iteration; the best iterate is kept.

    ``time_limit`` (s) bounds the wall-clock time (IPOPT's ``max_wall_time`` plus a check
    in the iteration callback).
    """
    t0 = _time.perf_counter()
    deadline = t0 + time_limit if time_limit is not None else None
    # expand the MX problem (built from mapped kernels) to SX, with every pinned variable
    # (dwells, rests, fixed boundary states) substituted as a constant: IPOPT only sees free ones
    free = np.flatnonzero(nlp.lbx != nlp.ubx)
    F = ca.Function("coplan_nlp", [nlp.problem["x"]], [nlp.problem["f"], nlp.problem["g"]]).expand()
    xf = ca.SX.sym("x", free.size)
    xfull = ca.SX(ca.DM(nlp.lbx))
    xfull[[int(i) for i in free]] = xf
    f_sx, g_sx = F(xfull)
    mon = _Monitor(free.size, nlp.lbg.size, nlp.lbg, nlp.ubg, nlp.lbx[free], nlp.ubx[free], deadline)
    opts = dict(nlp.options)
    opts["iteration_callback"] = mon
    if time_limit is not None:
        opts["ipopt.max_wall_time"] = max(float(time_limit), 1e-3)
    solver = ca.nlpsol("coplan", "ipopt", {"x": xf, "f": f_sx, "g": g_sx}, opts)
    args = dict(x0=nlp.x0[free], lbx=nlp.lbx[free], ubx=nlp.ubx[free], lbg=nlp.lbg, ubg=nlp.ubg)
    prev = signal.getsignal(signal.SIGINT)

    def on_sigint(signum, frame):
        mon.interrupted = True

    installed = False
    try:
        signal.signal(signal.SIGINT, on_sigint)
        installed = True
    except ValueError:  # not the main thread: Ctrl-C cannot be caught here
        pass
    try:
        res = solver.call(args)
    finally:
        if installed:
            signal.signal(signal.SIGINT, prev)
    stats = solver.stats()
    ipopt_status = str(stats.get("return_status", "unknown"))
    status = map_status(ipopt_status)
    if status == SolverStatus.INTERRUPTED and not mon.interrupted:
        status = SolverStatus.LIMIT_REACHED
    xv = np.asarray(res["x"]).ravel()
    g = np.asarray(res["g"]).ravel()
    if not status.converged and mon.best is not None:
        xv = mon.best[2]
        g = None
    x = nlp.lbx.copy()
    x[free] = xv
    return _unpack(nlp, names, x, res, g, status, ipopt_status, int(stats.get("iter_count", mon.iterations)), _time.perf_counter() - t0)


def _unpack(nlp: NLP, names, x, res, g, status, ipopt_status, iters, seconds) -> NLPSolution:
    L = nlp.layout
    K = nlp.grid.K
    lo_k, hi_k = nlp.window
    seg = nlp.grid.segment[lo_k:hi_k]
    _, seg_of = np.unique(seg, return_inverse=True)
    h = x[L["eta"][0] : L["eta"][1]][seg_of] * np.diff(nlp.grid.t)[lo_k:hi_k]
    t = np.r_[0.0, np.cumsum(h)]
    K = hi_k - lo_k
    X = {n: x[L[f"X_{n}"][0] : L[f"X_{n}"][1]].reshape((6, K + 1), order="F") * nlp.scales[n][0] for n in names}
    U = {n: x[L[f"U_{n}"][0] : L[f"U_{n}"][1]].reshape((2, K), order="F") * nlp.scales[n][1] for n in names}
    if g is None:
        g = np.asarray(ca.Function("g", [nlp.problem["x"]], [nlp.problem["g"]])(x)).ravel()
    viol = max(
        float(np.max(np.maximum(nlp.lbg - g, g - nlp.ubg), initial=0.0)),
        float(np.max(np.maximum(nlp.lbx - x, x - nlp.ubx), initial=0.0)),
    )
    sol = NLPSolution(
        status=status,
        ipopt_status=ipopt_status,
        iterations=iters,
        t=t,
        X=X,
        U=U,
        objective=float(res["f"]),
        solve_seconds=seconds,
        max_violation=viol,
        x=x,
    )
    sol.layout = L  # type: ignore[attr-defined]
    sol.window = (lo_k, hi_k)  # type: ignore[attr-defined]
    return sol
