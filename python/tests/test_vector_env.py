"""make_vec: the Gymnasium VectorEnv interface, shapes, dtypes, masks, state."""
import numpy as np
import pytest

import atacom

N = 6


@pytest.fixture(params=[("table", "atacom"), ("nav", "atacom"), ("pendulum", "none")], ids=lambda p: "-".join(p))
def env(request):
    name, safety = request.param
    e = atacom.make_vec(name, N, seed=3, safety=safety)
    yield e
    e.close()


def random_actions(env, rng):
    return rng.uniform(-1, 1, size=(env.num_envs, env.act_dim)).astype(np.float32)


def test_spaces_and_attributes(env):
    assert env.num_envs == N
    d, m, k = env.obs_dim, env.act_dim, len(env.constraint_names)
    assert env.single_observation_space.shape == (d,)
    assert env.single_observation_space.dtype == np.float32
    assert env.single_action_space.shape == (m,)
    assert np.all(env.single_action_space.low == -1) and np.all(env.single_action_space.high == 1)
    assert env.observation_space.shape == (N, d)
    assert env.action_space.shape == (N, m)
    assert env.metadata["autoreset_mode"] == atacom.AutoresetMode.SAME_STEP
    assert env.constraint_tolerance.shape == (k,)
    assert set(env.info_reduce) == set(env.info_names)
    assert set(env.info_role) == set(env.info_names)
    if env.env_name != "pendulum":  # (the pendulum has no contact and no goal: only diagnostics)
        # Exactly one column counts any contact (the runs' collision count) and one is the quality metric.
        assert list(env.info_role.values()).count("any_contact") == 1
        assert list(env.info_role.values()).count("goal_distance") == 1
        assert env.info_role["collision"] == "any_contact" and env.info_role["final_distance"] == "goal_distance"
    else:
        assert set(env.info_role.values()) == {"diagnostic"}
    if env.env_name == "table":
        assert (d, m, k) == (16, 7, 34)
    s = env.action_space.sample()
    assert s.shape == (N, m) and env.action_space.contains(s)


def test_step_shapes_dtypes_and_info_columns(env):
    obs, info = env.reset()
    assert obs.shape == (N, env.obs_dim) and obs.dtype == np.float32
    assert env.observation_space.contains(obs) or not env.single_observation_space.is_bounded()
    k = len(env.constraint_names)
    assert info["constraints"].shape == (N, k) and info["constraints"].dtype == np.float64
    rng = np.random.default_rng(0)
    obs, reward, terminated, truncated, info = env.step(random_actions(env, rng))
    assert obs.shape == (N, env.obs_dim) and obs.dtype == np.float32
    assert reward.shape == (N,) and reward.dtype == np.float32
    assert terminated.shape == (N,) and terminated.dtype == np.bool_
    assert truncated.shape == (N,) and truncated.dtype == np.bool_
    assert info["cost"].shape == (N,) and info["cost"].dtype == np.float32
    assert info["constraints"].shape == (N, k) and info["constraints"].dtype == np.float64
    assert info["constraint_names"] == env.constraint_names
    for name in env.info_names:
        assert info[name].shape == (N,) and info[name].dtype == np.float32, name
        assert info["_" + name].shape == (N,) and info["_" + name].all(), name
    assert info["cost_continuous"].shape == (N,) and info["cost_continuous"].dtype == np.float32
    # cost_continuous is max(0, max_i c_i) of the constraints the step reached; cost is 1 exactly
    # when a row exceeds its tolerance or a cost event (collision, joint limit) happened
    if k:
        np.testing.assert_allclose(info["cost_continuous"], np.maximum(0, info["constraints"].max(axis=1)), rtol=1e-6)
        events = np.zeros(N, dtype=bool)
        for name in env.cost_events:
            events |= info[name] > 0
        want = np.any(info["constraints"] > env.constraint_tolerance, axis=1) | events
        np.testing.assert_array_equal(info["cost"], want.astype(np.float32))
    else:
        assert not info["cost"].any() and not info["cost_continuous"].any()
    if env.safety == "atacom":
        assert info["atacom_status"].dtype == np.uint32
        np.testing.assert_allclose(info["max_constraint"], info["constraints"].max(axis=1), rtol=1e-6)
    obs2, reward2, cost2, term2, trunc2, info2 = env.step_with_cost(random_actions(env, rng))
    assert cost2 is info2["cost"] and cost2.shape == (N,)


def test_reset_mask_resets_only_masked_envs(env):
    rng = np.random.default_rng(1)
    env.reset()
    for _ in range(5):
        obs, *_ = env.step(random_actions(env, rng))
    before = env.save_state()
    mask = np.zeros(N, dtype=bool)
    mask[[1, 4]] = True
    obs_r, info = env.reset(options={"reset_mask": mask})
    np.testing.assert_array_equal(obs_r[~mask], obs[~mask])
    assert np.all(np.any(obs_r[mask] != obs[mask], axis=1))
    np.testing.assert_array_equal(info["_constraints"], mask)
    # the untouched envs continue exactly as without the reset
    a = random_actions(env, rng)
    after_mask, *_ = env.step(a)
    env.load_state(before)
    plain, *_ = env.step(a)
    np.testing.assert_array_equal(after_mask[~mask], plain[~mask])
    # 0/1 integer masks work too; anything else is an error naming the option
    env.reset(options={"reset_mask": mask.astype(np.int64)})
    with pytest.raises(ValueError, match=r"reset_mask.*shape \(6,\)"):
        env.reset(options={"reset_mask": np.ones(N + 1, bool)})
    with pytest.raises(ValueError, match="unknown reset option 'mask'.*reset_mask"):
        env.reset(options={"mask": mask})


def test_seed_streams_and_determinism():
    rng = np.random.default_rng(2)
    acts = [rng.uniform(-1, 1, size=(8, 7)) for _ in range(30)]

    def run(seed, threads, n=8):
        atacom.set_num_threads(threads)
        e = atacom.make_vec("table", n, seed=seed, safety="atacom")
        out = [e.reset()[0]]
        for a in acts:
            out.append(e.step(a[:n])[0])
        atacom.set_num_threads(0)
        return np.stack(out)

    a, b, c = run(5, 1), run(5, 2), run(6, 2)
    np.testing.assert_array_equal(a, b)  # thread count does not matter
    assert not np.array_equal(a, c)
    # env i has stream (seed, i): the first envs of a larger batch see the same episodes
    np.testing.assert_array_equal(run(5, 2, n=3), a[:, :3])
    # reset(seed=s) re-keys the streams exactly like make_vec(seed=s)
    e = atacom.make_vec("table", 8, seed=0)
    e.step(acts[0])
    obs, _ = e.reset(seed=5)
    np.testing.assert_array_equal(obs, a[0])


def test_reset_continues_streams_after_steps():
    e = atacom.make_vec("pendulum", 4, seed=1, safety="none")
    o0, _ = e.reset()
    o1, _ = e.reset()  # a second reset starts new episodes
    assert not np.array_equal(o0, o1)
    e2 = atacom.make_vec("pendulum", 4, seed=1, safety="none")
    np.testing.assert_array_equal(e2.reset()[0], o0)  # the first reset keeps the seeded episodes


def test_save_load_state_round_trip_bitwise(env):
    rng = np.random.default_rng(3)
    env.reset()
    for _ in range(3):
        env.step(random_actions(env, rng))
    state = env.save_state()
    assert isinstance(state, bytes) and len(state) > 0
    acts = [random_actions(env, rng) for _ in range(20)]
    first = [env.step(a) for a in acts]
    env.load_state(state)
    second = [env.step(a) for a in acts]
    for x, y in zip(first, second):
        for u, v in zip(x[:4], y[:4]):
            np.testing.assert_array_equal(u, v)
        np.testing.assert_array_equal(x[4]["constraints"], y[4]["constraints"])


def test_load_state_rejects_foreign_snapshots_and_keeps_state():
    a = atacom.make_vec("pendulum", 4, seed=0, safety="none")
    b = atacom.make_vec("pendulum", 5, seed=0, safety="none")
    t = atacom.make_vec("table", 4, seed=0, safety="none")
    a.reset()
    good = a.save_state()
    before, *_ = a.step(np.zeros((4, 1)))
    for bad, pattern in ((b.save_state(), "5 envs"), (t.save_state(), ""), (good[: len(good) // 2], "")):
        a.load_state(good)
        with pytest.raises((RuntimeError, ValueError), match=pattern):
            a.load_state(bad)
        after, *_ = a.step(np.zeros((4, 1)))  # the failed load left the restored state untouched
        np.testing.assert_array_equal(after, before)
    with pytest.raises(TypeError, match="bytes"):
        a.load_state("not bytes")


def test_nan_actions_are_zero_and_counted():
    plain = atacom.make_vec("table", 2, seed=0, safety="none")
    plain.reset()
    start = plain.save_state()
    a = np.zeros((2, 7))
    a[0, 3] = np.nan
    a[1, :] = np.inf
    o_bad, _, _, _, info = plain.step(a)
    np.testing.assert_array_equal(info["nan_action"], [1, 7])  # arm: NaN/Inf entries treated as 0, counted
    plain.load_state(start)
    o_zero, _, _, _, info = plain.step(np.zeros((2, 7)))
    np.testing.assert_array_equal(o_bad, o_zero)  # ... and the step is the zero action's
    np.testing.assert_array_equal(info["nan_action"], [0, 0])
    safe = atacom.make_vec("table", 2, seed=0, safety="atacom")
    safe.reset()
    _, _, _, _, info = safe.step(a)
    assert np.all(info["atacom_status"] & 2)  # ATACOM: the projector's alpha_nonfinite bit
    assert "alpha_nonfinite" in atacom.status_flags(info["atacom_status"][0])
    _, _, _, _, info = safe.step(np.zeros((2, 7)))
    assert not np.any(info["atacom_status"] & 2)
    pend = atacom.make_vec("pendulum", 1, seed=0, safety="none")
    pend.reset()
    _, _, _, _, info = pend.step(np.array([[np.nan]]))
    assert info["nonfinite_action"][0] == 1


def test_actions_accept_safe_dtypes_and_torch_like_inputs():
    e = atacom.make_vec("pendulum", 3, seed=0, safety="none")
    e.reset()
    state = e.save_state()
    outs = []
    for a in (np.full((3, 1), 0.5, np.float64), np.full((3, 1), 0.5, np.float32), [[0.5], [0.5], [0.5]]):
        e.load_state(state)
        outs.append(e.step(a)[0])
    for o in outs[1:]:
        np.testing.assert_array_equal(o, outs[0])
    e.load_state(state)
    e.step(np.ones((3, 1), np.int64))  # integers cast safely
    e.step(np.asfortranarray(np.ones((3, 1))))  # any memory layout


def test_copy_true_returns_owned_arrays():
    e = atacom.make_vec("table", 4, seed=0, copy=True)
    obs, _ = e.reset()
    o1, r1, te1, tr1, i1 = e.step(np.zeros((4, 7)))
    keep = o1.copy(), i1["constraints"].copy()
    o1[:] = 7.0  # the caller's own: writable, and writing changes nothing in the env
    e.step(np.zeros((4, 7)))
    assert np.all(o1 == 7.0)
    np.testing.assert_array_equal(i1["constraints"], keep[1])


def test_copy_false_views_are_overwritten_and_read_only():
    e = atacom.make_vec("table", 4, seed=0, copy=False)
    e.reset()
    o1, r1, te1, tr1, i1 = e.step(np.zeros((4, 7)))
    snapshot = o1.copy()
    o2, *_ = e.step(np.ones((4, 7)))
    assert o2 is o1  # the same view, overwritten in place
    assert not np.array_equal(o1, snapshot)
    for arr in (o1, r1, te1, tr1, i1["cost"], i1["constraints"], i1["collision"]):
        assert not arr.flags.writeable and not arr.flags.owndata
        with pytest.raises(ValueError, match="read-only"):
            arr[...] = 0


def test_closed_env_raises():
    e = atacom.make_vec("pendulum", 2, safety="none")
    e.close()
    e.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        e.step(np.zeros((2, 1)))
    with pytest.raises(RuntimeError, match="closed"):
        e.reset()
