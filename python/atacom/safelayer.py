"""SafeLayer (Dalal et al. 2018) over batches of users' own systems, from NumPy.

    r = atacom.safelayer(f, G, J_q, c, alpha, dt=1/30, threshold=0.0)
    r.a, r.qdot, r.active, r.correction, r.iterations, r.status

Per problem, a is the exact solution of min 1/2 |a - a_pi|^2 subject to
c_i + dt (F_i + (J_q G)_i a) <= C_i for every row (F = J_q f + J_x xdot)
and -1 <= a_j <= 1, with a_pi = clip(alpha, -1, 1): the same as `atacom
filter` with "method": "safelayer" (README; docs/safelayer.md). dt > 0
(default 1/30); threshold C is one number or one per row (default 0).
Status bits (STATUS_FLAGS): 1 infeasible (no action in the box satisfies
every row: a is then the action in the box with the least squared row
violation), 2 NaN/Inf alpha replaced by 0, 4 non-finite model (a = 0),
8 iteration bound hit.
"""
import numbers

import numpy as np

from . import _core
from ._arrays import ControlAffineBatch

STATUS_FLAGS = {1: "infeasible", 2: "alpha_nonfinite", 4: "model_nonfinite", 8: "iteration_limit"}


def status_flags(status):
    """Names of the bits set in one status value (as the filter's status_flags)."""
    status = int(status)
    return [name for bit, name in STATUS_FLAGS.items() if status & bit]


class SafeLayerResult(dict):
    """a (N, m), qdot (N, n) = f + G a, active (N, k) bool, correction (N,)
    = |a - a_pi|, iterations (N,) (0: a_pi kept, 1: closed form, more: the
    QP), status (N,) uint32; r.a or r["a"]."""

    def __getattr__(self, key):
        try:
            return self[key]
        except KeyError:
            raise AttributeError(key) from None


def _finite(value, what):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"'{what}' must be a number, got {type(value).__name__}")
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"'{what}' is NaN or infinite")
    return value


def safelayer(f, G, J_q, c, alpha, J_x=None, xdot=None, dt=1.0 / 30.0, threshold=0.0, parallel=True):
    """SafeLayer's correction of N actions (module docstring). f (N, n),
    G (N, n, m), J_q (N, k, n), c (N, k), alpha (N, m); optional J_x (N, k, p)
    and xdot (N, p) together. The GIL is released while the kernel runs."""
    b = ControlAffineBatch(f, G, J_q, c, alpha, J_x, xdot)
    n, m, k, p = b.n, b.m, b.k, b.p
    dt = _finite(dt, "dt")
    if not dt > 0:
        raise ValueError("'dt' must be > 0")
    if isinstance(threshold, numbers.Real) and not isinstance(threshold, (bool, np.bool_)):
        thr = [_finite(threshold, "threshold")] * k
    else:
        thr = [_finite(v, f"threshold[{i}]") for i, v in enumerate(threshold)]
        if len(thr) != k:
            raise ValueError(f"'threshold' has {len(thr)} entries, expected one per constraint ({k}) or a single value")
    out = _core.safelayer(n, m, k, p, dt, thr, b.f, b.G, b.J_q, b.c, b.alpha, b.J_x, b.xdot, bool(parallel))
    return SafeLayerResult(out)
