"""How a player's first kick goes (docs/journal/study.md, "The kick the learners brake"): the
midfield rod's actions over an episode's first steps, the rod's angle and angular velocity
and the ball's velocity after them, then per band of the ball's start x the score rate and
the ball's velocity five steps after the kick. Reads `trajectories.bin` files (a run's
`test/`, or the planner's episodes that `evaluate --policy planner` recorded; kept on the
machine that wrote them, not committed); numpy only.

    python tools/first_kick.py runs/demos/refined1800-seed1000/trajectories.bin \
        results/sac-normalize/sac-seed4/test/trajectories.bin

Observation indices (crates/env/src/layout.rs): ball velocity 3, 4 (cm/s); yellow's
midfield (rod 2) angle 24 (rad), angular velocity 32 (rad/s), slide 8 (cm); its action
slide 4, turn 5 (in [-1, 1]). A goal pays at least 1,000 in its step's reward.
"""
import argparse

import numpy as np

from plan_consistency import read

STEPS = 6
BANDS = [(-2.5, -0.5), (-0.5, 0.0), (0.0, 0.5), (0.5, 1.5)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", help="trajectories.bin files")
    args = parser.parse_args()
    for path in args.files:
        episodes = [e for e in read(path) if len(e[1]) > STEPS + 5]
        print(f"{path} ({len(episodes)} episodes)")
        obs = np.array([e[1][: STEPS + 6] for e in episodes])
        act = np.array([e[2][:STEPS] for e in episodes])
        for t in range(STEPS):
            med = lambda x: np.median(x)  # noqa: E731
            print(
                f"  step {t}: midfield slide {med(act[:, t, 4]):+.2f} turn {med(act[:, t, 5]):+.2f}"
                f" | angle {med(obs[:, t, 24]):+.2f} rad, {med(obs[:, t, 32]):+6.1f} rad/s;"
                f" ball ({med(obs[:, t, 3]):+4.0f}, {med(obs[:, t, 4]):+4.0f}) cm/s"
            )
        x0 = np.array([e[1][0, 0] for e in episodes])
        scored = np.array([(e[3] >= 1000).any() for e in episodes])
        for lo, hi in BANDS:
            band = (x0 >= lo) & (x0 < hi)
            if band.sum() == 0:
                continue
            after = []
            for e in (e for e, b in zip(episodes, band) if b):
                speed = np.hypot(e[1][:, 3], e[1][:, 4])
                kick = int(np.argmax(speed > 100))
                if speed[kick] > 100:
                    after.append(e[1][min(kick + 5, len(speed) - 1), 3:5])
            vx, vy = np.median(np.array(after), axis=0) if after else (0.0, 0.0)
            print(
                f"  start x {lo:+.1f}..{hi:+.1f} cm: {band.sum():4d} episodes, score rate"
                f" {scored[band].mean():.2f}, ball 5 steps after the kick ({vx:+.0f}, {vy:+.0f}) cm/s"
            )


if __name__ == "__main__":
    main()
