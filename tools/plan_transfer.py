"""Replays the planner's plans, open loop, on the paper code's MuJoCo model: how many of
the goals our table's plans find are goals there too (docs/reference-game.md, "Which
contacts").

A measuring instrument, not part of the project (MuJoCo is never a dependency of the
project or of CI); needs what tools/transfer.py needs (mujoco 3.3.2, numpy, gymnasium,
a Foosball_CU checkout). A plan is millisecond-exact: it scores there only where our
table answers its actions as the model does, rods, kicks and rebounds alike, so the share
that still scores is a per-step fidelity figure of the whole game, contacts included.

    cargo run --release --bin evaluate -- --policy planner --episodes 200 --out /tmp/plans
    FOOSBALL_CU=<checkout> python tools/plan_transfer.py /tmp/plans/trajectories.bin \\
        --episodes 200 --out /tmp/plan-transfer.json

Each episode starts from the plan's own start (the ball at rest where its first
recorded state puts it: the file keeps world coordinates, the gym's ball joints' origin
is world (0, -4) cm; rods at rest), plays the plan's actions (20 x
action, the gym's scale) until the gym ends the episode or the plan runs out, and counts
a goal when the ball crosses the goal line. Beside it, per plan: the step the ball first
moves (speed in the playfield's plane above the gym's 0.5 cm/s) here and there; three
steps later, the ratio of the ball's speeds (the model's over ours) and the angle between
their directions; ten steps after it first moves here, how far apart the two balls are.
"""
import argparse
import json
import math
import os

import mujoco
import numpy as np

from plan_consistency import read
from transfer import load_gym, wilson

GOAL_LINE = 65.0  # cm, joint frame
JOINT_ORIGIN = (0.0, -4.0)  # the ball joints' origin in the world (x, y), cm
MOVING = 0.5  # cm/s, the gym's `_is_ball_moving`
KICK_STEPS = 3  # the kick is read this many steps after the ball first moves
GAP_STEPS = 10  # the ball's positions are compared this many steps after it first moves


def first_move(speeds):
    moving = np.nonzero(np.asarray(speeds) > MOVING)[0]
    return int(moving[0]) if len(moving) else None


def replay(env, obs, actions):
    """The plan's actions from its start on the model: whether it scored, and the ball's
    joint-frame (x, y, vx, vy) after each step played."""
    np.random.seed(0)
    env.reset()
    m, d = env.model, env.data
    adr = lambda name: m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]
    x, y = (float(obs[0, i]) - JOINT_ORIGIN[i] for i in range(2))
    d.qpos[adr("ball_x")], d.qpos[adr("ball_y")] = x, y
    mujoco.mj_forward(m, d)
    env.prev_ball_y = y
    scored, ball = False, []
    for action in actions:
        o, _, terminated, _, _ = env.step(20.0 * action.astype(np.float64))
        ball.append([o[0], o[1], o[3], o[4]])  # the gym's o[2] and o[5] repeat y's
        scored = scored or o[1] > GOAL_LINE
        if terminated:
            break
    return scored, np.array(ball)


def emit(summary, out):
    """Prints `summary` as JSON and writes it to `out` when given."""
    print(json.dumps(summary, indent=1))
    if out:
        with open(out, "w") as f:
            json.dump(summary, f, indent=1)


def quartiles(values):
    return {"median": float(np.median(values)), "q25": float(np.quantile(values, 0.25)),
            "q75": float(np.quantile(values, 0.75)), "n": len(values)}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("trajectories", help="a trajectories.bin written by `evaluate --policy planner`")
    p.add_argument("--episodes", type=int, default=200)
    p.add_argument("--out", help="write the summary as JSON here")
    a = p.parse_args()
    env = load_gym(os.environ["FOOSBALL_CU"])
    episodes = read(a.trajectories)[: a.episodes]
    goals_here, goals_there, shifts, ratios, turns, gaps = 0, 0, [], [], [], []
    for _, obs, actions, _ in episodes:
        here = np.column_stack([obs[1:, 0] - JOINT_ORIGIN[0], obs[1:, 1] - JOINT_ORIGIN[1], obs[1:, 3:5]])
        goals_here += bool((obs[:, 1] - JOINT_ORIGIN[1] > GOAL_LINE).any())
        scored, there = replay(env, obs, actions)
        goals_there += scored
        t_here = first_move(np.hypot(here[:, 2], here[:, 3]))
        t_there = first_move(np.hypot(there[:, 2], there[:, 3]))
        if t_here is None or t_there is None:
            continue
        shifts.append(t_there - t_here)
        if max(t_here, t_there) + KICK_STEPS < min(len(here), len(there)):
            v_here, v_there = here[t_here + KICK_STEPS, 2:], there[t_there + KICK_STEPS, 2:]
            if np.hypot(*v_here) > MOVING and np.hypot(*v_there) > MOVING:
                ratios.append(np.hypot(*v_there) / np.hypot(*v_here))
                turn = math.atan2(v_there[1], v_there[0]) - math.atan2(v_here[1], v_here[0])
                turns.append(abs(math.degrees(math.remainder(turn, math.tau))))
        if t_here + GAP_STEPS < min(len(here), len(there)):
            gaps.append(float(np.hypot(*(there[t_here + GAP_STEPS, :2] - here[t_here + GAP_STEPS, :2]))))
    n = len(episodes)
    summary = {
        "trajectories": a.trajectories,
        "episodes": n,
        "scored_here": wilson(goals_here, n),
        "scored_on_model": wilson(goals_there, n),
        "first_move_shift_steps": {"mean": float(np.mean(shifts)), "abs_median": float(np.median(np.abs(shifts))),
                                   "within_one": float(np.mean(np.abs(shifts) <= 1))},
        "kick_speed_ratio_model_over_ours": quartiles(ratios),
        "kick_direction_difference_deg": quartiles(turns),
        "ball_gap_cm_10_steps_after_first_move": quartiles(gaps),
    }
    emit(summary, a.out)


if __name__ == "__main__":
    main()
