"""atacom.safelayer: agreement with `atacom filter` "method": "safelayer", the QP's KKT point, errors."""
import json

import numpy as np
import pytest

import atacom


def problem(rng, N=64, n=4, m=3, k=6):
    return dict(f=0.2 * rng.standard_normal((N, n)), G=rng.standard_normal((N, n, m)),
                J_q=rng.standard_normal((N, k, n)), c=rng.uniform(-0.1, 0.01, (N, k)),
                alpha=rng.uniform(-1, 1, (N, m)))


def test_shapes_feasibility_and_threads():
    rng = np.random.default_rng(0)
    p = problem(rng, N=500)
    r = atacom.safelayer(**p, dt=0.1)
    assert r.a.shape == (500, 3) and r.qdot.shape == (500, 4) and r.active.shape == (500, 6)
    assert r.active.dtype == np.bool_ and r.status.dtype == np.uint32
    assert np.all(np.abs(r.a) <= 1)
    np.testing.assert_allclose(r.qdot, p["f"] + np.einsum("inm,im->in", p["G"], r.a), atol=1e-12)
    # predicted rows c + dt J (f + G a) <= 0 wherever the QP was feasible
    pred = p["c"] + 0.1 * np.einsum("ikn,in->ik", p["J_q"], r.qdot)
    ok = (r.status & 1) == 0
    assert ok.sum() > 300
    assert np.all(pred[ok] <= 1e-9)
    np.testing.assert_allclose(np.linalg.norm(r.a - np.clip(p["alpha"], -1, 1), axis=1), r.correction, atol=1e-12)
    serial = atacom.safelayer(**p, dt=0.1, parallel=False)
    np.testing.assert_array_equal(serial.a, r.a)
    assert atacom.safelayer.__module__ == "atacom.safelayer"


def test_agrees_with_the_filter(cli):
    rng = np.random.default_rng(1)
    p = problem(rng, N=20)
    r = atacom.safelayer(**p, threshold=-0.01)
    lines = [json.dumps({"method": "safelayer", "threshold": -0.01, "f": p["f"][i].tolist(), "G": p["G"][i].tolist(),
                         "J_q": p["J_q"][i].tolist(), "c": p["c"][i].tolist(), "alpha": p["alpha"][i].tolist()})
             for i in range(20)]
    rc, stdout, stderr = cli(["filter"], stdin="\n".join(lines) + "\n")
    assert rc == 0, stderr
    for i, line in enumerate(stdout.splitlines()):
        j = json.loads(line)
        np.testing.assert_allclose(j["a"], r.a[i], atol=1e-12)
        assert j["active"] == np.flatnonzero(r.active[i]).tolist()
        assert j["status"] == int(r.status[i])


def test_bad_arguments():
    rng = np.random.default_rng(2)
    p = problem(rng, N=4)
    with pytest.raises(ValueError, match="'dt' must be > 0"):
        atacom.safelayer(**p, dt=0)
    with pytest.raises(ValueError, match="'threshold' has 2 entries"):
        atacom.safelayer(**p, threshold=[0, 0])
    with pytest.raises(ValueError, match="G must have shape"):
        atacom.safelayer(**{**p, "G": p["G"][:, :, :2]})
