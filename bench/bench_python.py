#!/usr/bin/env python3
"""bench_python: the Python module's cost over the native C++ paths.

One JSON object per line, like the C++ benches:
  {"bench": "env_step_python", "env": "table", "safety": "atacom", "N": 4096, "threads": 2, "copy": false,
   "autoreset_mode": "same_step", "per_s": ..., "native_per_s": ..., "share_of_native": ...,
   "core_per_s": ..., "share_of_core": ..., "overhead_us_per_step": ...}
      agent env steps per second through make_vec(...).step() (float64 actions, 8 pre-drawn uniform
      sets cycled, autoreset included) next to build/bench/bench_envs for the same env, N and threads,
      measured alternately (--pairs times each, the best kept: the machine is shared); core_per_s is
      the same C++ step called through the bare binding (_core.BatchEnv.step) in this process, so
      overhead_us_per_step = time per step() of the Python layer (checks, info dict, copies).
  {"bench": "project_python", "variant": "project" | "projector_inplace" | "numpy", "N": 16384, "k": 34,
   "m": 7, "n": 7, "threads": 2, "per_s": ..., "native_per_s": ..., "share_of_native": ...,
   "max_abs_diff_a": ...}
      projections per second: atacom.project() (inputs copied in, outputs allocated), a persistent
      atacom.Projector refilled in place (no copy), and a batched NumPy implementation written here
      (QR of [I; A^-1 J_G] per env, as the kernel; its difference to the kernel is reported), next to
      build/bench/bench_projector --quick (dense G, all outputs).

    PYTHONPATH=build/python python3 bench/bench_python.py                 # everything (~3 min)
    ... --env table --N 4096 --threads 2                                  # one env configuration
    ... --skip-projector / --skip-envs
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np

import atacom

HERE = os.path.dirname(os.path.abspath(__file__))
SAFETY = {"table": "atacom", "shelf": "atacom", "nav": "atacom", "pendulum": "none"}


def emit(line):
    print(json.dumps(line), flush=True)


def best_seconds_per_call(fn, repeats, min_round_s):
    """As bench_common.hpp: warm-up, then the best of `repeats` rounds of at least min_round_s."""
    fn()
    best = float("inf")
    for _ in range(repeats):
        calls, t0 = 0, time.perf_counter()
        while True:
            fn()
            calls += 1
            t1 = time.perf_counter()
            if t1 - t0 >= min_round_s:
                break
        best = min(best, (t1 - t0) / calls)
    return best


def native_env(build, env, safety, N, threads, repeats, round_s):
    out = subprocess.run([os.path.join(build, "bench", "bench_envs"), "--env", env, "--N", str(N), "--threads",
                          str(threads), "--atacom", "on" if safety == "atacom" else "off", "--repeats", str(repeats),
                          "--round-seconds", str(round_s)], capture_output=True, text=True, check=True).stdout
    return json.loads(out.splitlines()[0])["per_s"]


def python_env(env_name, safety, N, threads, copy, mode, repeats, round_s):
    atacom.set_num_threads(threads)
    env = atacom.make_vec(env_name, N, seed=1, safety=safety, copy=copy, autoreset_mode=mode)
    env.reset()
    rng = np.random.default_rng(2)
    acts = [rng.uniform(-1, 1, (N, env.act_dim)) for _ in range(8)]
    state = {"i": 0}
    step = env.step

    def one():
        step(acts[state["i"]])
        state["i"] = (state["i"] + 1) & 7

    sec = best_seconds_per_call(one, repeats, round_s)
    # The same C++ step through the bare binding (no Python layer), in this process on the same data.
    core_step = env._env.step

    def bare():
        core_step(acts[state["i"]])
        state["i"] = (state["i"] + 1) & 7

    core_sec = best_seconds_per_call(bare, repeats, round_s)
    env.close()
    return N / sec, N / core_sec


def bench_envs(args):
    for env_name in args.env:
        safety = SAFETY[env_name]
        for N in args.N:
            for threads in args.threads:
                native, py, core = 0.0, {}, {}
                for _ in range(args.pairs):
                    native = max(native, native_env(args.build, env_name, safety, N, threads, args.repeats,
                                                    args.round_seconds))
                    for copy in (False, True):
                        for mode in args.modes:
                            key = (copy, mode)
                            per_s, core_per_s = python_env(env_name, safety, N, threads, copy, mode, args.repeats,
                                                           args.round_seconds)
                            py[key] = max(py.get(key, 0.0), per_s)
                            core[key] = max(core.get(key, 0.0), core_per_s)
                for (copy, mode), per_s in py.items():
                    emit({"bench": "env_step_python", "env": env_name, "safety": safety, "N": N,
                          "threads": threads, "copy": copy, "autoreset_mode": mode, "per_s": per_s,
                          "native_per_s": native, "share_of_native": per_s / native,
                          "core_per_s": core[(copy, mode)], "share_of_core": per_s / core[(copy, mode)],
                          "overhead_us_per_step": (N / per_s - N / core[(copy, mode)]) * 1e6})


# ------------------------------------------------------------------ projector

def projector_problem(N, n, m, k, seed=1):
    rng = np.random.default_rng(seed)
    return dict(f=rng.standard_normal((N, n)), G=rng.standard_normal((N, n, m)), J_q=rng.standard_normal((N, k, n)),
                c=rng.uniform(-1.0, 0.05, (N, k)), alpha=rng.uniform(-1, 1, (N, m)))


def project_numpy(f, G, J_q, c, alpha, beta=3.0, tol=1e-6, K_c=30.0):
    """ATACOM in NumPy, batched (SoftCorner slack, projected basis, no equality rows).

    With J_G = J_q G and A = diag(a(s)): b = -argmin_x |x|^2 + |A^-1 (J_G x + r)|^2 and
    N_a = (I + J_G^T A^-2 J_G)^-1, both from the QR of [I; A^-1 J_G] (as the kernel), then
    the sign-aware scale lambda keeps b + lambda N_a alpha inside [-1, 1]^m.
    """
    N, m = alpha.shape
    alpha = np.clip(np.where(np.isfinite(alpha), alpha, 0.0), -1.0, 1.0)
    s = np.maximum(-c, tol)
    rate = np.minimum(np.exp(beta * s), 1.0 / tol) - 1.0
    JG = J_q @ G                                               # (N, k, m)
    r = np.einsum("ikn,in->ik", J_q, f) + K_c * (c + s)        # (N, k)
    B = np.concatenate([np.broadcast_to(np.eye(m), (N, m, m)), JG / rate[:, :, None]], axis=1)
    Q, R = np.linalg.qr(B)                                     # (N, m + k, m), (N, m, m)
    rhs = np.concatenate([np.zeros((N, m)), -r / rate], axis=1)
    b = np.linalg.solve(R, np.einsum("ijm,ij->im", Q, rhs)[..., None])[..., 0]
    Rt_inv_alpha = np.linalg.solve(np.swapaxes(R, 1, 2), alpha[..., None])
    t = np.linalg.solve(R, Rt_inv_alpha)[..., 0]               # N_a alpha = R^-1 R^-T alpha
    with np.errstate(divide="ignore", invalid="ignore"):
        lim = np.where(t > 0, (1.0 - b) / t, np.where(t < 0, (-1.0 - b) / t, np.inf))
    lam = np.minimum(1.0, lim.min(axis=1))
    out = np.any(np.abs(b) > 1.0, axis=1)
    lam = np.where(out | ~(lam > 0), 0.0, lam)
    return b + lam[:, None] * t


def native_projector(build, threads):
    out = subprocess.run([os.path.join(build, "bench", "bench_projector"), "--quick"], capture_output=True,
                         text=True, check=True).stdout
    for line in out.splitlines():
        j = json.loads(line)
        if (j.get("bench") == "projector" and j["N"] == 16384 and j["k"] == 34 and j["m"] == 7
                and j["G"] == "dense" and j["slack_out"] and j["threads"] == threads and "variant" not in j):
            return j["per_s"]
    raise RuntimeError("bench_projector printed no N = 16384, k = 34, m = 7 line")


def bench_projector(args):
    N, n, m, k = 16384, 7, 7, 34
    p = projector_problem(N, n, m, k)
    ref = atacom.project(**p).a
    proj = atacom.Projector(N, n, m, k)
    for key in ("f", "G", "J_q", "c", "alpha"):
        getattr(proj, key)[...] = p[key]
    a_np = project_numpy(**p)
    for threads in args.threads:
        native, best = 0.0, {}
        for _ in range(args.pairs):
            native = max(native, native_projector(args.build, threads))
            atacom.set_num_threads(threads)
            runs = {"project": lambda: atacom.project(**p), "projector_inplace": proj.project}
            if threads == args.threads[0]:
                runs["numpy"] = lambda: project_numpy(**p)
            for name, fn in runs.items():
                sec = best_seconds_per_call(fn, 3, args.round_seconds)
                best[name] = max(best.get(name, 0.0), N / sec)
        for name, per_s in best.items():
            line = {"bench": "project_python", "variant": name, "N": N, "k": k, "m": m, "n": n,
                    "threads": threads if name != "numpy" else 1, "per_s": per_s, "native_per_s": native,
                    "share_of_native": per_s / native}
            if name == "numpy":
                line["max_abs_diff_a"] = float(np.max(np.abs(a_np - ref)))
                line["note"] = "NumPy's own threads (BLAS); native_per_s is the 2-thread kernel"
            emit(line)


def _number(kind, lo, hi):
    """An argparse type: the whole text a decimal number of `kind` in [lo, hi]
    (as every numeric flag of atacom and of the C++ benches: no hex, no
    underscores, no spaces, no NaN/inf); argparse turns the error into exit 2."""
    pattern = r"[+-]?[0-9]+" if kind is int else r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?"

    def parse(text):
        if not re.fullmatch(pattern, text):
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'} "
                                             f"in [{lo}, {hi}]")
        value = kind(text)
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'} "
                                             f"in [{lo}, {hi}]")
        return value
    return parse


def main():
    ap = argparse.ArgumentParser(description="bench_python: Python module vs the native C++ benches")
    ap.add_argument("--build", default=os.path.join(os.path.dirname(HERE), "build"), help="build directory")
    ap.add_argument("--env", nargs="+", default=["table", "nav", "pendulum"])
    ap.add_argument("--N", nargs="+", type=_number(int, 1, 2**20), default=[1, 256, 4096])
    ap.add_argument("--threads", nargs="+", type=_number(int, 1, 1024), default=[2])
    ap.add_argument("--modes", nargs="+", default=["same_step"], help="autoreset modes to time")
    ap.add_argument("--pairs", type=_number(int, 1, 1000), default=2, help="alternating native/Python measurements (best kept)")
    ap.add_argument("--repeats", type=_number(int, 1, 10000), default=5)
    ap.add_argument("--round-seconds", type=_number(float, 1e-3, 600.0), default=0.2)
    ap.add_argument("--skip-envs", action="store_true")
    ap.add_argument("--skip-projector", action="store_true")
    args = ap.parse_args()
    if not args.skip_envs:
        bench_envs(args)
    if not args.skip_projector:
        bench_projector(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
