"""atacom: safe reinforcement learning on the tangent space of the constraint manifold.

The C++ engine's batched envs as a Gymnasium-style vector env with the
constraint vector in the open, and the ATACOM projector as a batched NumPy
function for your own systems:

    import atacom
    env = atacom.make_vec("table", 64, seed=0, safety="atacom")
    obs, info = env.reset()
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

    r = atacom.project(f, G, J_q, c, alpha)     # r.a, r.s, r.lambda_, r.status

    policy = atacom.load_policy("runs/table")  # a training run's policy: policy(obs) -> actions

With Gymnasium importable, every env is also registered with it:
gymnasium.make_vec("atacom/Table-v0", num_envs=64) and gymnasium.make("atacom/Table-v0").

Data files (robot models) are found next to this package (data/), or in
ATACOM_DATA_DIR when that is set.
"""
import json as _json
import os as _os
import warnings as _warnings

from ._build_check import check_numpy as _check_numpy

_check_numpy()  # a python3 without NumPy: name it and the one the module was built for
try:
    from . import _core
except ImportError as _e:  # the extension is missing or was built for another Python: say which
    from ._build_check import import_error as _import_error

    raise _import_error(_e) from None

_DATA = _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), "data")
if _os.path.isdir(_DATA):
    _core.set_data_dir(_DATA)

from ._arrays import MAX_THREADS, as_count  # noqa: E402
from ._core import RandomStreams, data_dir, env_names, num_threads  # noqa: E402
from .projector import STATUS_FLAGS, Projector, ProjectResult, project, status_flags  # noqa: E402
from .safelayer import SafeLayerResult, safelayer  # noqa: E402
from .spaces import HAVE_GYMNASIUM, Box  # noqa: E402
from .vector_env import AtacomVectorEnv, AutoresetMode, make_vec  # noqa: E402
from .policy import LoadedPolicy, load_policy  # noqa: E402
from .gym_registration import env_id as gymnasium_id, register_envs as _register_envs  # noqa: E402

GYMNASIUM_IDS = _register_envs()  # "atacom/Table-v0", ... when Gymnasium is importable, else []


def default_config(env):
    """The env's default config (what make_vec's config overrides)."""
    return _json.loads(_core.default_env_config(env))


def set_num_threads(threads):
    """Worker threads of the C++ side, as the CLI's --threads: 0 = all cores,
    else an integer in [0, 1024]; more than this machine's cores are clamped
    to them (with a RuntimeWarning). Results do not depend on it."""
    threads = as_count(threads, "threads", 0, MAX_THREADS)
    _core.set_num_threads(0)
    cores = _core.num_threads()
    if threads > cores:
        _warnings.warn(f"set_num_threads({threads}) is more than the {cores} cores here; using {cores}",
                       RuntimeWarning, stacklevel=2)
        threads = cores
    _core.set_num_threads(threads)


def safety_layers():
    """Names make_vec's safety= accepts."""
    return list(_core.safety_layer_names())


__all__ = [
    "AtacomVectorEnv", "AutoresetMode", "Box", "GYMNASIUM_IDS", "HAVE_GYMNASIUM", "LoadedPolicy", "ProjectResult",
    "Projector", "RandomStreams", "STATUS_FLAGS", "SafeLayerResult", "data_dir", "default_config", "env_names",
    "gymnasium_id", "load_policy", "make_vec", "num_threads", "project", "safelayer", "safety_layers",
    "set_num_threads", "status_flags",
]
