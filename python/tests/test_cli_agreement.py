"""The module and the `atacom` executable agree: rollouts (seeding) and the filter (projector)."""
import json

import numpy as np
import pytest

import atacom


def python_rollout(env_name, safety, steps, N, seed, policy="random"):
    """`atacom rollout` written against the Python API: same seed, same policy streams, same counts."""
    env = atacom.make_vec(env_name, N, seed=seed, safety=safety, copy=False)
    env.reset()
    # The rollout's action streams: Rng(seed ^ 0xA5A5A5A5, i + 2^40), m uniform draws per env and step.
    streams = atacom.RandomStreams(seed ^ 0xA5A5A5A5, [i + (1 << 40) for i in range(N)])
    m, tol = env.act_dim, env.constraint_tolerance
    collision_cols = [c for c in env.info_names if c.endswith("collision")]
    out = dict(episodes=0, terminations=0, violations=0, nonfinite_constraints=0)
    sums = {c: 0.0 for c in collision_cols}
    max_c = -np.inf
    done_steps = 0
    for _ in range((steps + N - 1) // N):
        active = min(N, steps - done_steps)
        a = streams.uniform(-1.0, 1.0, m) if policy == "random" else np.zeros((N, m))
        _, _, term, trunc, info = env.step(a)
        s = slice(0, active)
        out["episodes"] += int((term | trunc)[s].sum())
        out["terminations"] += int(term[s].sum())
        c = info["constraints"][s]
        finite = np.isfinite(c)
        out["nonfinite_constraints"] += int((~finite).sum())
        if finite.any():
            max_c = max(max_c, float(c[finite].max()))
        out["violations"] += int((np.where(finite, c, -np.inf) > tol).any(axis=1).sum())
        for col in collision_cols:
            sums[col] += float(info[col][s].astype(np.float64).sum())
        done_steps += active
    out["steps"] = done_steps
    out["max_constraint"] = max_c if len(tol) else None
    for col, v in sums.items():
        out[col + "s"] = int(round(v))
    return out


@pytest.mark.parametrize("env_name,safety,steps,N,seed", [
    ("table", "none", 4000, 8, 1),
    ("table", "atacom", 2000, 8, 2),
    ("nav", "none", 4000, 8, 1),
    ("nav", "atacom", 1000, 5, 3),
])
def test_rollout_counts_equal_the_cli(cli, env_name, safety, steps, N, seed):
    rc, stdout, stderr = cli(["rollout", "--env", env_name, "--policy", "random",
                              "--atacom", "on" if safety == "atacom" else "off",
                              "--steps", str(steps), "--envs", str(N), "--seed", str(seed)])
    assert rc == 0, stderr
    ref = json.loads(stdout)
    got = python_rollout(env_name, safety, steps, N, seed)
    for key, value in got.items():
        assert ref[key] == value, f"{key}: CLI {ref[key]}, Python {value}"
    if safety == "none":
        assert ref["collisions"] > 0 or ref["terminations"] > 0  # the comparison is not of zeros only


def random_problem(rng, N, n, m, k, p):
    prob = dict(f=0.3 * rng.standard_normal((N, n)), G=rng.standard_normal((N, n, m)),
                J_q=rng.standard_normal((N, k, n)), c=rng.uniform(-1.0, 0.05, (N, k)),
                alpha=rng.uniform(-1.2, 1.2, (N, m)))
    if p:
        prob["J_x"] = rng.standard_normal((N, k, p))
        prob["xdot"] = rng.standard_normal((N, p))
    return prob


CASES = [
    (dict(n=2, m=2, k=1, p=0), {}),
    (dict(n=7, m=7, k=34, p=0), {}),
    (dict(n=3, m=2, k=5, p=2), dict(slack=["softcorner", "exponential", "quadratic", "softcorner", "quadratic"],
                                    beta=[1.0, 2.0, 3.0, 4.0, 5.0], tol=1e-4, K_c=10.0)),
    (dict(n=4, m=3, k=4, p=0), dict(basis="smooth", beta=2.5)),
    (dict(n=4, m=3, k=4, p=0), dict(equality=[True, False, False, False], K_c=0.0)),
    (dict(n=3, m=3, k=0, p=0), {}),
]


def filter_line(prob, i, opts):
    line = {key: prob[key][i].tolist() for key in ("f", "G", "J_q", "c", "alpha")}
    if "xdot" in prob:
        line["J_x"] = prob["J_x"][i].tolist()
        line["xdot"] = prob["xdot"][i].tolist()
    line.update(opts)
    line["id"] = i
    return json.dumps(line)


@pytest.mark.parametrize("dims,opts", CASES, ids=[f"case{i}" for i in range(len(CASES))])
def test_project_agrees_with_the_filter(cli, dims, opts):
    rng = np.random.default_rng(sum(dims.values()) + len(opts))
    N = 40
    prob = random_problem(rng, N, **dims)
    stdin = "\n".join(filter_line(prob, i, opts) for i in range(N)) + "\n"
    rc, stdout, stderr = cli(["filter"], stdin=stdin)
    assert rc == 0, stdout[:500] + stderr
    ref = [json.loads(line) for line in stdout.splitlines()]
    assert [r["id"] for r in ref] == list(range(N))
    r = atacom.project(**prob, **opts)
    for key in ("a", "qdot", "s", "lambda"):
        expected = np.array([row[key] for row in ref], dtype=np.float64).reshape(r[key].shape)
        np.testing.assert_allclose(r[key], expected, rtol=0, atol=1e-12, err_msg=key)
    np.testing.assert_array_equal(r.status, [row["status"] for row in ref])
    for i in range(N):
        assert atacom.status_flags(r.status[i]) == ref[i]["status_flags"]
    # the statuses are not all trivial in these batches
    if dims["k"] >= 4:
        assert np.any(r.lambda_ < 1.0)
