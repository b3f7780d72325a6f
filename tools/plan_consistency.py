"""How much recorded episodes agree with each other, and how far one of them carries.

A measuring instrument for docs/journal/study.md (demonstrations from the planner), never needed
to build or test. Reads a `trajectories.bin` (src/play/trajectories.rs) and prints:

- the spread of the starts (standard deviation of every state value at step 0 that varies);
- how different the first actions of episodes with the nearest starts are, against
  random pairs (mean absolute difference per action value): near 0 for demonstrations a
  policy of the state can clone, near the random-pair figure when episodes from the same
  start act unrelatedly;
- with `--replay K S`: each of the first K episodes' actions replayed open loop from S
  other starts (reset seeds 10000..10000+S) on the `reference` table, their score rate.
  Needs the Python front (`maturin develop` in crates/py) and numpy.

    python tools/plan_consistency.py runs/demos/planner-seed1000/trajectories.bin --replay 30 20
"""

from __future__ import annotations

import argparse
import struct

import numpy as np


def read(path: str) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    data = open(path, "rb").read()
    if data[:4] != b"FSBT":
        raise SystemExit(f"{path}: not a trajectories file")
    obs_dim, action_dim, n = struct.unpack("<IIQ", data[8:24])
    at, episodes = 24, []
    for _ in range(n):
        seed, steps = struct.unpack("<QI", data[at : at + 12])
        at += 12
        parts = []
        for width in (obs_dim, action_dim, 1):
            parts.append(np.frombuffer(data, "<f4", steps * width, at).reshape(steps, width))
            at += steps * width * 4
        episodes.append((seed, *parts))
    return episodes


def score_rate(actions: np.ndarray, starts: range) -> float:
    from foosball_rl import FoosballEnv

    env, goals = FoosballEnv(), 0
    for seed in starts:
        env.reset(seed=seed)
        for t in range(4000):
            _, _, terminated, truncated, info = env.step(actions[min(t, len(actions) - 1)])
            if info.get("scored"):
                goals += 1
                break
            if terminated or truncated:
                break
    return goals / len(starts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("file")
    parser.add_argument("--replay", nargs=2, type=int, metavar=("K", "S"))
    args = parser.parse_args()
    episodes = read(args.file)
    first = np.array([e[1][0] for e in episodes])
    varying = np.flatnonzero(first.std(0) > 0)
    print(f"{len(episodes)} episodes; start spread (std) of state values {list(varying)}:",
          np.round(first[:, varying].std(0), 3))
    a0 = np.array([e[2][0] for e in episodes])
    starts = first[:, varying]
    nearest = []
    for i in range(len(episodes)):
        d = np.linalg.norm(starts - starts[i], axis=1)
        d[i] = np.inf
        nearest.append(np.abs(a0[i] - a0[int(np.argmin(d))]).mean())
    rng = np.random.default_rng(0)
    random_pairs = np.abs(a0 - a0[rng.permutation(len(a0))]).mean()
    print(f"first actions, mean |difference|: nearest starts {np.mean(nearest):.3f}, "
          f"random pairs {random_pairs:.3f}")
    if args.replay:
        k, s = args.replay
        rates = [score_rate(e[2], range(10_000, 10_000 + s)) for e in episodes[:k]]
        print(f"open-loop replay of the first {k} episodes from {s} other starts: score rate "
              f"mean {np.mean(rates):.3f}, best {np.max(rates):.3f}")


if __name__ == "__main__":
    main()
