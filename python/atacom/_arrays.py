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


def as_count(value, name, minimum=1):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    value = int(value)
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return value
