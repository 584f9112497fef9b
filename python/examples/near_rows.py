#!/usr/bin/env python3
"""Which constraint rows does a trained policy live next to?

Runs a training run's deterministic policy (what its evaluations run) on N
episodes of its env and prints, for the rows it comes closest to, the share
of the steps of a late window (by default the last 300 of 500) with the row
within --within of its boundary (c > -within) and the row's mean value, then
the episodes' final distances. Two policies that end at different distances
show where each one parks the arm. docs/paper_comparison.md ("Why ATACOM-SAC
trails on HRI") reads it: on HRI-Sim, ATACOM-SAC's fast-preset policies hold
the upper arm against the robot's body and wrist joints at their limits,
SafeLayer-SAC's reach over the table.

    PYTHONPATH=build/python python3 python/examples/near_rows.py RUN_DIR
    ... --which best --episodes 20 --seed 12345 --from-step 200 --within 0.05 --top 8
"""
import argparse

import numpy as np

import atacom


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--which", default="final", choices=["final", "best"])
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=12345)
    ap.add_argument("--steps", type=int, default=0, help="steps traced (0: the env's horizon)")
    ap.add_argument("--from-step", type=int, default=200, help="first step of the window counted")
    ap.add_argument("--within", type=float, default=0.05, help="a row is near when c > -within (its units)")
    ap.add_argument("--top", type=int, default=8, help="rows printed")
    args = ap.parse_args()

    policy = atacom.load_policy(args.run_dir, which=args.which)
    n = args.episodes
    env = policy.make_vec(n, seed=args.seed)
    horizon = env.horizon if args.steps <= 0 else min(args.steps, env.horizon)
    if not 0 <= args.from_step < horizon:
        raise SystemExit(f"--from-step is {args.from_step}, must be in [0, {horizon - 1}] (the steps traced)")
    names = list(env.constraint_names)
    obs, _ = env.reset()
    rows, dist = [], np.zeros(n)
    terminated_steps = 0
    for t in range(horizon):
        obs, _, terminated, _, info = env.step(policy(obs))
        terminated_steps += int(np.asarray(terminated).sum())
        if t >= args.from_step:
            rows.append(np.asarray(info["constraints"], dtype=float))
        dist = np.asarray(info["distance"], dtype=float)
    c = np.stack(rows)  # steps x episodes x rows
    near = (c > -args.within).mean(axis=(0, 1))
    print(f"{policy.algo} on {policy.env}, {n} episodes, steps {args.from_step}-{horizon - 1}: "
          f"share of steps with the row within {args.within:g} of its boundary")
    for i in np.argsort(-near, kind="stable")[:args.top]:
        print(f"  {names[i]:28s} {near[i]:.2f}   mean c {c[:, :, i].mean():+.3f}")
    print(f"final distance: mean {dist.mean():.3f} m, per episode {np.round(dist, 2).tolist()}")
    if terminated_steps:
        print(f"{terminated_steps} episodes ended early (collision or joint limit) and restarted")


if __name__ == "__main__":
    main()
