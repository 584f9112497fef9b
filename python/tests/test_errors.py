"""Bad input gets a Python exception naming the problem, never a crash."""
import numpy as np
import pytest

import atacom
from atacom import _core


@pytest.fixture(scope="module")
def table():
    return atacom.make_vec("table", 3, seed=0)


@pytest.mark.parametrize("kwargs,exc,pattern", [
    (dict(env="tabel"), ValueError, r"unknown env 'tabel' \(known: table, shelf, nav, hri, hri-upright, pendulum"),
    (dict(env=3), TypeError, "env must be a name"),
    (dict(env="table", safety="atacomm"), ValueError, r"unknown safety layer 'atacomm' \(known: none, atacom"),
    (dict(env="pendulum", safety="atacom"), ValueError, "no constraint model"),
    (dict(env="table", config={"horizn": 10}), ValueError, r"unknown config key 'env.horizn' \(known in 'env': .*horizon"),
    (dict(env="table", config={"reward": {"rho": 1}}), ValueError, r"'env.reward.rho' \(known in 'env.reward': .*rho_d"),
    (dict(env="table", config={"horizon": "long"}), ValueError, "config key 'env.horizon' has type string"),
    (dict(env="table", config={"horizon": float("nan")}), ValueError, "finite numbers"),
    (dict(env="table", config=[1]), TypeError, "config must be a dict"),
    (dict(env="table", num_envs=0), ValueError, r"num_envs must be an integer in \[1, 2\^20\], got 0"),
    (dict(env="table", num_envs=2**20 + 1), ValueError, r"num_envs must be an integer in \[1, 2\^20\], got 1048577"),
    (dict(env="table", num_envs=2**31), ValueError, r"num_envs must be an integer in \[1, 2\^20\]"),
    (dict(env="table", num_envs=2.5), TypeError, "num_envs must be an integer"),
    (dict(env="table", seed=-1), ValueError, r"seed must be in \[0, 2\*\*64\)"),
    (dict(env="table", seed=2**64), ValueError, "seed must be in"),
    (dict(env="table", seed="0"), TypeError, "seed must be an integer"),
    (dict(env="table", autoreset_mode="disabled"), ValueError, "autoreset_mode must be 'same_step' or 'next_step'"),
])
def test_make_vec_errors(kwargs, exc, pattern):
    kwargs = dict(dict(num_envs=2), **kwargs)
    with pytest.raises(exc, match=pattern):
        atacom.make_vec(**kwargs)


@pytest.mark.parametrize("actions,exc,pattern", [
    (np.zeros((3, 6)), ValueError, r"actions must have shape \(3, 7\), got \(3, 6\)"),
    (np.zeros((7,)), ValueError, r"actions must have 2 dimensions \(3, 7\), got shape \(7,\)"),
    (np.zeros((3, 7), dtype=np.complex128), TypeError, "actions has dtype complex128, which cannot be cast safely"),
    (np.array([["a"] * 7] * 3), TypeError, "cannot be cast safely"),
    (np.zeros((3, 7), dtype=object), TypeError, "dtype object"),
    (np.zeros((3, 7), dtype=np.longdouble), TypeError, "cannot be cast safely"),
    ([[0.0] * 7] * 2 + [[0.0] * 6], TypeError, "could not be converted|cannot be cast"),
    (None, TypeError, "cannot be cast safely"),
])
def test_step_errors(table, actions, exc, pattern):
    table.reset()
    with pytest.raises(exc, match=pattern):
        table.step(actions)
    table.step(np.zeros((3, 7)))  # the env is fine afterwards


def test_reset_errors(table):
    with pytest.raises(ValueError, match="seed must be one integer"):
        table.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match="cannot be combined"):
        table.reset(seed=1, options={"reset_mask": np.ones(3, bool)})
    with pytest.raises(TypeError, match="options must be a dict"):
        table.reset(options=[1])
    with pytest.raises(TypeError, match="booleans"):
        table.reset(options={"reset_mask": np.array([0.5, 1, 0])})


def test_core_rejects_what_the_python_layer_would_catch():
    """The bindings check again, so calling _core directly cannot read out of bounds."""
    e = _core.BatchEnv("pendulum", 2, "none", "{}")
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 1\)"):
        e.step(np.zeros((1, 1)))
    with pytest.raises(ValueError, match="float64"):
        e.step(np.zeros((2, 1), np.float32))
    with pytest.raises(ValueError, match="C-contiguous"):
        e.step(np.zeros((2, 2))[:, :1])
    with pytest.raises(ValueError, match="reset mask"):
        e.reset(np.ones(5, bool))
    with pytest.raises(RuntimeError):
        e.load_state(b"garbage")
    with pytest.raises(ValueError, match=r"num_envs must be an integer in \[1, 2\^20\]"):
        _core.BatchEnv("pendulum", 0, "none", "{}")
    with pytest.raises(ValueError, match=r"num_envs must be an integer in \[1, 2\^20\]"):
        _core.BatchEnv("pendulum", 2**20 + 1, "none", "{}")
    with pytest.raises(ValueError, match="f must have shape"):
        _core.project('{"n": 2, "m": 2, "k": 1}', np.zeros((3, 3)), np.zeros((3, 2, 2)), np.zeros((3, 1, 2)),
                      np.zeros((3, 1)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="only dense G"):
        _core.Projector('{"n": 2, "m": 2, "k": 1, "g_form": "diagonal"}', 4)


def prob(N=4, n=3, m=2, k=2):
    rng = np.random.default_rng(0)
    return dict(f=rng.standard_normal((N, n)), G=rng.standard_normal((N, n, m)), J_q=rng.standard_normal((N, k, n)),
                c=-rng.uniform(0.1, 1, (N, k)), alpha=rng.uniform(-1, 1, (N, m)))


@pytest.mark.parametrize("change,exc,pattern", [
    (dict(G=np.zeros((4, 3, 3))), ValueError, r"G must have shape \(4, 3, 2\), got \(4, 3, 3\)"),
    (dict(J_q=np.zeros((4, 2, 2))), ValueError, r"J_q must have shape \(4, 2, 3\)"),
    (dict(c=np.zeros((5, 2))), ValueError, "same number of rows N"),
    # A c of the wrong width is c's fault (J_q fits f): issue 28 item 11.
    (dict(c=np.zeros((4, 3))), ValueError, r"c must have shape \(4, 2\) \(one value per row of J_q"),
    (dict(f=np.zeros(3)), ValueError, "f must have 2 dimensions"),
    (dict(alpha=np.zeros((4, 2), np.complex64)), TypeError, "alpha has dtype complex64"),
    (dict(J_x=np.zeros((4, 2, 1))), ValueError, "J_x and xdot must be given together"),
    (dict(J_x=np.zeros((4, 2, 2)), xdot=np.zeros((4, 1))), ValueError, r"J_x must have shape \(4, 2, 1\)"),
    (dict(slack="soft"), ValueError, r"unknown slack type 'soft' \(softcorner, exponential, quadratic\)"),
    (dict(slack=["softcorner"]), ValueError, r"'slack' has 1 entries, expected one per constraint \(2\)"),
    (dict(beta=-1.0), ValueError, "beta.0. must be finite and > 0"),
    (dict(beta=float("nan")), ValueError, "'beta' is NaN or infinite"),
    (dict(beta="3"), TypeError, "'beta' must be a number"),
    (dict(tol=2.0), ValueError, r"tol\[0\] must be in \(0, 1\)"),
    (dict(K_c=-1.0), ValueError, "K_c must be finite and >= 0"),
    (dict(basis="orthonormal"), ValueError, r"unknown basis 'orthonormal' \(projected, smooth\)"),
    (dict(equality=[1, 0]), TypeError, r"'equality\[0\]' must be True or False"),
    (dict(equality=[True, True, True]), ValueError, "'equality' has 3 entries"),
])
def test_project_errors(change, exc, pattern):
    p = prob()
    p.update(change)
    with pytest.raises(exc, match=pattern):
        atacom.project(**p)


def test_project_more_equalities_than_controls():
    with pytest.raises(ValueError, match="more equality rows than controls"):
        atacom.project(**prob(k=3), equality=True)


# Issue 28 item 11: the Projector's attributes, num_envs, load_state and set_num_threads.
def test_projector_attributes_are_read_only_or_checked_on_assignment():
    p = atacom.Projector(3, 2, 2, 1)
    p.f[...] = 0.0
    p.G[...] = np.eye(2)
    p.J_q[...] = [[1.0, 0.0]]
    p.c[...] = -1.0
    p.alpha = np.array([[0.5, 0.5], [1.0, 0.0], [0.0, -1.0]])  # copied in: the kernel sees it
    assert p.project().a.shape == (3, 2)
    assert np.allclose(p.alpha, [[0.5, 0.5], [1.0, 0.0], [0.0, -1.0]])
    before = p.a.copy()
    p.alpha = np.zeros((3, 2))
    p.project()
    assert not np.array_equal(p.a, before), "the new alpha must reach the kernel, not be set aside"
    with pytest.raises(ValueError, match=r"alpha must have shape \(3, 2\), got \(1, 2\)"):
        p.alpha = np.zeros((1, 2))
    with pytest.raises(ValueError, match=r"alpha must have shape \(3, 2\), got \(3, 3\)"):
        p.alpha = np.zeros((3, 3))
    with pytest.raises(AttributeError, match="output of project"):
        p.a = np.zeros((3, 2))
    with pytest.raises(AttributeError, match="fixed"):
        p.N = 5
    with pytest.raises(AttributeError):
        p.alpah = np.zeros((3, 2))  # a typo is an error, not a new attribute


def test_load_state_refuses_trailing_bytes_and_keeps_state():
    env = atacom.make_vec("pendulum", 2, seed=0, safety="none")
    env.reset()
    state = env.save_state()
    obs_before = env.step(np.full((2, 1), 0.3))[0].copy()
    with pytest.raises(ValueError, match="100 bytes after the snapshot's end"):
        env.load_state(state + b"x" * 100)
    env.load_state(state)
    assert np.array_equal(env.step(np.full((2, 1), 0.3))[0], obs_before)


def test_set_num_threads_is_range_checked_and_clamped_like_the_cli():
    with pytest.raises(ValueError, match=r"threads must be an integer in \[0, 1024\], got -1"):
        atacom.set_num_threads(-1)
    with pytest.raises(ValueError, match=r"threads must be an integer in \[0, 1024\]"):
        atacom.set_num_threads(10**6)
    with pytest.raises(ValueError, match=r"threads must be an integer in \[0, 1024\]"):
        _core.set_num_threads(-1)
    try:
        with pytest.warns(RuntimeWarning, match="more than the"):
            atacom.set_num_threads(1024)
        assert atacom.num_threads() < 1024
    finally:
        atacom.set_num_threads(0)
