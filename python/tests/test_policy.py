"""atacom.load_policy: a training run's policy on NumPy observations equals `atacom rollout --policy trained`."""
import json
import os

import numpy as np
import pytest

import atacom

SMALL_RUN = {"sac": {"actor": {"hidden": [16, 16]}, "critic": {"hidden": [16, 16]}, "batch_size": 16,
                     "initial_replay": 100, "warmup": 100, "replay_capacity": 2000},
             "train": {"env": "nav", "algo": "atacom-sac", "steps": 400, "num_envs": 2, "eval_every": 200,
                       "eval_episodes": 2, "seed": 1}}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, cli):
    d = tmp_path_factory.mktemp("policy")
    cfg = d / "config.json"
    cfg.write_text(json.dumps(SMALL_RUN))
    rc, out, err = cli(["train", "--config", str(cfg), "--out", str(d / "run")])
    assert rc == 0, err
    return str(d / "run")


def python_rollout(policy, steps, N, seed):
    """`atacom rollout --policy trained` against the Python API: deterministic actions, the same counts."""
    env = policy.make_vec(N, seed=seed, copy=False)
    obs, _ = env.reset()
    tol = env.constraint_tolerance
    out = dict(episodes=0, terminations=0, violations=0)
    max_c = -np.inf
    done_steps = 0
    for _ in range((steps + N - 1) // N):
        active = min(N, steps - done_steps)
        obs, _, term, trunc, info = env.step(policy(obs))
        s = slice(0, active)
        out["episodes"] += int((term | trunc)[s].sum())
        out["terminations"] += int(term[s].sum())
        c = info["constraints"][s]
        max_c = max(max_c, float(c.max()))
        out["violations"] += int((c > tol).any(axis=1).sum())
        done_steps += active
    out["steps"] = done_steps
    out["max_constraint"] = max_c
    return out


@pytest.mark.parametrize("which", ["final", "best"])
def test_policy_equals_the_cli_rollout(cli, run_dir, which):
    policy = atacom.load_policy(run_dir, which=which)
    assert (policy.env, policy.algo, policy.safety) == ("nav", "atacom-sac", "atacom")
    rc, out, err = cli(["rollout", "--policy", "trained", "--run", run_dir, "--which", which,
                        "--steps", "600", "--envs", "3", "--seed", "5"])
    assert rc == 0, err
    ref = json.loads(out)
    got = python_rollout(policy, 600, 3, 5)
    for key, value in got.items():
        assert ref[key] == value, f"{key}: CLI {ref[key]}, Python {value}"
    assert got["episodes"] > 0 or got["max_constraint"] != 0.0  # the comparison is not of empty counts


def test_sampled_actions(run_dir):
    policy = atacom.load_policy(run_dir)
    env = policy.make_vec(4, seed=2)
    obs, _ = env.reset()
    det = policy(obs)
    assert det.shape == (4, policy.act_dim) and det.dtype == np.float64
    np.testing.assert_array_equal(det, policy(obs.astype(np.float64)))  # float64 obs are cast to float32
    # one observation -> one action (float32 GEMMs of another batch size may differ in the last bits)
    np.testing.assert_allclose(det[1], policy(obs[1]), rtol=0, atol=1e-5)
    policy.seed(7)
    a = policy(obs, deterministic=False)
    b = policy(obs, deterministic=False)
    assert np.all(np.abs(a) <= 1.0) and not np.array_equal(a, det) and not np.array_equal(a, b)
    policy.seed(7)
    np.testing.assert_array_equal(policy(obs, deterministic=False), a)   # reproducible from the seed
    policy.seed(7)
    np.testing.assert_allclose(policy(obs[:2], deterministic=False), a[:2], rtol=0, atol=1e-5)  # row i: stream (seed, i)


def test_errors_name_the_problem(tmp_path, run_dir):
    with pytest.raises(ValueError, match="which must be 'final' or 'best'"):
        atacom.load_policy(run_dir, which="last")
    with pytest.raises(ValueError, match="config.json"):
        atacom.load_policy(str(tmp_path))
    policy = atacom.load_policy(run_dir)
    with pytest.raises(ValueError, match=f"obs must have shape \\(N, {policy.obs_dim}\\)"):
        policy(np.zeros((2, policy.obs_dim + 1), dtype=np.float32))
    broken = tmp_path / "broken"
    broken.mkdir()
    for f in ("config.json", "policy_final.bin"):
        data = open(os.path.join(run_dir, f), "rb").read()
        (broken / f).write_bytes(data if f == "config.json" else data[:-9] + b"corrupted")
    with pytest.raises(ValueError):
        atacom.load_policy(str(broken))
