"""The ATACOM projector over batches of users' own systems, from NumPy.

    qdot = f(q) + G(q) a,  constraints c(q, x) <= 0,  J_q = dc/dq,  J_x = dc/dx

    r = atacom.project(f, G, J_q, c, alpha)        # f (N, n), G (N, n, m), J_q (N, k, n), c (N, k), alpha (N, m)
    a, s, lam, status = r                          # or r.a, r.s, r.lambda_, r.status, r.qdot, r["lambda"]

The options and their defaults are those of `atacom filter` (README, filter
section), and the results agree with it to 1e-12 on the same inputs:
    slack     "softcorner" | "exponential" | "quadratic", or one per row    default "softcorner"
    beta      number or one per row (> 0)                                   default 3
    tol       number or one per row, in (0, 1)                              default 1e-6
    K_c       number >= 0                                                   default 30 (1/dt at 30 Hz)
    basis     "projected" | "smooth"                                        default "projected"
    equality  bool or one per row                                           default False
The model options are shared by the whole batch; every array is per env.
Non-finite entries are not an error here (the filter rejects such a line):
the kernel's status bits report them per env (2: NaN/Inf alpha replaced by
0; 4: non-finite model, a = 0), as inside the envs.
"""
import json
import numbers

import numpy as np

from . import _core
from ._arrays import MAX_BATCH, ControlAffineBatch, as_count, as_float64

# Bits of the status array (ProjectorStatus in include/atacom/projector.hpp).
STATUS_FLAGS = {
    1: "bias_out_of_bounds",    # the correction alone is outside [-1, 1]^m: lambda = 0, a = b scaled into the box
    2: "alpha_nonfinite",       # NaN/Inf in alpha: replaced by 0 (pure correction)
    4: "model_nonfinite",       # NaN/Inf in f, G, c, J or xdot: a = 0 (stop)
    8: "equality_rank_loss",    # equality rows dependent: solved in least squares
}


def status_flags(status):
    """Names of the bits set in one status value (as the filter's status_flags)."""
    status = int(status)
    return [name for bit, name in STATUS_FLAGS.items() if status & bit]


class ProjectResult(tuple):
    """(a, s, lambda, status) of N projections.

    Attributes a (N, m), s (N, k), lambda_ (N,), status (N,) uint32 and qdot
    (N, n) = f + G a; r["a"], r["lambda"], ... index by the filter's keys.
    """

    def __new__(cls, out):
        obj = super().__new__(cls, (out["a"], out["s"], out["lambda"], out["status"]))
        obj._out = out
        return obj

    def __getitem__(self, key):
        if isinstance(key, str):
            return self._out[key]
        return super().__getitem__(key)

    def keys(self):
        return self._out.keys()

    a = property(lambda self: self._out["a"])
    s = property(lambda self: self._out["s"])
    lambda_ = property(lambda self: self._out["lambda"])
    status = property(lambda self: self._out["status"])
    qdot = property(lambda self: self._out["qdot"])


def _number(value, what):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"'{what}' must be a number, got {type(value).__name__}")
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"'{what}' is NaN or infinite")
    return value


def _string(value, what):
    if not isinstance(value, str):
        raise TypeError(f"'{what}' must be a string, got {type(value).__name__}")
    return value


def _boolean(value, what):
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"'{what}' must be True or False, got {type(value).__name__}")
    return bool(value)


def _per_row(value, key, k, parse):
    """A single value for every row or one per row, as the filter reads them."""
    if isinstance(value, (str, bool, np.bool_, numbers.Number)):
        return [parse(value, key)] * k
    try:
        values = list(value)
    except TypeError:
        raise TypeError(f"'{key}' must be a single value or one per constraint, got {type(value).__name__}") \
            from None
    if len(values) != k:
        raise ValueError(f"'{key}' has {len(values)} entries, expected one per constraint ({k}) or a single value")
    return [parse(v, f"{key}[{i}]") for i, v in enumerate(values)]


def _model_json(n, m, k, p, slack, beta, tol, K_c, basis, equality):
    model = {"n": n, "m": m, "k": k, "p": p}
    if slack is not None:
        model["slack"] = _per_row(slack, "slack", k, _string)
    if beta is not None:
        model["beta"] = _per_row(beta, "beta", k, _number)
    if tol is not None:
        model["tol"] = _per_row(tol, "tol", k, _number)
    if equality is not None:
        model["equality"] = _per_row(equality, "equality", k, _boolean)
    if K_c is not None:
        model["K_c"] = _number(K_c, "K_c")
    if basis is not None:
        model["basis"] = _string(basis, "basis")
    return json.dumps(model)


def project(f, G, J_q, c, alpha, J_x=None, xdot=None, slack=None, beta=None, tol=None, K_c=None, basis=None,
            equality=None, parallel=True):
    """Project N policy actions alpha onto the constraint manifold's tangent space.

    f (N, n), G (N, n, m), J_q (N, k, n), c (N, k), alpha (N, m); optional
    J_x (N, k, p) and xdot (N, p) together. Options (None = the filter's
    default): slack, beta, tol, K_c, basis, equality (module docstring).
    Returns ProjectResult: a (N, m) safe controls, s (N, k) slack values
    (0 on equality rows), lambda (N,) tangential scale in [0, 1], status (N,)
    uint32 bits (STATUS_FLAGS), qdot (N, n) = f + G a. The GIL is released
    while the kernel runs (TBB-parallel unless parallel=False).
    """
    b = ControlAffineBatch(f, G, J_q, c, alpha, J_x, xdot)
    n, m, k, p = b.n, b.m, b.k, b.p
    model = _model_json(n, m, k, p, slack, beta, tol, K_c, basis, equality)
    out = _core.project(model, b.f, b.G, b.J_q, b.c, b.alpha, b.J_x, b.xdot, bool(parallel))
    return ProjectResult(out)


def _input_view(name):
    """A writable input array: assigning copies the values in (checked shape), never replaces the view."""

    def get(self):
        return self._views[name]

    def set(self, value):
        view = self._views[name]
        np.copyto(view, as_float64(value, name, shape=view.shape, ndim=view.ndim))

    return property(get, set, doc=f"input {name}: writable float64 view; `p.{name} = x` copies x in (same shape)")


def _output_view(name, key):
    def get(self):
        return self._views[key]

    def set(self, value):
        raise AttributeError(f"'{name}' is an output of project() (read-only); write the inputs "
                             f"(f, G, J_q, c, alpha, J_x, xdot) instead")

    return property(get, set, doc=f"output {name}: read-only view, overwritten by each project()")


def _dimension(name):
    def get(self):
        return self._dims[name]

    def set(self, value):
        raise AttributeError(f"'{name}' is fixed when the Projector is made; make a new Projector for another size")

    return property(get, set, doc=f"dimension {name} (fixed)")


class Projector:
    """A persistent batch of N problems: write the inputs in place, call project().

    Inputs f, G, J_q, c, alpha (and J_x, xdot when p > 0) are writable float64
    arrays of the shapes project() takes: write into them (`p.alpha[:] = x`)
    or assign (`p.alpha = x` copies x in, with its shape checked); a, s,
    slack_u, lambda_, status are read-only outputs, overwritten by each
    project(); N, n, m, k, p are fixed. Nothing is copied or allocated per
    call: the fastest way to run the kernel from Python.
    """

    __slots__ = ("_core", "_views", "_dims")

    def __init__(self, N, n, m, k, p=0, slack=None, beta=None, tol=None, K_c=None, basis=None, equality=None):
        N = as_count(N, "N", maximum=MAX_BATCH)
        n, m = as_count(n, "n"), as_count(m, "m")
        k, p = as_count(k, "k", 0), as_count(p, "p", 0)
        self._core = _core.Projector(_model_json(n, m, k, p, slack, beta, tol, K_c, basis, equality), N)
        self._dims = {"N": N, "n": n, "m": m, "k": k, "p": p}
        self._views = self._core.views()

    N, n, m, k, p = (_dimension(d) for d in ("N", "n", "m", "k", "p"))
    f, G, J_q, c, alpha, J_x, xdot = (_input_view(v) for v in ("f", "G", "J_q", "c", "alpha", "J_x", "xdot"))
    a, s, slack_u, status = (_output_view(v, v) for v in ("a", "s", "slack_u", "status"))
    lambda_ = _output_view("lambda_", "lambda")

    @property
    def model(self):
        """The resolved projector model (every option per row)."""
        return json.loads(self._core.model_json)

    def project(self, parallel=True):
        self._core.project(bool(parallel))
        return self
