"""The batched C++ envs as a Gymnasium 1.x VectorEnv, with safety in the open.

    env = atacom.make_vec("table", 64, seed=0, safety="atacom")
    obs, info = env.reset()
    obs, reward, terminated, truncated, info = env.step(actions)   # actions (64, 7) in [-1, 1]
    info["cost"], info["constraints"], info["constraint_names"], info["collision"], ...

All N envs live in one C++ object and step together, TBB-parallel, with the
GIL released. A subclass of gymnasium.vector.VectorEnv when Gymnasium is
importable; otherwise the same interface without it.
"""
import enum
import json
import struct

import numpy as np

from . import _core
from ._arrays import MAX_ENVS, as_count, as_float64, as_mask, as_seed
from .spaces import HAVE_GYMNASIUM, Box, batch_space

if HAVE_GYMNASIUM:
    from gymnasium.vector import VectorEnv as _VectorEnvBase

    try:
        from gymnasium.vector import AutoresetMode  # Gymnasium >= 1.1
    except ImportError:
        AutoresetMode = None
else:
    _VectorEnvBase = object
    AutoresetMode = None

if AutoresetMode is None:

    class AutoresetMode(enum.Enum):
        """Gymnasium 1.1's autoreset modes (same names and values)."""

        NEXT_STEP = "NextStep"
        SAME_STEP = "SameStep"
        DISABLED = "Disabled"


_MODE_NAMES = {"same_step": AutoresetMode.SAME_STEP, "next_step": AutoresetMode.NEXT_STEP,
               "SameStep": AutoresetMode.SAME_STEP, "NextStep": AutoresetMode.NEXT_STEP}
_RESET_OPTIONS = ("reset_mask",)
# save_state() in next-step mode: this header, N (uint32 LE), N pending-reset bytes, then the C++ snapshot.
_NEXT_STEP_MAGIC = b"ATACOM-PY-NEXT-STEP\x01"


def _parse_mode(mode):
    if isinstance(mode, AutoresetMode):
        if mode in (AutoresetMode.SAME_STEP, AutoresetMode.NEXT_STEP):
            return mode
    elif isinstance(mode, str) and mode in _MODE_NAMES:
        return _MODE_NAMES[mode]
    elif isinstance(mode, enum.Enum) and getattr(mode, "value", None) in ("SameStep", "NextStep"):
        return _MODE_NAMES[mode.value]  # the other AutoresetMode (Gymnasium's or ours)
    raise ValueError(f"autoreset_mode must be 'same_step' or 'next_step', got {mode!r}")


def _check_config_keys(env, config):
    """Unknown keys named with the known ones at that level (C++ checks types and values)."""
    defaults = json.loads(_core.default_env_config(env))  # an unknown env fails here, listing the known ones

    def walk(base, over, path):
        for key, value in over.items():
            name = f"{path}.{key}"
            if key not in base:
                raise ValueError(f"unknown config key '{name}' (known in '{path}': {', '.join(sorted(base))})")
            if isinstance(base[key], dict) and isinstance(value, dict):
                walk(base[key], value, name)

    walk(defaults, config, "env")


def _readonly(a):
    a.flags.writeable = False
    return a


class AtacomVectorEnv(_VectorEnvBase):
    """N envs of one registered kind (see atacom.env_names()) behind a safety layer.

    Arrays: observations float32 (N, obs_dim), rewards float32 (N,),
    terminated / truncated bool (N,), info["cost"] float32 (N,) (0 or 1: a row
    above its tolerance or a collision / joint-limit event, Safety-Gymnasium's
    convention), info["cost_continuous"] float32 (N,) (max(0, max_i c_i)),
    info["constraints"] float64 (N, k) with info["constraint_names"] (k names),
    every per-step info column of the env by name, float32 (N,), and under
    ATACOM info["atacom_status"] uint32 (N,) (projector status bits; bit 2 =
    the action had NaN/Inf and was replaced by 0). Every key has its
    Gymnasium "_key" mask. The safety columns always describe the step just
    taken, for every env (summing info["cost"] counts every step, including
    the one that ended an episode); final_info repeats them for the envs whose
    episode ended, laid out as Gymnasium's SameStep mode.

    copy=True (default): every returned array is the caller's own.
    copy=False: obs, rewards, flags and the per-step info arrays are
    read-only views of the C++ buffers that the next step() or reset()
    overwrites in place (no copy at all); each view holds a reference to the
    C++ env, so it stays valid memory even after close().

    Actions: (N, act_dim), anything NumPy casts safely to float64 (float32,
    float64, integers); each entry is clipped to [-1, 1]; NaN is treated as 0
    and counted (the env's "nan_action"/"nonfinite_action" column without a
    safety layer, the status bit under ATACOM).
    """

    def __init__(self, env, num_envs, seed=0, safety="atacom", config=None, autoreset_mode="same_step",
                 copy=True):
        if not isinstance(env, str):
            raise TypeError(f"env must be a name (one of {', '.join(_core.env_names())}), got {type(env).__name__}")
        if not isinstance(safety, str):
            raise TypeError(f"safety must be a name (one of {', '.join(_core.safety_layer_names())}), "
                            f"got {type(safety).__name__}")
        num_envs = as_count(num_envs, "num_envs", maximum=MAX_ENVS)  # the CLI's --envs limit
        seed = as_seed(seed)
        if config is None:
            config = {}
        if not isinstance(config, dict):
            raise TypeError(f"config must be a dict of overrides of the env's defaults, got {type(config).__name__}")
        try:
            config_json = json.dumps(config, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"config is not representable as JSON (finite numbers, strings, lists, dicts): {e}") \
                from None
        _check_config_keys(env, config)
        self._mode = _parse_mode(autoreset_mode)
        self.copy = bool(copy)
        self._env = _core.BatchEnv(env, num_envs, safety, config_json)

        spec = self._env.spec()
        self.num_envs = num_envs
        self.env_name = env
        self.safety = safety
        self.dt = spec["dt"]
        self.horizon = spec["horizon"]
        self.obs_dim = spec["obs_dim"]
        self.act_dim = spec["act_dim"]
        self.constraint_names = tuple(spec["constraint_names"])
        self.constraint_tolerance = _readonly(np.array(spec["constraint_tolerance"], dtype=np.float64))
        self.info_names = tuple(spec["info_names"])
        self.info_reduce = dict(zip(spec["info_names"], spec["info_reduce"]))
        # What each column is for: "any_contact" (the env's collision count), "contact" (one kind),
        # "episode_event" (1 per episode with it), "goal_distance" (the quality metric), "diagnostic".
        self.info_role = dict(zip(spec["info_names"], spec["info_role"]))
        self.cost_events = tuple(spec["cost_events"])  # info columns that make a step's cost 1
        self.metadata = {"autoreset_mode": self._mode, "render_modes": []}
        self.render_mode = None
        self.spec = None
        self.closed = False

        obs_low = np.array(spec["obs_low"], dtype=np.float32)
        obs_high = np.array(spec["obs_high"], dtype=np.float32)
        if obs_low.shape != (self.obs_dim,):
            obs_low = np.full(self.obs_dim, -np.inf, dtype=np.float32)
            obs_high = np.full(self.obs_dim, np.inf, dtype=np.float32)
        self.single_observation_space = Box(obs_low, obs_high, shape=(self.obs_dim,), dtype=np.float32)
        self.single_action_space = Box(-1.0, 1.0, shape=(self.act_dim,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)

        e = self._env
        self._obs, self._final_obs = e.view_obs(), e.view_final_obs()
        self._reward, self._cost = e.view_reward(), e.view_cost()
        self._cost_continuous = e.view_cost_continuous()
        self._terminated, self._truncated = e.view_terminated(), e.view_truncated()
        self._constraints, self._info = e.view_constraints(), e.view_info()
        self._episode_return, self._episode_length = e.view_episode_return(), e.view_episode_length()
        self._status = e.view_atacom_status()
        self._info_cols = [self._info[:, j] for j in range(len(self.info_names))]
        self._all_true = _readonly(np.ones(num_envs, dtype=np.bool_))
        self._pending = np.zeros(num_envs, dtype=np.bool_)  # next-step mode: reset at the next step()
        self._env.seed(seed)
        self._fresh = True  # seeded and not stepped since: reset() need not reset again

    # ------------------------------------------------------------------ API

    @property
    def autoreset_mode(self):
        return self._mode

    @property
    def unwrapped(self):
        return self

    def reset(self, *, seed=None, options=None):
        """Reset envs; returns (obs, info).

        seed=int: env i gets the stream (seed, i), exactly as the C++ side
        (`atacom rollout --seed`, `atacom train --seed`) seeds it; all envs
        reset. seed=None continues the streams. The first reset() after
        make_vec(..., seed=s), with no step in between, keeps the episodes
        that seeding started, so make_vec(seed=s) + reset() + the same
        actions reproduce the CLI's run with --seed s.
        options={"reset_mask": mask}: reset only the envs with mask[i] (a bool
        array of N); the others keep their state and observation.
        info: "constraints" (N, k) at the returned state and its "_constraints"
        mask (the envs that were reset), "constraint_names".
        """
        self._check_open()
        mask = None
        if options is not None:
            if not isinstance(options, dict):
                raise TypeError(f"options must be a dict, got {type(options).__name__}")
            unknown = [k for k in options if k not in _RESET_OPTIONS]
            if unknown:
                raise ValueError(f"unknown reset option {unknown[0]!r} (known: {', '.join(_RESET_OPTIONS)})")
            if options.get("reset_mask") is not None:
                mask = as_mask(options["reset_mask"], "options['reset_mask']", self.num_envs)
        if seed is not None:
            if isinstance(seed, (list, tuple, np.ndarray)):
                raise ValueError("seed must be one integer: env i gets the stream (seed, i); per-env seed lists "
                                 "are not supported")
            if mask is not None:
                raise ValueError("seed and options['reset_mask'] cannot be combined: seeding re-keys every env's "
                                 "stream and resets all envs")
            seed = as_seed(seed)
            if HAVE_GYMNASIUM:
                super().reset(seed=seed)
            self._env.seed(seed)
            self._pending[:] = False
        elif mask is not None:
            self._env.reset(mask)
            self._pending[mask] = False
        elif not self._fresh:
            self._env.reset(None)
            self._pending[:] = False
        self._fresh = False
        obs = self._final_obs if self._mode is AutoresetMode.NEXT_STEP else self._obs
        info = {"constraints": self._constraints.copy() if self.copy else self._constraints,
                "_constraints": _readonly(mask.copy()) if mask is not None else self._all_true,
                "constraint_names": self.constraint_names}
        return (obs.copy() if self.copy else obs), info

    def step(self, actions):
        """One step of every env; returns (obs, reward, terminated, truncated, info)."""
        self._check_open()
        a = as_float64(actions, "actions", shape=(self.num_envs, self.act_dim), ndim=2)
        next_step = self._mode is AutoresetMode.NEXT_STEP
        pending = None
        if next_step and self._pending.any():
            # Gymnasium's next-step autoreset: the envs that ended last step
            # start a new episode now, with reward 0 and their action ignored.
            # The batch steps all envs, so those envs take a zero action (the
            # user's never reaches them) and are reset after the step: the
            # episode the C++ same-step autoreset had started is discarded.
            pending = self._pending.copy()
            a = a.copy()  # never write into the caller's array
            a[pending] = 0.0
            self._env.step(a)
            self._env.reset(pending)
        else:
            self._env.step(a)
        self._fresh = False
        done = np.logical_or(self._terminated, self._truncated)

        c = self.copy
        obs = self._final_obs if next_step else self._obs  # final_obs == obs except where an episode ended
        step_mask = self._all_true if pending is None else _readonly(~pending)
        info = {}
        info["cost"] = self._cost.copy() if c else self._cost
        info["_cost"] = step_mask
        info["cost_continuous"] = self._cost_continuous.copy() if c else self._cost_continuous
        info["_cost_continuous"] = step_mask
        info["constraints"] = self._constraints.copy() if c else self._constraints
        info["_constraints"] = self._all_true
        info["constraint_names"] = self.constraint_names
        cols = [col.copy() for col in self._info_cols] if c else self._info_cols
        for name, col in zip(self.info_names, cols):
            info[name] = col
            info["_" + name] = step_mask
        if self._status is not None:
            info["atacom_status"] = self._status.copy() if c else self._status
            info["_atacom_status"] = step_mask

        if done.any():
            _readonly(done)
            if next_step:
                info["episode_return"] = np.where(done, self._episode_return, 0.0)
                info["_episode_return"] = done
                info["episode_length"] = np.where(done, self._episode_length, 0).astype(np.int32)
                info["_episode_length"] = done
                self._pending = done.copy()
            else:
                self._add_final(info, done, c)
        elif next_step:
            self._pending[:] = False

        return ((obs.copy() if c else obs), (self._reward.copy() if c else self._reward),
                (self._terminated.copy() if c else self._terminated),
                (self._truncated.copy() if c else self._truncated), info)

    def step_with_cost(self, actions):
        """Safety-Gymnasium's convention: (obs, reward, cost, terminated, truncated, info).

        cost is info["cost"], 0 or 1 per env; the continuous one is info["cost_continuous"].
        """
        obs, reward, terminated, truncated, info = self.step(actions)
        return obs, reward, info["cost"], terminated, truncated, info

    def save_state(self):
        """The complete batch state as bytes (C++ snapshot: RNG streams, counters, buffers).

        load_state() of these bytes followed by the same actions reproduces
        the same results bitwise. In next-step mode the pending resets are
        prepended (a small header), so a restore continues exactly there.
        """
        self._check_open()
        core = self._env.save_state()
        if self._mode is AutoresetMode.NEXT_STEP:
            return _NEXT_STEP_MAGIC + struct.pack("<I", self.num_envs) + self._pending.astype(np.uint8).tobytes() + core
        return core

    def load_state(self, data):
        """Restore a save_state() snapshot of an env of the same kind and N.

        Raises (and keeps the current state) for a snapshot of another env
        kind, another N, or truncated / corrupted bytes.
        """
        self._check_open()
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"load_state expects bytes from save_state(), got {type(data).__name__}")
        data = bytes(data)
        pending = np.zeros(self.num_envs, dtype=np.bool_)
        if data.startswith(_NEXT_STEP_MAGIC):
            if self._mode is not AutoresetMode.NEXT_STEP:
                raise ValueError("this snapshot comes from a next-step autoreset env; this env is same-step")
            head = len(_NEXT_STEP_MAGIC)
            if len(data) < head + 4:
                raise ValueError("snapshot truncated (next-step header)")
            (n,) = struct.unpack_from("<I", data, head)
            if n != self.num_envs:
                raise ValueError(f"snapshot holds {n} envs, this env has {self.num_envs}")
            body = head + 4 + n
            if len(data) < body:
                raise ValueError("snapshot truncated (pending resets)")
            pending = np.frombuffer(data, dtype=np.uint8, count=n, offset=head + 4).astype(np.bool_)
            data = data[body:]
        self._env.load_state(data)
        self._pending = pending
        self._fresh = False

    def close(self, **kwargs):
        """Release the env (its memory lives on while copy=False views refer to it)."""
        if self.closed:
            return
        self.closed = True
        self._env = None

    def __repr__(self):
        return (f"AtacomVectorEnv({self.env_name!r}, num_envs={self.num_envs}, safety={self.safety!r}, "
                f"autoreset_mode={self._mode.name.lower()!r}, copy={self.copy})")

    # ------------------------------------------------------------- private

    def _check_open(self):
        if self.closed:
            raise RuntimeError("this env is closed")

    def _add_final(self, info, done, c):
        """final_obs / final_info exactly as Gymnasium's SameStep mode lays them out."""
        idx = np.flatnonzero(done)
        src = self._final_obs.copy() if c else self._final_obs
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in idx:
            final_obs[i] = src[i]
        info["final_obs"] = final_obs
        info["_final_obs"] = done
        fin = {}

        def put(name, values):
            out = np.zeros_like(values)
            out[idx] = values[idx]
            fin[name] = out
            fin["_" + name] = done

        put("cost", self._cost)
        put("cost_continuous", self._cost_continuous)
        put("constraints", self._constraints)
        for name, col in zip(self.info_names, self._info_cols):
            put(name, col)
        if self._status is not None:
            put("atacom_status", self._status)
        put("episode_return", self._episode_return)
        put("episode_length", self._episode_length)
        info["final_info"] = fin
        info["_final_info"] = done


def make_vec(env, num_envs, seed=0, safety="atacom", config=None, autoreset_mode="same_step", copy=True):
    """N envs of a registered kind as one Gymnasium-style vector env.

    env: "table", "shelf", "nav", "pendulum", ... (atacom.env_names()).
    safety: "atacom" (the projector between the agent and the env), "none",
    or "safelayer" (SafeLayer's one-step QP); atacom.safety_layers() lists them.
    config: overrides of the env's defaults (atacom.default_config(env));
    unknown keys are rejected with the known ones listed.
    autoreset_mode: "same_step" (the C++ envs' own: the step that ends an
    episode returns the next episode's first obs, the true last one in
    info["final_obs"]) or "next_step" (Gymnasium's default: the step after a
    done returns the reset obs with reward 0 and ignores the action).
    copy: False returns read-only views overwritten by the next step.
    """
    return AtacomVectorEnv(env, num_envs, seed=seed, safety=safety, config=config, autoreset_mode=autoreset_mode,
                           copy=copy)
