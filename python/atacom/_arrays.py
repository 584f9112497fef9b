"""Input checks shared by the vector env and the projector front ends.

Every user array goes through here before it reaches C++: a clear exception
naming the argument, its shape or dtype, never a silent unsafe cast.
"""
import numbers
import operator

import numpy as np


def as_float64(x, name, shape=None, ndim=None):
    """x as a C-contiguous float64 array (no copy when it already is one).

    Casts only where NumPy calls it safe (bool, integers, float16/32):
    complex, object, string or longdouble input raises TypeError.
    """
    try:
        a = np.asarray(x)
    except Exception as e:  # e.g. a torch tensor that requires grad
        raise TypeError(f"{name} could not be converted to a NumPy array: {e}") from None
    if a.dtype != np.float64:
        if not np.can_cast(a.dtype, np.float64, casting="safe"):
            raise TypeError(f"{name} has dtype {a.dtype}, which cannot be cast safely to float64 "
                            f"(pass float32 or float64)")
        a = a.astype(np.float64)
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimensions{_shape_hint(shape)}, got shape {a.shape}")
    if shape is not None and a.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {a.shape}")
    return np.ascontiguousarray(a)


class ControlAffineBatch:
    """The checked arrays of N control-affine problems qdot = f + G a with
    rows c (J_q, and J_x with xdot for moving obstacles), shared by every
    safety layer's front end: shapes (N, n), (N, n, m), (N, k, n), (N, k),
    alpha (N, m), J_x (N, k, p) and xdot (N, p) (None when p = 0)."""

    def __init__(self, f, G, J_q, c, alpha, J_x=None, xdot=None):
        f = as_float64(f, "f", ndim=2)
        N, n = f.shape
        alpha = as_float64(alpha, "alpha", ndim=2)
        c = as_float64(c, "c", ndim=2)
        if N < 1:
            raise ValueError("the batch is empty (f has N = 0 rows)")
        if alpha.shape[0] != N or c.shape[0] != N:
            raise ValueError(f"f, alpha and c must have the same number of rows N (got {N}, {alpha.shape[0]}, "
                             f"{c.shape[0]})")
        m = alpha.shape[1]
        if n < 1:
            raise ValueError("f must not be empty (it sets n)")
        if m < 1:
            raise ValueError("alpha must not be empty (it sets m)")
        G = as_float64(G, "G", shape=(N, n, m), ndim=3)
        # k is J_q's row count when J_q is otherwise right, so a c of the wrong
        # width is blamed on c (not on a J_q that fits f).
        J_q = as_float64(J_q, "J_q", ndim=3)
        if J_q.shape[0] == N and J_q.shape[2] == n and J_q.shape[1] != c.shape[1]:
            raise ValueError(f"c must have shape {(N, J_q.shape[1])} (one value per row of J_q {J_q.shape}), "
                             f"got {c.shape}")
        k = c.shape[1]
        J_q = as_float64(J_q, "J_q", shape=(N, k, n), ndim=3)
        if (J_x is None) != (xdot is None):
            raise ValueError("J_x and xdot must be given together")
        p = 0
        if xdot is not None:
            xdot = as_float64(xdot, "xdot", ndim=2)
            if xdot.shape[0] != N:
                raise ValueError(f"xdot must have N = {N} rows, got {xdot.shape[0]}")
            p = xdot.shape[1]
            J_x = as_float64(J_x, "J_x", shape=(N, k, p), ndim=3)
        if p == 0:
            J_x = xdot = None
        self.f, self.G, self.J_q, self.c, self.alpha, self.J_x, self.xdot = f, G, J_q, c, alpha, J_x, xdot
        self.N, self.n, self.m, self.k, self.p = N, n, m, k, p


def _shape_hint(shape):
    return f" {tuple(shape)}" if shape is not None else ""


def as_mask(x, name, n):
    """x as a bool array of shape (n,); only bool or 0/1 integers are accepted."""
    a = np.asarray(x)
    if a.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
    if a.dtype == np.bool_:
        return np.ascontiguousarray(a)
    if np.issubdtype(a.dtype, np.integer) and np.all((a == 0) | (a == 1)):
        return a.astype(np.bool_)
    raise TypeError(f"{name} must hold booleans (or 0/1 integers), got dtype {a.dtype}")


def as_seed(seed, name="seed"):
    """A seed for the C++ streams: an integer in [0, 2**64)."""
    if isinstance(seed, (bool, np.bool_)):
        raise TypeError(f"{name} must be an integer, got {type(seed).__name__}")
    try:
        s = operator.index(seed)
    except TypeError:
        raise TypeError(f"{name} must be an integer, got {type(seed).__name__}") from None
    if not 0 <= s < 2**64:
        raise ValueError(f"{name} must be in [0, 2**64), got {s}")
    return s


def as_count(value, name, minimum=1, maximum=None):
    """An integer count in [minimum, maximum] (maximum None: no upper bound)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    value = int(value)
    if value < minimum or (maximum is not None and value > maximum):
        bound = f">= {minimum}" if maximum is None else f"in [{minimum}, {_readable(maximum)}]"
        raise ValueError(f"{name} must be an integer {bound}, got {value}")
    return value


def _readable(v):
    """2**20 as '2^20', as the CLI prints its limits."""
    if v >= 65536 and v & (v - 1) == 0:
        return f"2^{v.bit_length() - 1}"
    if v >= 65536 and (v + 1) & v == 0:
        return f"2^{v.bit_length()} - 1"
    return str(v)


# The limits of the CLI (src/core/limits.hpp), the same from Python.
MAX_ENVS = 2**20     # parallel envs of one batch (train.num_envs, --envs)
MAX_BATCH = 2**31 - 1  # problems of one projector batch (a C++ int)
MAX_THREADS = 1024   # --threads
