"""Autoreset as Gymnasium 1.x defines it, in both modes.

Same-step (AutoresetMode.SAME_STEP): the step that ends an episode returns
the next episode's first observation; info["final_obs"] is an object array
(None except for the envs that ended) with mask info["_final_obs"], and
info["final_info"] a dict of batched arrays with "_" masks.
Next-step (AutoresetMode.NEXT_STEP): the step that ends an episode returns
its true last observation; the following step returns the reset observation
with reward 0, terminated = truncated = False, and ignores the action.

Checked against the pendulum's dynamics written out here (every transition
of every env must be the physics or a reset, with the episode length the
mode implies), and on TableEnv without a safety layer, which terminates.
"""
import numpy as np
import pytest

import atacom

H = 5  # pendulum horizon for these tests


def pendulum_step(obs, a, g=10.0, m=1.0, l=1.0, dt=0.05, max_speed=8.0, max_torque=2.0):
    """Pendulum-v1 from the observation (cos, sin, thetadot) and action in [-1, 1]."""
    obs = obs.astype(np.float64)
    th = np.arctan2(obs[:, 1], obs[:, 0])
    thdot = obs[:, 2]
    u = max_torque * np.clip(a[:, 0], -1, 1)
    thn = ((th + np.pi) % (2 * np.pi)) - np.pi
    reward = -(thn**2 + 0.1 * thdot**2 + 0.001 * u**2)
    newthdot = np.clip(thdot + (3 * g / (2 * l) * np.sin(th) + 3.0 / (m * l * l) * u) * dt, -max_speed, max_speed)
    th2 = th + newthdot * dt
    return np.stack([np.cos(th2), np.sin(th2), newthdot], axis=1), reward


def is_reset_obs(o):
    """A pendulum start: theta ~ U(-pi, pi), thetadot ~ U(-1, 1)."""
    return abs(o[0] ** 2 + o[1] ** 2 - 1) < 1e-5 and abs(o[2]) <= 1.0


def check_masked(arr, mask, expected=None):
    assert arr.shape[0] == mask.shape[0]
    assert np.all(arr[~mask] == 0)
    if expected is not None:
        np.testing.assert_array_equal(arr[mask], expected[mask])


@pytest.mark.parametrize("mode", ["same_step", "next_step"])
def test_pendulum_transitions_follow_gymnasium_semantics(mode):
    N = 7
    env = atacom.make_vec("pendulum", N, seed=4, safety="none", config={"horizon": H}, autoreset_mode=mode)
    assert env.metadata["autoreset_mode"] == atacom.AutoresetMode[mode.upper()]
    rng = np.random.default_rng(0)
    obs, _ = env.reset()
    # Stagger the episodes so that ends and resets fall on different steps.
    mask = np.zeros(N, bool)
    mask[::2] = True
    for _ in range(2):
        env.step(rng.uniform(-1, 1, (N, 1)))
    obs, _ = env.reset(options={"reset_mask": mask})
    t = np.where(mask, 0, 2)  # steps taken in the current episode
    pending = np.zeros(N, bool)
    ends = 0
    for step in range(6 * H):
        a = rng.uniform(-1, 1, (N, 1))
        pred, pred_r = pendulum_step(obs, a)
        obs2, r, term, trunc, info = env.step(a)
        assert not term.any()  # Pendulum never terminates
        if mode == "same_step":
            done = trunc
            t += 1
            np.testing.assert_array_equal(trunc, t == H)
            if done.any():
                fo = info["final_obs"]
                assert fo.dtype == object and fo.shape == (N,)
                np.testing.assert_array_equal(info["_final_obs"], done)
                assert all((fo[i] is None) != done[i] for i in range(N))
                final = np.array([fo[i] if done[i] else obs2[i] for i in range(N)])
                fin = info["final_info"]
                np.testing.assert_array_equal(info["_final_info"], done)
                for key in ("abs_theta", "nonfinite_action", "cost", "cost_continuous", "episode_length",
                            "episode_return"):
                    np.testing.assert_array_equal(fin["_" + key], done)
                    check_masked(fin[key], done)
                np.testing.assert_array_equal(fin["episode_length"][done], H)
                check_masked(fin["abs_theta"], done, info["abs_theta"])
                for i in np.flatnonzero(done):
                    assert is_reset_obs(obs2[i]) and not np.allclose(obs2[i], fo[i])
                t[done] = 0
                ends += int(done.sum())
            else:
                assert "final_obs" not in info and "final_info" not in info
                final = obs2
            np.testing.assert_allclose(final, pred, atol=2e-4)
            np.testing.assert_allclose(r, pred_r, rtol=1e-4, atol=1e-4)
        else:
            assert "final_obs" not in info and "final_info" not in info
            live = ~pending
            t[live] += 1
            # reset step of the envs that ended last step: reward 0, no flags, action ignored
            for i in np.flatnonzero(pending):
                assert r[i] == 0 and not trunc[i] and not term[i]
                assert is_reset_obs(obs2[i])
                assert not info["_cost"][i] and not info["_abs_theta"][i] and info["abs_theta"][i] == 0
            t[pending] = 0
            np.testing.assert_allclose(obs2[live], pred[live], atol=2e-4)
            np.testing.assert_allclose(r[live], pred_r[live], rtol=1e-4, atol=1e-4)
            np.testing.assert_array_equal(trunc, t == H)
            assert np.all(info["_cost"] == live)
            if trunc.any():
                np.testing.assert_array_equal(info["_episode_length"], trunc)
                np.testing.assert_array_equal(info["episode_length"][trunc], H)
            pending = trunc.copy()
            ends += int(trunc.sum())
        obs = obs2
    # same-step: an episode every H steps; next-step: every H + 1 (the reset step)
    period = H if mode == "same_step" else H + 1
    assert ends >= N * (6 * H // period) - N


def test_next_step_ignores_the_action_of_the_reset_step():
    N = 4
    env = atacom.make_vec("pendulum", N, seed=2, safety="none", config={"horizon": H}, autoreset_mode="next_step")
    env.reset()
    rng = np.random.default_rng(1)
    for _ in range(H):
        _, _, _, trunc, _ = env.step(rng.uniform(-1, 1, (N, 1)))
    assert trunc.all()
    state = env.save_state()  # includes the pending resets
    a = rng.uniform(-1, 1, (N, 1))
    b = -a
    runs = []
    for first in (a, b):
        env.load_state(state)
        out = [env.step(first)]
        out += [env.step(np.full((N, 1), 0.3)) for _ in range(3)]
        runs.append(out)
    for x, y in zip(*runs):
        for u, v in zip(x[:4], y[:4]):
            np.testing.assert_array_equal(u, v)
    assert np.all(runs[0][0][1] == 0)  # reward 0 on the reset step


def table_pair(seed, N=8):
    kw = dict(seed=seed, safety="none")
    return atacom.make_vec("table", N, autoreset_mode="same_step", **kw), \
        atacom.make_vec("table", N, autoreset_mode="next_step", **kw)


def test_table_terminations_same_step_and_next_step_agree_until_the_reset():
    """On a terminating env: both modes see the same episode; they differ exactly where Gymnasium says."""
    N = 8
    same, nxt = table_pair(seed=15, N=N)  # env 2 collides at step 60 under these actions
    rng = np.random.default_rng(5)
    same.reset()
    nxt.reset()
    for _ in range(200):
        a = rng.uniform(-1, 1, (N, 7))
        o_s, r_s, te_s, tr_s, i_s = same.step(a)
        o_n, r_n, te_n, tr_n, i_n = nxt.step(a)
        done = te_s | tr_s
        np.testing.assert_array_equal(r_s, r_n)
        np.testing.assert_array_equal(te_s, te_n)
        np.testing.assert_array_equal(tr_s, tr_n)
        np.testing.assert_array_equal(i_s["constraints"], i_n["constraints"])
        np.testing.assert_array_equal(i_s["collision"], i_n["collision"])
        np.testing.assert_array_equal(o_s[~done], o_n[~done])
        if not done.any():
            continue
        assert te_s.any()  # the first end is a termination (a collision), not the horizon
        # same-step: final_obs holds what next-step returns as the observation
        for i in np.flatnonzero(done):
            np.testing.assert_array_equal(i_s["final_obs"][i], o_n[i])
            assert not np.array_equal(o_s[i], o_n[i])  # ... and obs is already the next episode's
        fin = i_s["final_info"]
        for key in ("collision", "joint_limit_violation", "cost", "cost_continuous"):
            check_masked(fin[key], done, i_s[key])
        check_masked(fin["constraints"], done, i_s["constraints"])
        assert np.all(fin["episode_length"][done] >= 1)
        # the terminal collision is in final_info and in the top-level columns (summing those counts it)
        assert np.any(fin["collision"][te_s] > 0)
        np.testing.assert_array_equal(i_s["collision"][done], fin["collision"][done])
        # the next step: next-step returns the reset for the ended envs, the others go on identically
        a2 = rng.uniform(-1, 1, (N, 7))
        o_s2, r_s2, te_s2, tr_s2, i_s2 = same.step(a2)
        o_n2, r_n2, te_n2, tr_n2, i_n2 = nxt.step(a2)
        live = ~done
        np.testing.assert_array_equal(o_s2[live], o_n2[live])
        np.testing.assert_array_equal(r_s2[live], r_n2[live])
        assert np.all(r_n2[done] == 0) and not te_n2[done].any() and not tr_n2[done].any()
        assert not np.any(i_n2["_collision"][done]) and np.all(i_n2["_collision"][live])
        break
    else:
        pytest.fail("no episode ended in 200 steps")


def test_table_next_step_action_ignored_after_a_termination():
    N = 8
    _, env = table_pair(seed=3, N=N)
    env.reset()
    rng = np.random.default_rng(9)
    for _ in range(400):
        _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, (N, 7)))
        if term.any():
            break
    else:
        pytest.fail("no termination in 400 random steps")
    ended = term | trunc
    state = env.save_state()
    a = rng.uniform(-1, 1, (N, 7))
    b = a.copy()
    b[ended] = rng.uniform(-1, 1, (int(ended.sum()), 7))  # other actions only for the envs being reset
    outs = []
    for act in (a, b):
        env.load_state(state)
        outs.append([env.step(act)] + [env.step(np.full((N, 7), 0.2)) for _ in range(3)])
    for x, y in zip(*outs):
        for u, v in zip(x[:4], y[:4]):
            np.testing.assert_array_equal(u, v)
        np.testing.assert_array_equal(x[4]["constraints"], y[4]["constraints"])
