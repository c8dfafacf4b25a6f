"""Reinforcement learning on learned symbols: tabular Q-learning in the tower cell's abstract states.

A model from ``groundsym learn`` wraps the Gymnasium tower environment (``AbstractStates``), so the
agent sees the learned ground atoms, a 0/1 vector, instead of coordinates; that makes a plain
Q-table possible. The agent trains for ``--episodes`` episodes with epsilon-greedy exploration,
then its greedy policy and a random policy each play ``--test`` new start states; the script
prints their mean episode values ``sum_t gamma^(t-1) r_t`` (gamma 0.8, the task's) and, with
``--plot``, draws the training curve. Learn a model first, e.g.:

    groundsym collect --sim tower --sim-opt cubes=4 --traces 20 -o traces.json
    groundsym learn traces.json -o model --evals 20000
    python examples/gym_abstract.py --model model --cubes 4 --episodes 40 --plot q.png

Every random choice derives from ``--seed``. A tower primitive takes about 0.2 s of simulation, so
40 training episodes of 10 primitives run in a few minutes.
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable

import gymnasium
import numpy as np

from groundsym.gym import AbstractStates

Policy = Callable[[np.ndarray, np.ndarray], int]


def play(env: gymnasium.Env, seed: int, policy: Policy, learn: Callable | None = None) -> float:
    """One episode; returns its discounted value. ``learn(s, a, r, s2, mask2, done)`` updates Q."""
    obs, info = env.reset(seed=seed)
    gamma, value, t, done = env.unwrapped.gamma, 0.0, 0, False
    while not done:
        action = policy(obs, info["action_mask"])
        nxt, reward, term, trunc, info = env.step(action)
        done = term or trunc
        if learn is not None:
            learn(obs, action, reward, nxt, info["action_mask"], term)
        value += gamma ** t * reward
        obs, t = nxt, t + 1
    return value


class QTable:
    """Q-values per abstract state (the vector's bytes), zero for states never seen."""

    def __init__(self, n_actions: int, gamma: float, alpha: float):
        self.q: dict[bytes, np.ndarray] = {}
        self.n, self.gamma, self.alpha = n_actions, gamma, alpha

    def values(self, obs: np.ndarray) -> np.ndarray:
        return self.q.setdefault(obs.tobytes(), np.zeros(self.n))

    def greedy(self, obs: np.ndarray, mask: np.ndarray) -> int:
        v = np.where(mask.astype(bool), self.values(obs), -np.inf)
        return int(np.argmax(v))

    def update(self, obs, action, reward, nxt, mask, terminal) -> None:
        target = reward if terminal else reward + self.gamma * self.values(nxt)[mask.astype(bool)].max()
        row = self.values(obs)
        row[action] += self.alpha * (target - row[action])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", required=True, help="model directory from `groundsym learn` (with symbols.json)")
    p.add_argument("--cubes", type=int, default=4)
    p.add_argument("--episodes", type=int, default=40, help="training episodes")
    p.add_argument("--test", type=int, default=10, help="test episodes per policy")
    p.add_argument("--epsilon", type=float, default=0.3)
    p.add_argument("--alpha", type=float, default=0.3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--plot", help="PNG of the training episodes' values")
    args = p.parse_args(argv)

    env = AbstractStates(gymnasium.make("groundsym/Tower-v0", cubes=args.cubes), args.model)
    rng = np.random.default_rng(args.seed)
    table = QTable(env.action_space.n, env.unwrapped.gamma, args.alpha)

    def random_policy(obs: np.ndarray, mask: np.ndarray) -> int:
        return int(rng.choice(np.flatnonzero(mask)))

    def explore(obs: np.ndarray, mask: np.ndarray) -> int:
        return random_policy(obs, mask) if rng.random() < args.epsilon else table.greedy(obs, mask)

    seeds = rng.integers(2 ** 31, size=args.episodes + args.test)
    curve = []
    for k in range(args.episodes):
        curve.append(play(env, int(seeds[k]), explore, table.update))
        print(f"episode {k + 1}/{args.episodes}: value {curve[-1]:.4f}, "
              f"{len(table.q)} abstract states seen", file=sys.stderr)
    test = [int(s) for s in seeds[args.episodes:]]
    greedy = [play(env, s, table.greedy) for s in test]
    random = [play(env, s, random_policy) for s in test]
    env.close()
    print(f"atoms observed: {len(env.atoms)} ({', '.join(map(str, env.atoms[:4]))}, ...)")
    print(f"abstract states seen in training: {len(table.q)}")
    print(f"greedy Q policy: mean value {np.mean(greedy):.4f} +- {stderr(greedy):.4f} over {len(test)} test episodes")
    print(f"random policy:   mean value {np.mean(random):.4f} +- {stderr(random):.4f} over the same start states")
    if args.plot:
        plot_curve(args.plot, curve, float(np.mean(random)))
    return 0


def stderr(values: list[float]) -> float:
    """Standard error of the mean (0 for a single value)."""
    return float(np.std(values, ddof=1) / np.sqrt(len(values))) if len(values) > 1 else 0.0


def plot_curve(path: str, curve: list[float], random_mean: float) -> None:
    import io

    from matplotlib.figure import Figure

    from groundsym.fileio import atomic_write_bytes

    fig = Figure(figsize=(6, 3.5))
    ax = fig.add_subplot()
    ax.plot(range(1, len(curve) + 1), curve, ".-", label="Q-learning (training, epsilon-greedy)")
    ax.axhline(random_mean, color="grey", ls="--", label="random policy (test mean)")
    ax.set_xlabel("episode")
    ax.set_ylabel("episode value")
    ax.legend()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    atomic_write_bytes(path, buf.getvalue())
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
