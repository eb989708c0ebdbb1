"""PyTorch side of ``skillmimic bench infer|update`` (the same network, batch and threads).

Run as a worker: reads one JSON command per line on stdin and answers one JSON line with the
median seconds of ``reps`` timed calls. Commands::

    {"op": "setup", "obs_dim": 902, "act_dim": 156, "hidden": [1024, 512, 512], "threads": 2}
    {"op": "infer", "batch": 64, "reps": 5}
    {"op": "update", "batch": 4096, "reps": 3}

``update`` is one PPO minibatch step as in the Rust trainer: observation-normaliser update,
normalisation, actor and critic forward, clipped surrogate + 5 x value loss + 10 x bounds loss,
backward, Adam step (lr 2e-5).
"""

from __future__ import annotations

import json
import math
import sys
import time

import torch
from torch import nn


def mlp(sizes):
    layers = []
    for k in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[k], sizes[k + 1]))
        if k + 2 < len(sizes):
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class Bench:
    def setup(self, obs_dim, act_dim, hidden, threads):
        torch.set_num_threads(threads)
        torch.manual_seed(0)
        self.obs_dim, self.act_dim = obs_dim, act_dim
        self.actor = mlp([obs_dim, *hidden, act_dim])
        self.critic = mlp([obs_dim, *hidden, 1])
        self.log_std = torch.full((act_dim,), -2.9)
        self.mean = torch.zeros(obs_dim, dtype=torch.float64)
        self.var = torch.ones(obs_dim, dtype=torch.float64)
        self.count = 1.0
        self.opt = torch.optim.Adam(list(self.actor.parameters()) + list(self.critic.parameters()), lr=2e-5, eps=1e-8)
        return {"ok": True, "torch": torch.__version__, "threads": torch.get_num_threads()}

    def normalize(self, x):
        return ((x.double() - self.mean) / torch.sqrt(self.var + 1e-5)).clamp(-5, 5).float()

    def update_norm(self, x):
        xd = x.double()
        bm, bv, n = xd.mean(0), xd.var(0), x.shape[0]
        delta, tot = bm - self.mean, self.count + n
        m2 = self.var * self.count + bv * n + delta**2 * self.count * n / tot
        self.mean, self.var, self.count = self.mean + delta * n / tot, m2 / tot, tot

    def infer(self, batch, reps):
        obs = torch.randn(batch, self.obs_dim)
        times = []
        with torch.no_grad():
            for _ in range(reps + 1):
                t = time.perf_counter()
                x = self.normalize(obs)
                self.actor(x)
                self.critic(x)
                times.append(time.perf_counter() - t)
        return sorted(times[1:])[len(times[1:]) // 2]

    def update(self, batch, reps):
        obs = torch.randn(batch, self.obs_dim)
        act = torch.randn(batch, self.act_dim) * 0.1
        old = torch.randn(batch) + 0.5 * self.act_dim * math.log(2 * math.pi)
        adv = torch.randn(batch)
        ret = torch.randn(batch)
        sigma = torch.exp(self.log_std)
        times = []
        for _ in range(reps + 1):
            t = time.perf_counter()
            self.update_norm(obs)
            x = self.normalize(obs)
            mu = self.actor(x)
            v = self.critic(x).squeeze(-1)
            neglogp = 0.5 * (((act - mu) / sigma) ** 2).sum(1) + self.log_std.sum() + 0.5 * math.log(2 * math.pi) * self.act_dim
            ratio = torch.exp((old - neglogp).clamp(-20, 20))
            a_loss = torch.max(-adv * ratio, -adv * ratio.clamp(0.8, 1.2)).mean()
            c_loss = ((v - ret) ** 2).mean()
            b_loss = ((mu - 1).clamp(min=0) ** 2 + (-1 - mu).clamp(min=0) ** 2).sum(1).mean()
            loss = a_loss + 5 * c_loss + 10 * b_loss
            self.opt.zero_grad(set_to_none=True)
            loss.backward()
            self.opt.step()
            times.append(time.perf_counter() - t)
        return sorted(times[1:])[len(times[1:]) // 2]


def main():
    b = Bench()
    for line in sys.stdin:
        cmd = json.loads(line)
        op = cmd.pop("op")
        if op == "quit":
            break
        res = b.setup(**cmd) if op == "setup" else {"seconds": getattr(b, op)(**cmd)}
        print(json.dumps(res), flush=True)


if __name__ == "__main__":
    main()
