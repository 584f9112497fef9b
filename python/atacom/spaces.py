"""Observation and action spaces.

With Gymnasium importable these are Gymnasium's own Box and batch_space.
Without it, a minimal Box with Gymnasium's attribute names (low, high,
shape, dtype, sample, contains, seed, np_random, is_bounded), so code written
against Gymnasium's spaces runs unchanged.
"""
import numpy as np

try:
    from gymnasium.spaces import Box
    from gymnasium.vector.utils import batch_space

    HAVE_GYMNASIUM = True
except ImportError:
    HAVE_GYMNASIUM = False

    class Box:
        """A box in R^shape with per-entry bounds (Gymnasium's Box interface, minimal)."""

        def __init__(self, low, high, shape=None, dtype=np.float32, seed=None):
            self.dtype = np.dtype(dtype)
            if shape is None:
                shape = np.shape(low) if np.ndim(low) else np.shape(high)
            self.shape = tuple(int(s) for s in shape)
            self.low = np.broadcast_to(np.asarray(low, dtype=self.dtype), self.shape).copy()
            self.high = np.broadcast_to(np.asarray(high, dtype=self.dtype), self.shape).copy()
            if np.any(self.low > self.high):
                raise ValueError("Box: low must not exceed high")
            self._np_random = None
            if seed is not None:
                self.seed(seed)

        @property
        def np_random(self):
            if self._np_random is None:
                self._np_random = np.random.default_rng()
            return self._np_random

        def seed(self, seed=None):
            self._np_random = np.random.default_rng(seed)
            return [seed]

        def is_bounded(self, manner="both"):
            below = bool(np.all(np.isfinite(self.low)))
            above = bool(np.all(np.isfinite(self.high)))
            if manner == "both":
                return below and above
            if manner == "below":
                return below
            if manner == "above":
                return above
            raise ValueError(f"manner must be 'both', 'below' or 'above', got {manner!r}")

        def sample(self):
            """Uniform where bounded on both sides; normal / shifted exponential otherwise (as Gymnasium)."""
            low = self.low.astype(np.float64)
            high = self.high.astype(np.float64)
            rng = self.np_random
            out = np.empty(self.shape, dtype=np.float64)
            lo_f, hi_f = np.isfinite(low), np.isfinite(high)
            both, none = lo_f & hi_f, ~lo_f & ~hi_f
            out[both] = rng.uniform(low[both], high[both])
            out[none] = rng.normal(size=int(none.sum()))
            only_lo, only_hi = lo_f & ~hi_f, ~lo_f & hi_f
            out[only_lo] = low[only_lo] + rng.exponential(size=int(only_lo.sum()))
            out[only_hi] = high[only_hi] - rng.exponential(size=int(only_hi.sum()))
            return out.astype(self.dtype)

        def contains(self, x):
            x = np.asarray(x)
            return bool(x.shape == self.shape and np.can_cast(x.dtype, self.dtype)
                        and np.all(x >= self.low) and np.all(x <= self.high))

        def __contains__(self, x):
            return self.contains(x)

        def __eq__(self, other):
            return (isinstance(other, Box) and self.shape == other.shape and self.dtype == other.dtype
                    and np.array_equal(self.low, other.low) and np.array_equal(self.high, other.high))

        def __repr__(self):
            return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"

    def batch_space(space, n):
        """The space of n stacked samples of `space` (Gymnasium's batch_space for a Box)."""
        reps = (n,) + (1,) * len(space.shape)
        return Box(np.tile(space.low, reps), np.tile(space.high, reps), dtype=space.dtype)


__all__ = ["Box", "batch_space", "HAVE_GYMNASIUM"]
