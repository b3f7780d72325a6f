"""MuJoCo against itself: how far apart the paper code's model puts the ball when only its
contact search changes (docs/reference-game.md, "MuJoCo against itself").

A measuring instrument, not part of the project; needs what tools/transfer.py needs
(mujoco 3.3.2, numpy, gymnasium, a Foosball_CU checkout). Replays the planner's plans open
loop on the model twice, with the model's own `sdf_initpoints` (40: the starting points
of its SDF contact search between the ball and each man) and with `--initpoints K`, and
compares the two balls ten steps after the ball first moves on the model, as
tools/plan_transfer.py compares ours with the model's; also ours against the model's
(the plan's recorded states, aligned at the model's first move).

    FOOSBALL_CU=<checkout> python tools/mujoco_sensitivity.py runs/demos/refined1800-seed1000/trajectories.bin \\
        --initpoints 41 --episodes 60 --out /tmp/sensitivity-41.json
"""
import argparse
import json
import os

import numpy as np

from plan_consistency import read
from plan_transfer import GAP_STEPS, JOINT_ORIGIN, first_move, quartiles, replay
from transfer import load_gym, wilson

MODEL_INITPOINTS = 40  # the model's <option sdf_initpoints="40">


def gap(a, b, t):
    """Distance (cm) between two balls' joint-frame (x, y) `GAP_STEPS` after step `t`."""
    if t is None or t + GAP_STEPS >= min(len(a), len(b)):
        return None
    return float(np.hypot(*(a[t + GAP_STEPS, :2] - b[t + GAP_STEPS, :2])))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("trajectories", help="a trajectories.bin of the planner's (evaluate --policy planner)")
    p.add_argument("--initpoints", type=int, required=True, help="the other sdf_initpoints")
    p.add_argument("--episodes", type=int, default=60)
    p.add_argument("--out", help="write the summary as JSON here")
    a = p.parse_args()
    env = load_gym(os.environ["FOOSBALL_CU"])
    episodes = read(a.trajectories)[: a.episodes]
    played = {}
    for k in [MODEL_INITPOINTS, a.initpoints]:
        env.model.opt.sdf_initpoints = k
        played[k] = [replay(env, obs, actions) for _, obs, actions, _ in episodes]
    between, ours = [], []
    for (_, obs, _, _), (_, model), (_, other) in zip(episodes, played[MODEL_INITPOINTS], played[a.initpoints]):
        here = np.column_stack([obs[1:, 0] - JOINT_ORIGIN[0], obs[1:, 1] - JOINT_ORIGIN[1]])
        t = first_move(np.hypot(model[:, 2], model[:, 3]))
        for values, g in [(between, gap(model, other, t)), (ours, gap(model, here, t))]:
            if g is not None:
                values.append(g)
    n = len(episodes)
    goals = lambda k: wilson(sum(s for s, _ in played[k]), n)
    summary = {
        "trajectories": a.trajectories,
        "episodes": n,
        "initpoints": [MODEL_INITPOINTS, a.initpoints],
        "scored_on_model": goals(MODEL_INITPOINTS),
        "scored_with_other_initpoints": goals(a.initpoints),
        "ball_gap_cm_model_vs_other_initpoints": quartiles(between),
        "ball_gap_cm_model_vs_ours": quartiles(ours),
    }
    print(json.dumps(summary, indent=1))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(summary, f, indent=1)


if __name__ == "__main__":
    main()
