"""A training run's policy, usable outside the trainer.

    policy = atacom.load_policy("runs/table", which="final")   # or "best"
    env = policy.make_vec(64, seed=0)                           # the run's env, env config and safety layer
    obs, info = env.reset()
    obs, reward, terminated, truncated, info = env.step(policy(obs))

policy(obs) is the deterministic (mean) action, exactly what the run's
evaluations and `atacom rollout --policy trained --run DIR` do;
policy(obs, deterministic=False) samples, row i from its own C++ stream
(seed, i) (policy.seed(s) restarts the streams). Actions are float64 in
[-1, 1], for the env behind the run's safety layer (policy.safety).
"""
import json

import numpy as np

from . import _core
from ._arrays import as_seed


class LoadedPolicy:
    """Callable policy of a run directory (policy_final.bin or policy_best.bin)."""

    def __init__(self, run_dir, which="final", seed=0):
        if not isinstance(which, str) or which not in ("final", "best"):
            raise ValueError(f"which must be 'final' or 'best', got {which!r}")
        try:
            self._p = _core.TrainedPolicy(str(run_dir), which)
        except RuntimeError as e:
            raise ValueError(str(e)) from None
        self.run_dir = str(run_dir)
        self.which = which
        self.obs_dim = self._p.obs_dim
        self.act_dim = self._p.act_dim
        self.kind = self._p.kind
        self.env = self._p.env
        self.algo = self._p.algo
        self.safety = self._p.safety
        self.env_config = json.loads(self._p.env_config_json)
        self.manifest = json.loads(self._p.manifest_json)
        self.seed(seed)

    def seed(self, seed):
        """Restart the sampling streams: row i draws from (seed, i)."""
        self._p.seed(as_seed(seed))

    def __call__(self, obs, deterministic=True):
        """Actions for observations (N, obs_dim), or one observation (obs_dim,) -> (act_dim,)."""
        a = np.asarray(obs)
        if a.dtype != np.float32:
            if not np.can_cast(a.dtype, np.float64, casting="safe"):
                raise TypeError(f"obs must be numbers castable to float64, got {a.dtype}")
            a = a.astype(np.float32)
        single = a.ndim == 1
        if single:
            a = a[None, :]
        if a.ndim != 2 or a.shape[1] != self.obs_dim:
            raise ValueError(f"obs must have shape (N, {self.obs_dim}) or ({self.obs_dim},), got {np.shape(obs)}")
        out = self._p.act(np.ascontiguousarray(a), bool(deterministic))
        return out[0] if single else out

    def make_vec(self, num_envs, seed=0, **kwargs):
        """The env the policy was trained on: atacom.make_vec(run env, N, config=run env config, safety=run layer)."""
        from .vector_env import make_vec

        kwargs.setdefault("safety", self.safety)
        kwargs.setdefault("config", self.env_config)
        return make_vec(self.env, num_envs, seed=seed, **kwargs)

    def __repr__(self):
        return (f"LoadedPolicy({self.run_dir!r}, which={self.which!r}: {self.kind} for env {self.env!r}, "
                f"algo {self.algo!r}, safety {self.safety!r})")


def load_policy(run_dir, which="final", seed=0):
    """The learned policy of an `atacom train` run directory, as a callable on NumPy observations.

    which: "final" (policy_final.bin, the end of training) or "best"
    (policy_best.bin, the best evaluation). Raises ValueError naming the
    problem for a directory that holds no usable policy (no config.json, an
    algorithm that does not learn, a missing or corrupt file).
    """
    return LoadedPolicy(run_dir, which=which, seed=seed)


__all__ = ["LoadedPolicy", "load_policy"]
