#!/usr/bin/env python3
"""Where in an HRI-Sim episode does a trained policy tilt the cup?

Runs a training run's deterministic policy (what its evaluations run) on N
episodes of its env and prints, per episode, the first step the tilt passed
25 deg and the largest tilt, and per time step the mean and largest tilt,
the mean distance and the mean |action| over the episodes. docs/training.md
("hri: why the cup spills") reads it: the spills of the PPO policies all
start in the first 20 steps of the reach.

    PYTHONPATH=build/python python3 python/examples/hri_tilt_trace.py RUN_DIR
    ... --which best --episodes 20 --seed 12345 --steps 100
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
    ap.add_argument("--spill-deg", type=float, default=25.0)
    ap.add_argument("--steps", type=int, default=0, help="steps per episode traced (0: the env's horizon)")
    args = ap.parse_args()

    policy = atacom.load_policy(args.run_dir, which=args.which)
    if policy.env not in ("hri", "hri-upright"):
        raise SystemExit(f"{args.run_dir}: env {policy.env!r} has no cup (hri or hri-upright only)")
    n = args.episodes
    env = policy.make_vec(n, seed=args.seed)
    obs, _ = env.reset()
    horizon = env.horizon if args.steps <= 0 else min(args.steps, env.horizon)
    tilt = np.zeros((horizon, n))
    dist = np.zeros((horizon, n))
    act = np.zeros((horizon, n))
    for t in range(horizon):  # every env's episode ends at the horizon together (no termination expected)
        a = policy(obs)
        act[t] = np.abs(a).mean(axis=1)
        obs, _, terminated, _, info = env.step(a)
        tilt[t] = np.degrees(info["tilt"])
        dist[t] = info["distance"]
        if terminated.any():
            print(f"step {t}: {int(terminated.sum())} episodes terminated (collision or joint limit)")
    over = tilt > args.spill_deg
    first = [int(np.argmax(over[:, e])) if over[:, e].any() else -1 for e in range(n)]
    print(f"episodes above {args.spill_deg:g} deg: {int(over.any(axis=0).sum())} of {n}; above 15 deg: "
          f"{int((tilt > 15).any(axis=0).sum())}")
    print("first step above it, per episode (-1: never):", first)
    print("largest tilt per episode (deg):", np.round(tilt.max(axis=0)).astype(int).tolist())
    print(f"final distance: mean {dist[-1].mean():.3f} m")
    for t in (0, 5, 10, 20, 40, 60, 100, 150, 200, 300, 400, horizon - 1):
        if t < horizon:
            print(f"t={t:3d}  tilt mean {tilt[t].mean():5.1f} max {tilt[t].max():5.1f} deg  distance {dist[t].mean():.3f} m"
                  f"  |a| {act[t].mean():.2f}  share above {args.spill_deg:g} deg {over[t].mean():.2f}")


if __name__ == "__main__":
    main()
