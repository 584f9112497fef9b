"""With Gymnasium importable, make_vec subclasses its VectorEnv and uses its spaces and AutoresetMode.

Gymnasium is not a Debian package, so CI runs this against a stand-in package
with Gymnasium 1.1's names (gymnasium.vector.VectorEnv, AutoresetMode,
gymnasium.vector.utils.batch_space, gymnasium.spaces.Box, gymnasium.Env, and
register / make / make_vec / registry with 1.x's semantics: make calls the
entry point with the spec's kwargs and the caller's and needs a
gymnasium.Env; make_vec calls the vector entry point with num_envs= and
checks metadata["autoreset_mode"]); with the real Gymnasium installed the
same scripts run against it.
"""
import importlib.util
import os
import subprocess
import sys
import textwrap

import atacom

STUB = {
    "gymnasium/__init__.py": textwrap.dedent("""
        import importlib
        registry = {}
        class Env:
            metadata = {"render_modes": []}
            spec = None
            seeded_with = None
            def reset(self, *, seed=None, options=None):
                if seed is not None:
                    self.seeded_with = seed
            @property
            def unwrapped(self):
                return self
        class EnvSpec:
            def __init__(self, id, entry_point, vector_entry_point, kwargs):
                self.id, self.entry_point, self.vector_entry_point, self.kwargs = id, entry_point, vector_entry_point, kwargs
        def _load(entry_point):
            module, attr = entry_point.split(":")
            return getattr(importlib.import_module(module), attr)
        def _spec(id):
            if ":" in id:
                module, id = id.split(":", 1)
                importlib.import_module(module)
            return registry[id]
        def register(id, entry_point=None, vector_entry_point=None, kwargs=None, **ignored):
            registry[id] = EnvSpec(id, entry_point, vector_entry_point, dict(kwargs or {}))
        def make(id, **kwargs):
            spec = _spec(id)
            env = _load(spec.entry_point)(**dict(spec.kwargs, **kwargs))
            assert isinstance(env, Env), type(env)
            env.unwrapped.spec = spec
            return env
        def make_vec(id, num_envs=1, vectorization_mode=None, vector_kwargs=None, wrappers=None, **kwargs):
            spec = _spec(id)
            assert vectorization_mode in (None, "vector_entry_point") and spec.vector_entry_point is not None
            env = _load(spec.vector_entry_point)(num_envs=num_envs, **dict(spec.kwargs, **kwargs))
            from gymnasium.vector import AutoresetMode
            assert isinstance(env.metadata["autoreset_mode"], AutoresetMode)
            env.unwrapped.spec = spec
            return env
        """),
    "gymnasium/spaces.py": textwrap.dedent("""
        import numpy as np
        class Box:
            def __init__(self, low, high, shape=None, dtype=np.float32, seed=None):
                self.dtype = np.dtype(dtype)
                self.shape = tuple(shape) if shape is not None else np.shape(low)
                self.low = np.broadcast_to(np.asarray(low, self.dtype), self.shape).copy()
                self.high = np.broadcast_to(np.asarray(high, self.dtype), self.shape).copy()
            def sample(self):
                return np.random.default_rng(0).uniform(self.low, self.high).astype(self.dtype)
        """),
    "gymnasium/vector/__init__.py": textwrap.dedent("""
        import enum
        class AutoresetMode(enum.Enum):
            NEXT_STEP = "NextStep"
            SAME_STEP = "SameStep"
            DISABLED = "Disabled"
        class VectorEnv:
            metadata = {}
            closed = False
            seeded_with = None
            def reset(self, *, seed=None, options=None):
                self.seeded_with = seed
            def close(self, **kwargs):
                self.closed = True
        """),
    "gymnasium/vector/utils.py": textwrap.dedent("""
        import numpy as np
        from gymnasium.spaces import Box
        def batch_space(space, n):
            reps = (n,) + (1,) * len(space.shape)
            return Box(np.tile(space.low, reps), np.tile(space.high, reps), dtype=space.dtype)
        """),
}

SCRIPT = textwrap.dedent("""
    import numpy as np
    import gymnasium, gymnasium.vector, gymnasium.spaces
    import atacom
    assert atacom.HAVE_GYMNASIUM
    env = atacom.make_vec("pendulum", 3, safety="none", autoreset_mode="next_step")
    assert isinstance(env, gymnasium.vector.VectorEnv)
    assert isinstance(env.single_action_space, gymnasium.spaces.Box)
    assert env.metadata["autoreset_mode"] is gymnasium.vector.AutoresetMode.NEXT_STEP
    assert atacom.AutoresetMode is gymnasium.vector.AutoresetMode
    env.reset(seed=4)
    assert env.seeded_with == 4
    obs, r, te, tr, info = env.step(env.action_space.sample())
    assert obs.shape == (3, 3) and env.observation_space.shape == (3, 3)
    env.close()
    print("ok")
""")


REGISTRATION = textwrap.dedent("""
    import numpy as np
    import gymnasium, gymnasium.vector
    import atacom
    ids = atacom.GYMNASIUM_IDS
    assert "atacom/Table-v0" in ids and "atacom/Nav-v0" in ids and len(ids) == len(atacom.env_names()), ids
    assert all(i in gymnasium.registry for i in ids)
    # make_vec: the batched C++ env itself through the vector entry point, kwargs as atacom.make_vec's
    venv = gymnasium.make_vec("atacom/Table-v0", num_envs=3, seed=4, safety="atacom")
    assert isinstance(venv, atacom.AtacomVectorEnv) and isinstance(venv, gymnasium.vector.VectorEnv)
    assert venv.num_envs == 3 and venv.safety == "atacom" and venv.spec.id == "atacom/Table-v0"
    mine = atacom.make_vec("table", 3, seed=4, safety="atacom")
    a = np.full((3, venv.act_dim), 0.5)
    np.testing.assert_array_equal(venv.reset()[0], mine.reset()[0])
    np.testing.assert_array_equal(venv.step(a)[0], mine.step(a)[0])
    # make: one env behind gymnasium.Env's API; a seeded sequence of episodes equals env 0 of the vector env
    env = gymnasium.make("atacom:atacom/Pendulum-v0", safety="none")
    assert isinstance(env, gymnasium.Env) and env.spec.id == "atacom/Pendulum-v0"
    assert env.observation_space.shape == (3,) and env.action_space.shape == (1,)
    ref = atacom.make_vec("pendulum", 1, seed=9, safety="none")
    obs, info = env.reset(seed=9)
    np.testing.assert_array_equal(obs, ref.reset(seed=9)[0][0])
    ends = 0
    for t in range(450):  # past the 200-step horizon twice
        act = np.array([np.sin(0.1 * t)])
        obs, r, term, trunc, info = env.step(act)
        vobs, vr, vterm, vtrunc, vinfo = ref.step(act[None, :])
        assert isinstance(r, float) and isinstance(term, bool) and "cost" in info and "constraints" in info
        assert r == float(vr[0]) and term == bool(vterm[0]) and trunc == bool(vtrunc[0])
        if term or trunc:
            ends += 1
            np.testing.assert_array_equal(obs, vinfo["final_obs"][0])   # the true last observation
            obs, info = env.reset()                                     # the episode the autoreset started
        np.testing.assert_array_equal(obs, vobs[0])
    assert ends == 2, ends
    env.close()
    print("ok")
""")


def run_with_gymnasium(tmp_path, script):
    if importlib.util.find_spec("gymnasium") is None:
        for rel, text in STUB.items():
            path = tmp_path / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, env=env,
                       cwd=tmp_path)  # not the source tree: its atacom/ has no compiled _core
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stdout + r.stderr


def test_subclasses_gymnasium_when_importable(tmp_path):
    run_with_gymnasium(tmp_path, SCRIPT)


def test_registered_with_gymnasium_make_and_make_vec(tmp_path):
    run_with_gymnasium(tmp_path, REGISTRATION)


def test_no_gymnasium_no_registration():
    assert atacom.HAVE_GYMNASIUM or atacom.GYMNASIUM_IDS == []
