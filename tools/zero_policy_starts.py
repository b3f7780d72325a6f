"""The zero policy on the paper code's MuJoCo model from given ball starts, and over the
gym's own serves: how long its episodes last and what the ball does in their first steps
(issue 91's residual: does a man at rest push a ball served at its foot?).

A measuring instrument, not part of the project (see tools/transfer.py for the venv and
the Foosball_CU checkout it needs):

    FOOSBALL_CU=<checkout> python tools/zero_policy_starts.py \\
        --starts="-1.3765666,-1.3894038;-0.82881474,-1.6649365" --serves 400 \\
        --out tests/data/zero_policy_model.json

A start is the ball's joint coordinates (x, y, cm), set after the gym's reset (the ball at
rest, every rod at neutral); the gym's own serve is its draw after `numpy.random.seed(k)`
for k = 0 .. serves - 1. Each episode is stepped with the zero action to its end.
"""
import argparse
import json
import os
import sys

import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from transfer import load_gym  # noqa: E402

ROWS = 10  # the ball's first rows kept per episode


def episode(env, start=None):
    """Steps the zero policy to the episode's end from the gym's state after its reset,
    with the ball moved to `start` (joint x, y) if given: the step count and the ball's
    first rows (x, y, vx, vy after each step)."""
    m, d = env.model, env.data
    if start is not None:
        joint = lambda name: m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]
        d.qpos[joint("ball_x")], d.qpos[joint("ball_y")] = start
        env.prev_ball_y = start[1]
        mujoco.mj_forward(m, d)
    steps, rows = 0, []
    while True:
        obs, _, terminated, _, _ = env.step(np.zeros(8))
        steps += 1
        if len(rows) < ROWS:
            rows.append([float(obs[0]), float(obs[1]), float(obs[3]), float(obs[4])])
        if terminated:
            return steps, rows


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--starts", default="", help="ball starts `x,y;x,y;...` (joint frame, cm)")
    p.add_argument("--serves", type=int, default=0, help="also play this many of the gym's own serves")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    env = load_gym(os.environ["FOOSBALL_CU"])
    starts = [[float(v) for v in s.split(",")] for s in a.starts.split(";") if s]
    out = {"mujoco": mujoco.__version__, "policy": "zero", "episodes": []}
    for start in starts:
        env.reset()
        steps, rows = episode(env, start)
        out["episodes"].append({"start": start, "steps": steps, "ball": rows})
        print(f"start {start}: {steps} steps", flush=True)
    if a.serves:
        lengths = []
        for k in range(a.serves):
            np.random.seed(k)
            env.reset()
            lengths.append(episode(env)[0])
        out["serves"] = {
            "episodes": a.serves,
            "mean_length": float(np.mean(lengths)),
            "longer_than_10": int(sum(n > 10 for n in lengths)),
        }
        print(out["serves"])
    with open(a.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
