#!/usr/bin/env python3
"""Random-policy safety check: is the constraint setup safe before you train?

Runs uniform random actions in every env that has constraints, with and
without ATACOM, and counts ground-truth collisions, constraint violations
(a row above its stated tolerance) and the largest constraint value. With
ATACOM the collisions should be 0 (the process exits 1 if not).

    PYTHONPATH=build/python python3 python/examples/random_safety_check.py
    ... --env table nav --envs 64 --steps 20000 --seed 1
"""
import argparse
import json
import sys

import numpy as np

import atacom


def check(env_name, safety, num_envs, steps, seed):
    env = atacom.make_vec(env_name, num_envs, seed=seed, safety=safety, copy=False)
    env.reset()
    env.action_space.seed(seed)
    collision_cols = [c for c in env.info_names if c.endswith("collision")]
    counts = {c: 0 for c in collision_cols}
    episodes = violations = 0
    max_c = -np.inf
    for _ in range(max(1, steps // num_envs)):
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        episodes += int(np.count_nonzero(terminated | truncated))
        violations += int(np.count_nonzero((info["constraints"] > env.constraint_tolerance).any(axis=1)))
        max_c = max(max_c, float(info["constraints"].max()))
        for c in collision_cols:
            counts[c] += int(np.count_nonzero(info[c]))
    env.close()
    return {"env": env_name, "safety": safety, "steps": max(1, steps // num_envs) * num_envs, "episodes": episodes,
            "violations": violations, "max_constraint": max_c, **{c + "s": n for c, n in counts.items()}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--env", nargs="+", default=["table", "shelf", "nav"], help="env names")
    ap.add_argument("--envs", type=int, default=32, help="parallel envs")
    ap.add_argument("--steps", type=int, default=8000, help="env steps per env kind and safety layer")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    unsafe = False
    print(f"{'env':8} {'safety':8} {'steps':>7} {'episodes':>8} {'collisions':>10} {'violations':>10} "
          f"{'max c':>9}")
    for name in args.env:
        for safety in ("none", "atacom"):
            r = check(name, safety, args.envs, args.steps, args.seed)
            print(f"{name:8} {safety:8} {r['steps']:7d} {r['episodes']:8d} {r['collisions']:10d} "
                  f"{r['violations']:10d} {r['max_constraint']:9.4f}")
            print(json.dumps(r), file=sys.stderr)
            unsafe = unsafe or (safety == "atacom" and r["collisions"] > 0)
    if unsafe:
        print("UNSAFE: collisions under ATACOM", file=sys.stderr)
        return 1
    print("ATACOM: no collisions")
    return 0


if __name__ == "__main__":
    sys.exit(main())
