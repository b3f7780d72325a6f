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

With `--contact-poses N` it first probes the model's contacts themselves: N random poses
of the ball by yellow's centre midfielder (turn in [-1.5, 1.5] rad, ball joint x in
[-2.5, 1.5] and y in [-4, 1] cm, seed 0), only that pair colliding: how many contacts a
touching pose reports and in how many distinct places (merged within 0.05 in position,
cm, and normal).
"""
import argparse
import os

import mujoco
import numpy as np

from plan_consistency import read
from plan_transfer import GAP_STEPS, JOINT_ORIGIN, emit, first_move, quartiles, replay
from transfer import load_gym, wilson

MODEL_INITPOINTS = 40  # the model's <option sdf_initpoints="40">


def gap(a, b, t):
    """Distance (cm) between two balls' joint-frame (x, y) `GAP_STEPS` after step `t`."""
    if t is None or t + GAP_STEPS >= min(len(a), len(b)):
        return None
    return float(np.hypot(*(a[t + GAP_STEPS, :2] - b[t + GAP_STEPS, :2])))


def midfielder_pair(m):
    """The geom ids of the ball and of yellow's centre midfielder."""
    geom = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)
    return geom("ball"), geom("y_mid_guy3")


def midfielder_poses(m, d, poses):
    """Puts the ball by yellow's centre midfielder at `poses` random poses (turn in
    [-1.5, 1.5] rad, ball joint x in [-2.5, 1.5] and y in [-4, 1] cm, seed 0), `d` forward
    at each, yielding each in turn; only that pair collides while it runs."""
    qpos = lambda n: m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]
    ball, man = midfielder_pair(m)
    contype, conaffinity = m.geom_contype.copy(), m.geom_conaffinity.copy()
    for g in range(m.ngeom):
        if g not in (ball, man):
            m.geom_contype[g] = m.geom_conaffinity[g] = 0
    rng = np.random.default_rng(0)
    try:
        for _ in range(poses):
            mujoco.mj_resetData(m, d)
            d.qpos[qpos("y_mid_rotation")] = rng.uniform(-1.5, 1.5)
            d.qpos[qpos("ball_x")] = rng.uniform(-2.5, 1.5)
            d.qpos[qpos("ball_y")] = rng.uniform(-4.0, 1.0)
            mujoco.mj_forward(m, d)
            yield
    finally:
        m.geom_contype[:], m.geom_conaffinity[:] = contype, conaffinity


def contact_patches(env, poses, tol=0.05):
    """The model's ball-man contacts at `poses` random poses: per touching pose, the
    contacts reported and the distinct places among them."""
    m = env.model
    d = mujoco.MjData(m)
    _, man = midfielder_pair(m)
    reported, places = [], []
    for _ in midfielder_poses(m, d, poses):
        rows = [np.r_[c.pos, (1 if c.geom1 == man else -1) * c.frame[:3]] for c in d.contact[: d.ncon]]
        if not rows:
            continue
        distinct = []
        for r in rows:
            if not any(np.abs(r - k).max() < tol for k in distinct):
                distinct.append(r)
        reported.append(len(rows))
        places.append(len(distinct))
    return {"poses": poses, "touching": len(places), "contacts_per_touching_pose": float(np.mean(reported)),
            "distinct_places_mean": float(np.mean(places)), "distinct_places_max": int(max(places))}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("trajectories", help="a trajectories.bin of the planner's (evaluate --policy planner)")
    p.add_argument("--initpoints", type=int, required=True, help="the other sdf_initpoints")
    p.add_argument("--episodes", type=int, default=60)
    p.add_argument("--contact-poses", type=int, default=0, help="probe the model's contacts at this many poses")
    p.add_argument("--out", help="write the summary as JSON here")
    a = p.parse_args()
    env = load_gym(os.environ["FOOSBALL_CU"])
    patches = contact_patches(env, a.contact_poses) if a.contact_poses else None
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
        "contact_patches": patches,
    }
    emit(summary, a.out)


if __name__ == "__main__":
    main()
