"""Gymnasium registration: every atacom env under the id "atacom/<Name>-v0".

With Gymnasium importable, `import atacom` registers them, so

    import atacom, gymnasium
    venv = gymnasium.make_vec("atacom/Table-v0", num_envs=64, safety="atacom")   # the batched C++ env itself
    env = gymnasium.make("atacom/Table-v0")                                        # one env, gymnasium.Env

(or, without importing atacom first, the id "atacom:atacom/Table-v0").
make_vec uses the vector entry point: one AtacomVectorEnv of N envs stepped
together in C++, not N Python envs (keyword arguments as atacom.make_vec:
seed, safety, config, autoreset_mode, copy). make gives AtacomEnv, one env
of the same batch (N = 1) behind Gymnasium's single-env API. The safety
layer defaults to "atacom" for envs with constraints, "none" for the others
(pendulum).
"""
import numpy as np

from . import _core
from .spaces import HAVE_GYMNASIUM
from .vector_env import AtacomVectorEnv

NAMESPACE = "atacom"
VERSION = 0


def env_id(name):
    """The Gymnasium id of an atacom env: "table" -> "atacom/Table-v0"."""
    return f"{NAMESPACE}/{name[:1].upper()}{name[1:]}-v{VERSION}"


def make_vector_env(num_envs=1, *, env, seed=0, safety="atacom", config=None, autoreset_mode="same_step", copy=True):
    """Gymnasium's vector entry point: gymnasium.make_vec(id, num_envs=N, **kwargs) calls this."""
    return AtacomVectorEnv(env, num_envs, seed=seed, safety=safety, config=config, autoreset_mode=autoreset_mode,
                           copy=copy)


if HAVE_GYMNASIUM:
    import gymnasium

    class AtacomEnv(gymnasium.Env):
        """One atacom env (a batch of N = 1) behind Gymnasium's single-env API.

        step() returns the episode's true last observation when it ends
        (terminated or truncated); the C++ env has already started the next
        episode (same-step autoreset), and the following reset() without a
        seed returns that episode's first observation, so a seeded sequence
        of episodes equals the vector env's. info holds the same keys as the
        vector env's for env 0 as scalars: "cost", "constraints" (k,),
        "constraint_names", every info column, "atacom_status" under ATACOM.
        """

        metadata = {"render_modes": []}

        def __init__(self, env, seed=0, safety="atacom", config=None, render_mode=None):
            if render_mode is not None:
                raise ValueError(f"atacom envs do not render through Gymnasium (render_mode={render_mode!r}); "
                                 "use `atacom render` for an HTML episode")
            self._venv = AtacomVectorEnv(env, 1, seed=seed, safety=safety, config=config)
            v = self._venv
            self.env_name, self.safety = v.env_name, v.safety
            self.constraint_names, self.constraint_tolerance = v.constraint_names, v.constraint_tolerance
            self.observation_space = v.single_observation_space
            self.action_space = v.single_action_space
            self.render_mode = None
            self._reset_obs = None  # the next episode's first observation, after an episode ended

        def reset(self, *, seed=None, options=None):
            if options:
                raise ValueError(f"AtacomEnv.reset takes no options, got {options!r}")
            if seed is None and self._reset_obs is not None:
                # The autoreset already started this episode (its constraint values are not kept).
                obs, self._reset_obs = self._reset_obs, None
                return obs, {"constraint_names": self.constraint_names}
            super().reset(seed=seed)
            self._reset_obs = None
            obs, info = self._venv.reset(seed=seed)
            return obs[0], {"constraints": info["constraints"][0], "constraint_names": self.constraint_names}

        def step(self, action):
            a = np.asarray(action, dtype=np.float64).reshape(1, -1)
            obs, reward, terminated, truncated, vinfo = self._venv.step(a)
            info = {"constraint_names": self.constraint_names}
            for key, value in vinfo.items():
                if key.startswith("_") or key in ("constraint_names", "final_obs", "final_info"):
                    continue
                info[key] = value[0]
            out = obs[0]
            if terminated[0] or truncated[0]:
                self._reset_obs = out
                out = vinfo["final_obs"][0]
                info["episode_return"] = float(vinfo["final_info"]["episode_return"][0])
                info["episode_length"] = int(vinfo["final_info"]["episode_length"][0])
            else:
                self._reset_obs = None
            return out, float(reward[0]), bool(terminated[0]), bool(truncated[0]), info

        def close(self):
            self._venv.close()

    def make_single_env(*, env, seed=0, safety="atacom", config=None, render_mode=None):
        """Gymnasium's entry point: gymnasium.make(id, **kwargs) calls this."""
        return AtacomEnv(env, seed=seed, safety=safety, config=config, render_mode=render_mode)

else:
    AtacomEnv = None

    def make_single_env(**kwargs):
        raise ImportError("gymnasium is not importable: make_single_env needs gymnasium.Env "
                          "(atacom.make_vec works without it)")


def register_envs():
    """Register every env of atacom.env_names() with Gymnasium (once); returns the ids."""
    if not HAVE_GYMNASIUM:
        return []
    import gymnasium

    ids = []
    for name, (_, constrained) in _core.env_help().items():
        gid = env_id(name)
        ids.append(gid)
        if gid in gymnasium.registry:
            continue
        # Envs with constraints default to ATACOM (as atacom.make_vec), the others to no layer.
        gymnasium.register(id=gid, entry_point=f"{__name__}:make_single_env",
                           vector_entry_point=f"{__name__}:make_vector_env",
                           kwargs={"env": name, "safety": "atacom" if constrained else "none"})
    return ids


__all__ = ["AtacomEnv", "env_id", "make_single_env", "make_vector_env", "register_envs"]
