"""Where a run's test episodes score: the score rate by the ball's start across the table
(x, world cm), and how much several runs' scoring starts overlap (docs/study.md, "Where
the learner scores"). Reads the test's `trajectories.bin` (kept on the machine that ran
the test, not committed); numpy only.

    python tools/score_by_start.py results/recipe-v4/sac-recipe-seed{0,1,2,3,4}
    python tools/score_by_start.py RUN... --test evaluate-last-on-reference   # another game's test

Prints, for the first run, the score rate in 12 bins of the start's x; then for every
other run the chance that it scores on a start where the first one scores and where the
first one does not (equal chances: the two score on unrelated starts).
"""
import argparse
import os

import numpy as np

from plan_consistency import read

GOAL_LINE_WORLD = 61.0  # the joint frame's 65 cm, world y (joint origin at y = -4)


def scored_starts(run, test="test"):
    """Start x (world cm) and whether each episode of `run`'s `test` directory scored."""
    episodes = read(os.path.join(run, test, "trajectories.bin"))
    x = np.array([obs[0, 0] for _, obs, _, _ in episodes])
    scored = np.array([bool((obs[:, 1] > GOAL_LINE_WORLD).any()) for _, obs, _, _ in episodes])
    return x, scored


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="run directories with test/trajectories.bin, same test starts")
    p.add_argument("--test", default="test",
                   help="each run's directory of the episodes (e.g. evaluate-last-on-reference)")
    a = p.parse_args()
    x, first = scored_starts(a.runs[0], a.test)
    print(f"{a.runs[0]}: {len(first)} test episodes, score rate {first.mean():.3f}")
    print("| start x (world cm) | episodes | score rate |\n| --- | --- | --- |")
    edges = np.linspace(x.min(), x.max(), 13)
    bins = np.clip(np.digitize(x, edges) - 1, 0, 11)
    for b in range(12):
        m = bins == b
        if m.any():
            print(f"| {edges[b]:.2f} to {edges[b + 1]:.2f} | {m.sum()} | {first[m].mean():.2f} |")
    print("| run | score rate | P(scores where the first scores) | P(scores where it does not) |")
    print("| --- | --- | --- | --- |")
    for run in a.runs[1:]:
        x2, other = scored_starts(run, a.test)
        if not np.array_equal(x, x2):
            raise SystemExit(f"{run}: other test starts than {a.runs[0]}")
        print(f"| {run} | {other.mean():.3f} | {other[first].mean():.3f} | {other[~first].mean():.3f} |")


if __name__ == "__main__":
    main()
