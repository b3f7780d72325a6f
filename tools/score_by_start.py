"""Where a run's test episodes score: the score rate by the ball's start across the table
(x, world cm), and how much several runs' scoring starts overlap (docs/journal/study.md, "Where
the learner scores"). Reads the test's `trajectories.bin` (kept on the machine that ran
the test, not committed); numpy only.

    python tools/score_by_start.py results/recipe-v4/sac-recipe-seed{0,1,2,3,4}
    python tools/score_by_start.py RUN... --test evaluate-last-on-reference   # another game's test
    python tools/score_by_start.py RUN --first-actions   # and how its first actions follow x
    python tools/score_by_start.py RUN --test evaluate-last-stochastic --at-bound 4 --split-x -0.22
        # sampled episodes: the score rate where the first midfield slide sat at a bound or not
    python tools/score_by_start.py RUN --mujoco results/transfer/NAME.json   # beside the MuJoCo model's

Prints, for the first run, the score rate in 12 bins of the start's x; then for every
other run the chance that it scores on a start where the first one scores and where the
first one does not (equal chances: the two score on unrelated starts).
"""
import argparse
import json
import os

import numpy as np

from plan_consistency import read

GOAL_LINE_WORLD = 61.0  # the joint frame's 65 cm, world y (joint origin at y = -4)


def read_episodes(run, test="test"):
    """The episodes of `run`'s `test` directory (its `trajectories.bin`)."""
    return read(os.path.join(run, test, "trajectories.bin"))


def scored_starts(episodes):
    """Start x (world cm) and whether each episode scored."""
    x = np.array([obs[0, 0] for _, obs, _, _ in episodes])
    scored = np.array([bool((obs[:, 1] > GOAL_LINE_WORLD).any()) for _, obs, _, _ in episodes])
    return x, scored


def first_actions(episodes, x, steps=3):
    """How the first `steps` actions of the episodes follow the ball's start x (`x`, one
    per episode): each action value's mean, spread and correlation with x."""
    print("| step | action: mean over episodes | spread (std) | correlation with start x |")
    print("| --- | --- | --- | --- |")
    fmt = lambda v: " ".join(f"{u:+.3f}" for u in v)
    for t in range(steps):
        long_enough = np.array([len(acts) > t for _, _, acts, _ in episodes])
        a = np.array([acts[t] for (_, _, acts, _), keep in zip(episodes, long_enough) if keep])
        xs = x[long_enough]
        corr = [np.corrcoef(xs, a[:, j])[0, 1] if a[:, j].std() > 1e-6 else 0.0 for j in range(a.shape[1])]
        print(f"| {t} | {fmt(a.mean(0))} | {fmt(a.std(0))} | {fmt(corr)} |")


def at_bound(episodes, x, scored, j, split_x):
    """The score rate of the episodes whose first action `j` sat at -1 or +1 against those
    where it lay inside, on the starts left of `split_x` (world cm) and right of it."""
    a = np.array([acts[0][j] for _, _, acts, _ in episodes])
    bound = np.abs(a) >= 0.9999
    print(f"| starts | first action {j} | episodes | score rate |\n| --- | --- | --- | --- |")
    for side, m in [(f"x < {split_x}", x < split_x), (f"x >= {split_x}", x >= split_x)]:
        for label, k in [("at -1 or +1", bound), ("inside", ~bound)]:
            n = (m & k).sum()
            rate = f"{scored[m & k].mean():.3f}" if n else "-"
            print(f"| {side} | {label} | {n} | {rate} |")


def beside_model(x, scored, path, bins=6):
    """The score rate by start x in `bins` sextiles of the run's own starts, beside the
    MuJoCo model's episodes of a `tools/transfer.py --out` file (its `per_episode` starts,
    joint frame, whose x is the world's)."""
    per = json.load(open(path))["per_episode"]
    mx = np.array([e["start"][0] for e in per])
    ms = np.array([e["scored"] for e in per])
    edges = np.quantile(x, np.linspace(0, 1, bins + 1))
    print(f"| start x (cm) | ours: episodes, score rate | the MuJoCo model ({path}): episodes, score rate |")
    print("| --- | --- | --- |")
    for lo, hi in zip(edges[:-1], edges[1:]):
        o, m = (x >= lo) & (x <= hi), (mx >= lo) & (mx <= hi)
        theirs = f"{m.sum()}, {ms[m].mean():.2f}" if m.any() else "0, -"
        print(f"| {lo:+.2f} to {hi:+.2f} | {o.sum()}, {scored[o].mean():.2f} | {theirs} |")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="run directories with test/trajectories.bin, same test starts")
    p.add_argument("--test", default="test",
                   help="each run's directory of the episodes (e.g. evaluate-last-on-reference)")
    p.add_argument("--first-actions", action="store_true",
                   help="also print how the first run's first actions follow the start x")
    p.add_argument("--at-bound", type=int, metavar="J",
                   help="also the score rate by whether the first action J sat at a bound")
    p.add_argument("--split-x", type=float, default=-0.22,
                   help="start x (world cm) splitting the starts for --at-bound")
    p.add_argument("--mujoco", metavar="JSON",
                   help="also the score rate by start beside the MuJoCo model's (a tools/transfer.py --out file)")
    a = p.parse_args()
    episodes = read_episodes(a.runs[0], a.test)
    x, first = scored_starts(episodes)
    print(f"{a.runs[0]}: {len(first)} test episodes, score rate {first.mean():.3f}")
    print("| start x (world cm) | episodes | score rate |\n| --- | --- | --- |")
    edges = np.linspace(x.min(), x.max(), 13)
    bins = np.clip(np.digitize(x, edges) - 1, 0, 11)
    for b in range(12):
        m = bins == b
        if m.any():
            print(f"| {edges[b]:.2f} to {edges[b + 1]:.2f} | {m.sum()} | {first[m].mean():.2f} |")
    if a.first_actions:
        first_actions(episodes, x)
    if a.at_bound is not None:
        at_bound(episodes, x, first, a.at_bound, a.split_x)
    if a.mujoco:
        beside_model(x, first, a.mujoco)
    print("| run | score rate | P(scores where the first scores) | P(scores where it does not) |")
    print("| --- | --- | --- | --- |")
    for run in a.runs[1:]:
        x2, other = scored_starts(read_episodes(run, a.test))
        if not np.array_equal(x, x2):
            raise SystemExit(f"{run}: other test starts than {a.runs[0]}")
        print(f"| {run} | {other.mean():.3f} | {other[first].mean():.3f} | {other[~first].mean():.3f} |")


if __name__ == "__main__":
    main()
