#!/usr/bin/env python3
"""Can HRI-Sim's reach be made with the cup upright? A resolved-rate probe.

Not a learner: at every step it measures, by finite differences through the
env (ATACOM and the moving human included: save_state, one step per action
dimension, load_state), how the action moves the grasping point and the cup
axis, and takes the least-squares action that moves the grasping point
toward the goal at --speed m per step while turning the cup's horizontal
components back toward 0 (gain --gain per step). It prints each episode's
final distance and largest tilt. docs/training.md ("hri: why the cup
spills") uses it to tell a trade-off of the reward from a learning problem:
a reach as fast as the PPO policies' keeps the cup within about 11 deg.
Slow (8 env steps per step, one env): about a minute per episode.

    PYTHONPATH=build/python python3 python/examples/hri_upright_probe.py --episodes 5
"""
import argparse

import numpy as np

import atacom

GRASP = slice(10, 13)  # HRI-Sim's observation: grasping point (docs/envs_arm.md)
GOAL = slice(7, 10)
CUP = slice(16, 19)    # cup axis (unit vector; upright = +z)


def step_obs(env, a):
    obs, _, _, truncated, info = env.step(a[None, :])
    if truncated[0]:  # same-step autoreset: the episode's own last observation
        return np.array(info["final_obs"][0]), info
    return np.array(obs[0]), info


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--speed", type=float, default=0.02, help="m per step toward the goal (30 steps/s)")
    ap.add_argument("--gain", type=float, default=0.3, help="share of the cup's horizontal components removed per step")
    ap.add_argument("--eps", type=float, default=0.2, help="finite-difference action step")
    ap.add_argument("--steps", type=int, default=0, help="steps per episode (0: the env's horizon)")
    args = ap.parse_args()

    env = atacom.make_vec("hri", 1, seed=args.seed, safety="atacom")
    m = env.act_dim
    results = []
    for ep in range(args.episodes):
        obs, _ = env.reset(seed=args.seed + ep)
        obs = np.array(obs[0])
        max_tilt = 0.0
        for t in range(env.horizon if args.steps <= 0 else min(args.steps, env.horizon)):
            snap = env.save_state()
            o0, _ = step_obs(env, np.zeros(m))
            J = np.zeros((6, m))
            for j in range(m):
                env.load_state(snap)
                a = np.zeros(m)
                a[j] = args.eps
                o, _ = step_obs(env, a)
                J[:3, j] = (o[GRASP] - o0[GRASP]) / args.eps
                J[3:, j] = (o[CUP] - o0[CUP]) / args.eps
            env.load_state(snap)
            to_goal = obs[GOAL] - obs[GRASP]
            d = np.linalg.norm(to_goal)
            want_grasp = to_goal / max(d, 1e-9) * min(args.speed, d) - (o0[GRASP] - obs[GRASP])
            cup = obs[CUP]
            want_cup = np.array([-args.gain * cup[0], -args.gain * cup[1], 0.0]) - (o0[CUP] - cup)
            a = np.linalg.lstsq(J, np.concatenate([want_grasp, want_cup]), rcond=1e-3)[0]
            a /= max(1.0, np.abs(a).max())  # into the action box, direction kept
            obs, info = step_obs(env, a)
            max_tilt = max(max_tilt, float(np.degrees(info["tilt"][0])))
        results.append((float(info["distance"][0]), max_tilt))
        print(f"episode {ep}: final distance {results[-1][0]:.3f} m, largest tilt {max_tilt:.1f} deg", flush=True)
    r = np.array(results)
    print(f"mean final distance {r[:, 0].mean():.3f} m; episodes above 25 deg: {int((r[:, 1] > 25).sum())} of {len(r)}, "
          f"above 15 deg: {int((r[:, 1] > 15).sum())}")


if __name__ == "__main__":
    main()
