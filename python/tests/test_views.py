"""copy=False views: they keep the C++ env alive, never dangle; the GIL is released while C++ steps."""
import gc
import sys
import threading
import time
import weakref

import numpy as np
import pytest

import atacom


def test_views_hold_a_reference_to_the_env():
    e = atacom.make_vec("table", 4, seed=0, copy=False)
    core = e._env
    before = sys.getrefcount(core)
    extra = [core.view_obs() for _ in range(10)]
    assert sys.getrefcount(core) == before + 10  # one reference per view
    assert all(v.base is core for v in extra)
    del extra
    assert sys.getrefcount(core) == before


def test_views_outlive_the_env_object_safely():
    e = atacom.make_vec("table", 4, seed=0, copy=False)
    e.reset()
    obs, reward, term, trunc, info = e.step(np.full((4, 7), 0.5))
    constraints = info["constraints"]
    expected = obs.copy(), reward.copy(), constraints.copy()
    alive = weakref.ref(e._env)
    e.close()
    del e
    gc.collect()
    assert alive() is not None  # the views keep the C++ env (and its buffers) alive
    np.testing.assert_array_equal(obs, expected[0])
    np.testing.assert_array_equal(reward, expected[1])
    np.testing.assert_array_equal(constraints, expected[2])
    del obs, reward, term, trunc, info, constraints
    gc.collect()
    assert alive() is None  # ... and only them: the last view frees it


def test_load_state_keeps_views_valid():
    e = atacom.make_vec("nav", 3, seed=1, copy=False)
    obs, _ = e.reset()
    state = e.save_state()
    o1, *_ = e.step(np.zeros((3, 2)))
    first = o1.copy()
    e.load_state(state)
    o2, *_ = e.step(np.zeros((3, 2)))
    assert o2 is o1 and o1.base is e._env
    np.testing.assert_array_equal(o1, first)


def test_projector_views_and_results_own_their_memory():
    p = atacom.Projector(N=5, n=2, m=2, k=1)
    p.G[:] = np.eye(2)
    p.J_q[:, 0, 0] = 1.0
    p.c[:] = -1e-3
    p.alpha[:] = [1.0, 0.5]
    a = p.project().a
    assert a.base is p._core and not a.flags.writeable
    del p
    gc.collect()
    np.testing.assert_allclose(a[:, 1], 0.5)
    rng = np.random.default_rng(0)
    r = atacom.project(f=np.zeros((3, 2)), G=np.tile(np.eye(2), (3, 1, 1)), J_q=rng.standard_normal((3, 1, 2)),
                       c=np.full((3, 1), -0.5), alpha=np.ones((3, 2)))
    a, lam = r.a, r["lambda"]
    del r
    gc.collect()
    assert a.shape == (3, 2) and lam.shape == (3,) and np.all(np.isfinite(a))


def test_step_releases_the_gil():
    """A second thread gets into step() of the same env while the first is inside C++.

    With the GIL held during the C++ step this could never happen; the
    per-env lock turns the overlap into an exception instead of a data race.
    """
    e = atacom.make_vec("table", 2048, seed=0, copy=False)
    e.reset()
    a = np.zeros((2048, 7))
    stop = time.monotonic() + 3.0
    overlaps, errors = [], []

    def worker():
        while time.monotonic() < stop and not overlaps:
            try:
                e.step(a)
            except RuntimeError as ex:
                overlaps.append(str(ex))
            except Exception as ex:  # pragma: no cover
                errors.append(ex)

    threads = [threading.Thread(target=worker) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert overlaps, "the two threads never overlapped in step(): is the GIL released?"
    assert "in use by another thread" in overlaps[0]
    e.step(a)  # and the env is fine afterwards


def test_two_envs_step_concurrently_and_deterministically():
    acts = np.random.default_rng(0).uniform(-1, 1, (20, 256, 7))

    def run(out, idx):
        e = atacom.make_vec("table", 256, seed=9, copy=True)
        e.reset()
        out[idx] = np.stack([e.step(x)[0] for x in acts])

    res = [None, None]
    ts = [threading.Thread(target=run, args=(res, i)) for i in range(2)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    seq = [None]
    run(seq, 0)
    np.testing.assert_array_equal(res[0], res[1])
    np.testing.assert_array_equal(res[0], seq[0])


@pytest.mark.parametrize("copy", [True, False])
def test_final_obs_rows_are_the_true_last_observations(copy):
    e = atacom.make_vec("pendulum", 3, seed=0, safety="none", config={"horizon": 2}, copy=copy)
    e.reset()
    e.step(np.zeros((3, 1)))
    _, _, _, trunc, info = e.step(np.zeros((3, 1)))
    assert trunc.all()
    rows = [info["final_obs"][i].copy() for i in range(3)]
    e.step(np.zeros((3, 1)))
    for i in range(3):
        if copy:
            np.testing.assert_array_equal(info["final_obs"][i], rows[i])  # owned
        else:
            assert not info["final_obs"][i].flags.writeable  # a view that the next step overwrites
