"""With Gymnasium importable, make_vec subclasses its VectorEnv and uses its spaces and AutoresetMode.

Gymnasium is not a Debian package, so this runs against a stand-in package
with Gymnasium 1.1's names (gymnasium.vector.VectorEnv, AutoresetMode,
gymnasium.vector.utils.batch_space, gymnasium.spaces.Box); with the real
Gymnasium installed the same script runs against it.
"""
import importlib.util
import os
import subprocess
import sys
import textwrap

STUB = {
    "gymnasium/__init__.py": "",
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


def test_subclasses_gymnasium_when_importable(tmp_path):
    if importlib.util.find_spec("gymnasium") is None:
        for rel, text in STUB.items():
            path = tmp_path / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=60, env=env,
                       cwd=tmp_path)  # not the source tree: its atacom/ has no compiled _core
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stdout + r.stderr
