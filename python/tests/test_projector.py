"""atacom.project and atacom.Projector: API, statuses, and what projection means."""
import numpy as np
import pytest

import atacom


def problem(rng, N=64, n=4, m=3, k=6):
    return dict(f=0.2 * rng.standard_normal((N, n)), G=rng.standard_normal((N, n, m)),
                J_q=rng.standard_normal((N, k, n)), c=rng.uniform(-0.5, -1e-3, (N, k)),
                alpha=rng.uniform(-1, 1, (N, m)))


def test_result_shapes_dtypes_and_access():
    rng = np.random.default_rng(0)
    p = problem(rng)
    r = atacom.project(**p)
    a, s, lam, status = r  # unpacks as (a, s, lambda, status)
    assert a.shape == (64, 3) and a.dtype == np.float64
    assert s.shape == (64, 6) and lam.shape == (64,) and status.dtype == np.uint32
    assert r.qdot.shape == (64, 4)
    assert r["lambda"] is lam and r.lambda_ is lam and r.a is a
    np.testing.assert_allclose(r.qdot, p["f"] + np.einsum("inm,im->in", p["G"], a), atol=1e-12)
    assert np.all((lam >= 0) & (lam <= 1))
    inside = (status & 1) == 0  # bit 1: the correction alone leaves [-1, 1]^m (then scaled into it)
    assert inside.sum() > 32
    assert np.all(np.abs(a[inside]) <= 1 + 1e-12)
    assert np.all(lam[~inside] == 0)
    np.testing.assert_array_equal(s, np.maximum(-p["c"], 1e-6))  # s = max(-c, tol)


def test_float32_inputs_and_thread_independence():
    rng = np.random.default_rng(1)
    p = problem(rng, N=300)
    r64 = atacom.project(**p)
    r32 = atacom.project(**{k: v.astype(np.float32) for k, v in p.items()})
    assert r32.a.dtype == np.float64
    ref = atacom.project(**{k: v.astype(np.float32).astype(np.float64) for k, v in p.items()})
    np.testing.assert_array_equal(r32.a, ref.a)
    serial = atacom.project(**p, parallel=False)
    np.testing.assert_array_equal(serial.a, r64.a)
    atacom.set_num_threads(1)
    try:
        one = atacom.project(**p)
    finally:
        atacom.set_num_threads(0)
    np.testing.assert_array_equal(one.a, r64.a)
    # env i's result does not depend on the other envs in the batch
    part = atacom.project(**{k: v[100:137] for k, v in p.items()})
    np.testing.assert_array_equal(part.a, r64.a[100:137])


def test_projection_stops_motion_into_an_active_constraint():
    """On the boundary (c = -tol) the constraint's rate J_q qdot is ~ -K_c (c + s) = 0 whatever alpha."""
    rng = np.random.default_rng(2)
    N, n, m = 200, 3, 3
    f = np.zeros((N, n))
    G = np.tile(np.eye(n), (N, 1, 1))
    J = rng.standard_normal((N, 1, n))
    c = np.full((N, 1), -1e-6)
    r = atacom.project(f, G, J, c, rng.uniform(-1, 1, (N, m)))
    rate = np.einsum("ikn,in->ik", J, r.qdot)[:, 0]
    assert np.all(rate <= 1e-4)
    # far from it, the action passes unchanged (up to the tiny slack correction)
    far = atacom.project(f, G, J, np.full((N, 1), -5.0), np.full((N, m), 0.3))
    np.testing.assert_allclose(far.a, 0.3, atol=1e-3)


def test_nonfinite_inputs_give_status_bits_not_exceptions():
    rng = np.random.default_rng(3)
    p = problem(rng, N=4)
    p["alpha"][0, 1] = np.nan
    p["c"][1, 2] = np.inf
    r = atacom.project(**p)
    assert r.status[0] & 2 and atacom.status_flags(r.status[0]) == ["alpha_nonfinite"]
    assert r.status[1] & 4 and np.all(r.a[1] == 0)  # non-finite model: stop
    assert r.status[2] == 0 and r.status[3] == 0
    # a NaN entry of alpha acts as 0 (the other entries stay)
    fixed = dict(p, alpha=p["alpha"].copy())
    fixed["alpha"][0, 1] = 0.0
    z = atacom.project(**{k: v[:1] for k, v in fixed.items()})
    np.testing.assert_array_equal(r.a[0], z.a[0])
    assert z.status[0] == 0


def test_per_row_options_and_persistent_projector():
    rng = np.random.default_rng(4)
    N, n, m, k, pdim = 50, 3, 2, 4, 2
    p = problem(rng, N=N, n=n, m=m, k=k)
    p["J_x"] = rng.standard_normal((N, k, pdim))
    p["xdot"] = rng.standard_normal((N, pdim))
    opts = dict(slack=["softcorner", "exponential", "quadratic", "softcorner"], beta=[1, 2, 3, 4], tol=1e-4,
                K_c=12.0, basis="smooth", equality=[False, False, False, True])
    r = atacom.project(**p, **opts)
    proj = atacom.Projector(N, n, m, k, pdim, **opts)
    for key in ("f", "G", "J_q", "c", "alpha", "J_x", "xdot"):
        getattr(proj, key)[...] = p[key]
    proj.project()
    np.testing.assert_array_equal(proj.a, r.a)
    np.testing.assert_array_equal(proj.s, r.s)
    np.testing.assert_array_equal(proj.lambda_, r.lambda_)
    assert np.all(r.s[:, 3] == 0)  # no slack on the equality row
    model = proj.model
    assert model["slack"] == opts["slack"] and model["tol"] == [1e-4] * 4 and model["basis"] == "smooth"
    assert model["equality"] == opts["equality"] and model["K_c"] == 12.0
    # the options change the result
    default = atacom.project(**p)
    assert not np.allclose(default.a, r.a)
    # refilling the same batch in place
    proj.alpha[...] = 0.0
    proj.project()
    zero = atacom.project(**dict(p, alpha=np.zeros((N, m))), **opts)
    np.testing.assert_array_equal(proj.a, zero.a)


def test_projector_outputs_are_read_only_inputs_writable():
    proj = atacom.Projector(4, 2, 2, 1)
    proj.alpha[...] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        proj.a[...] = 0
    with pytest.raises(ValueError, match=r"N must be an integer in \[1, 2\^31 - 1\]"):
        atacom.Projector(0, 2, 2, 1)
