#!/usr/bin/env python3
"""A compact PyTorch SAC trained through ATACOM on TableEnv: learning with zero collisions.

The agent's action is ATACOM's alpha: the env projects it onto the tangent
space of the constraint manifold before the arm moves, so the random
exploration of early training cannot hit the table, the robot's body or the
joint limits. The script prints progress and, at the end, the training
collisions and violations (0 is the claim; it exits 1 otherwise).

    PYTHONPATH=build/python python3 python/examples/sac_torch.py            # 5000 env steps, about 20 s on 2 quiet cores
    ... --steps 20000 --envs 8 --seed 1 --safety none                       # the same without ATACOM: collisions

Needs PyTorch (Debian: apt-get install python3-torch); without it the script
says so and exits 0.
"""
import argparse
import json
import sys
import time

import numpy as np

try:
    import torch
    import torch.nn as nn
    import torch.nn.functional as F
except ImportError:
    print("sac_torch.py skipped: PyTorch is not installed (Debian: apt-get install python3-torch)")
    sys.exit(0)

import atacom


def mlp(inp, out, hidden):
    return nn.Sequential(nn.Linear(inp, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, out))


class Actor(nn.Module):
    """Tanh-squashed Gaussian policy: actions in [-1, 1]^m (what the env takes)."""

    def __init__(self, obs_dim, act_dim, hidden):
        super().__init__()
        self.net = mlp(obs_dim, 2 * act_dim, hidden)

    def forward(self, obs, deterministic=False):
        mu, log_std = self.net(obs).chunk(2, dim=-1)
        log_std = log_std.clamp(-20, 2)
        std = log_std.exp()
        u = mu if deterministic else mu + std * torch.randn_like(mu)
        a = torch.tanh(u)
        logp = (-0.5 * ((u - mu) / std) ** 2 - log_std - 0.5 * np.log(2 * np.pi)).sum(-1)
        logp = logp - (2 * (np.log(2) - u - F.softplus(-2 * u))).sum(-1)
        return a, logp


class Critic(nn.Module):
    """Twin Q networks."""

    def __init__(self, obs_dim, act_dim, hidden):
        super().__init__()
        self.q1, self.q2 = mlp(obs_dim + act_dim, 1, hidden), mlp(obs_dim + act_dim, 1, hidden)

    def forward(self, obs, act):
        x = torch.cat([obs, act], -1)
        return self.q1(x).squeeze(-1), self.q2(x).squeeze(-1)


class Replay:
    def __init__(self, capacity, obs_dim, act_dim):
        self.o = np.zeros((capacity, obs_dim), np.float32)
        self.a = np.zeros((capacity, act_dim), np.float32)
        self.r = np.zeros(capacity, np.float32)
        self.o2 = np.zeros((capacity, obs_dim), np.float32)
        self.d = np.zeros(capacity, np.float32)
        self.capacity, self.size, self.ptr = capacity, 0, 0

    def add(self, o, a, r, o2, d):
        n = len(o)
        idx = (self.ptr + np.arange(n)) % self.capacity
        self.o[idx], self.a[idx], self.r[idx], self.o2[idx], self.d[idx] = o, a, r, o2, d
        self.ptr = (self.ptr + n) % self.capacity
        self.size = min(self.size + n, self.capacity)

    def sample(self, batch, rng):
        i = rng.integers(0, self.size, batch)
        return [torch.as_tensor(x[i]) for x in (self.o, self.a, self.r, self.o2, self.d)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--env", default="table")
    ap.add_argument("--safety", default="atacom", help="atacom or none")
    ap.add_argument("--steps", type=int, default=5000, help="env steps in total (over all envs)")
    ap.add_argument("--envs", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--warmup", type=int, default=1000, help="env steps of uniform random actions first")
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--hidden", type=int, default=256)
    ap.add_argument("--lr", type=float, default=3e-4)
    ap.add_argument("--gamma", type=float, default=0.99)
    ap.add_argument("--tau", type=float, default=5e-3)
    ap.add_argument("--updates-per-step", type=float, default=0.5, help="gradient updates per env step")
    ap.add_argument("--log-every", type=int, default=1000, help="env steps between progress lines")
    args = ap.parse_args()

    torch.manual_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    env = atacom.make_vec(args.env, args.envs, seed=args.seed, safety=args.safety)
    N, d, m = env.num_envs, env.obs_dim, env.act_dim
    actor, critic = Actor(d, m, args.hidden), Critic(d, m, args.hidden)
    target = Critic(d, m, args.hidden)
    target.load_state_dict(critic.state_dict())
    log_alpha = torch.zeros(1, requires_grad=True)
    opt_actor = torch.optim.Adam(actor.parameters(), lr=args.lr)
    opt_critic = torch.optim.Adam(critic.parameters(), lr=args.lr)
    opt_alpha = torch.optim.Adam([log_alpha], lr=args.lr)
    replay = Replay(max(args.steps, 1), d, m)
    collision_cols = [c for c in env.info_names if c.endswith("collision")]

    def update():
        o, a, r, o2, done = replay.sample(args.batch, rng)
        alpha = log_alpha.exp().detach()
        with torch.no_grad():
            a2, logp2 = actor(o2)
            q_next = torch.min(*target(o2, a2)) - alpha * logp2
            y = r + args.gamma * (1 - done) * q_next
        q1, q2 = critic(o, a)
        loss_q = F.mse_loss(q1, y) + F.mse_loss(q2, y)
        opt_critic.zero_grad()
        loss_q.backward()
        opt_critic.step()
        a_new, logp = actor(o)
        loss_pi = (alpha * logp - torch.min(*critic(o, a_new))).mean()
        opt_actor.zero_grad()
        loss_pi.backward()
        opt_actor.step()
        loss_alpha = -(log_alpha * (logp.detach() - m).mean())  # target entropy -m
        opt_alpha.zero_grad()
        loss_alpha.backward()
        opt_alpha.step()
        with torch.no_grad():
            for p, tp in zip(critic.parameters(), target.parameters()):
                tp.mul_(1 - args.tau).add_(args.tau * p)

    obs, _ = env.reset()
    ep_ret = np.zeros(N)
    returns, collisions, violations, episodes, updates, budget = [], 0, 0, 0, 0, 0.0
    steps, t0, next_log = 0, time.time(), args.log_every
    while steps < args.steps:
        if steps < args.warmup:
            act = rng.uniform(-1, 1, (N, m)).astype(np.float32)
        else:
            with torch.no_grad():
                act = actor(torch.as_tensor(obs))[0].numpy()
        obs2, reward, term, trunc, info = env.step(act)
        done = term | trunc
        # Same-step autoreset: the transition's next state is the true last observation.
        nxt = obs2.copy()
        if done.any():
            for i in np.flatnonzero(done):
                nxt[i] = info["final_obs"][i]
        replay.add(obs, act, reward, nxt, term.astype(np.float32))  # bootstrap through truncation
        ep_ret += reward
        collisions += sum(int(np.count_nonzero(info[c])) for c in collision_cols)
        violations += int(np.count_nonzero((info["constraints"] > env.constraint_tolerance).any(axis=1)))
        for i in np.flatnonzero(done):
            returns.append(ep_ret[i])
            ep_ret[i] = 0.0
        episodes += int(done.sum())
        obs = obs2
        steps += N
        if steps >= args.warmup:
            budget += args.updates_per_step * N
            while budget >= 1:
                update()
                updates += 1
                budget -= 1
        if steps >= next_log or steps >= args.steps:
            next_log += args.log_every
            recent = np.mean(returns[-10:]) if returns else float("nan")
            sps = steps / (time.time() - t0)
            print(f"steps {steps:6d}  updates {updates:6d}  episodes {episodes:4d}  return(last 10) {recent:9.1f}  "
                  f"collisions {collisions}  violations {violations}  {sps:6.0f} steps/s  "
                  f"ETA {(args.steps - steps) / max(sps, 1e-9):5.0f} s", flush=True)

    summary = {"env": args.env, "safety": args.safety, "steps": steps, "updates": updates, "episodes": episodes,
               "train_collisions": collisions, "train_violations": violations,
               "first_returns": [float(x) for x in returns[:3]], "last_returns": [float(x) for x in returns[-3:]],
               "wall_s": round(time.time() - t0, 1)}
    print(json.dumps(summary))
    if args.safety == "atacom" and collisions:
        print("collisions during training under ATACOM", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
