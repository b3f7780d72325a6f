"""What the paper code's MuJoCo model does where the ball meets a man (docs/reference-game.md,
"After a man touches the ball"). A measuring instrument, not part of the project: it needs
`pip install mujoco==3.3.2 numpy` in a throwaway venv and a Foosball_CU checkout.

    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/probe_contacts.py

Prints, for yellow's midfield kick from rest (the ball at joint (-0.5, 0), the turn
commanded to +2.5 rad, as behaviour.json's `kicks`), each step's ball and rod velocity and
the ball's contacts: how many, the deepest and mean distance, their mean position relative
to the rod's axis and mean normal (from the ball to the man), and the total contact force
in the world frame (what the ball exerts on the man), and how deep the man's mesh really
is in the ball (its deepest vertex); then the push-out of balls that start
overlapping a resting man (the first 8 steps' speeds, cm/s).
"""
import os

import mujoco
import numpy as np


def main():
    m = mujoco.MjModel.from_xml_path(os.environ["FOOSBALL_CU_SIM"])
    d = mujoco.MjData(m)
    print("option: timestep", m.opt.timestep, "integrator", m.opt.integrator, "cone", m.opt.cone,
          "solver", m.opt.solver, "iterations", m.opt.iterations, "impratio", m.opt.impratio)
    joint = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)
    qpos = lambda n: m.jnt_qposadr[joint(n)]
    qvel = lambda n: m.jnt_dofadr[joint(n)]
    ball = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "ball")
    man = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "y_mid_guy3")
    mesh = m.geom_dataid[man]
    verts = m.mesh_vert[m.mesh_vertadr[mesh]: m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]

    mujoco.mj_resetData(m, d)
    d.qpos[qpos("ball_x")], d.qpos[qpos("ball_y")] = -0.5, 0.0
    d.ctrl[5] = 2.5  # yellow midfield turn
    for k in range(1, 13):
        mujoco.mj_step(m, d)
        v = (d.qvel[qvel("ball_x")], d.qvel[qvel("ball_y")])
        w = d.qvel[qvel("y_mid_rotation")]
        line = f"step {k:2d}: ball v ({v[0]:7.1f}, {v[1]:7.1f}) cm/s, midfield turn {w:6.1f} rad/s"
        world = verts @ d.geom_xmat[man].reshape(3, 3).T + d.geom_xpos[man]
        depth = m.geom_size[ball][0] - np.linalg.norm(world - d.geom_xpos[ball], axis=1).min()
        if depth > 0:
            line += f"; the centre man's mesh {depth:.3f} cm deep in the ball"
        found = [(i, c) for i, c in enumerate(d.contact[: d.ncon]) if ball in (c.geom1, c.geom2)]
        if found:
            total = np.zeros(3)
            for i, c in found:
                f = np.zeros(6)
                mujoco.mj_contactForce(m, d, i, f)
                total += c.frame.reshape(3, 3).T @ f[:3]
            pos = np.mean([c.pos for _, c in found], axis=0)
            normal = np.mean([c.frame[:3] * (1 if c.geom1 == ball else -1) for _, c in found], axis=0)
            dist = [c.dist for _, c in found]
            line += (f"; {len(found)} contacts, dist min {min(dist):.3f} mean {np.mean(dist):.3f} cm, "
                     f"at ({pos[1] + 7.5:.2f}, {pos[2] - 7.75:.2f}) cm from the axis (y, z), "
                     f"normal {np.round(normal, 2)}, force {np.round(total, 0)}")
        print(line)

    print("balls starting in a resting man's foot (joint x, y): speeds of the first 8 steps")
    for x, y in [(-0.83, -1.665), (-1.377, -1.389), (-0.299, -1.087), (-0.538, -1.201)]:
        mujoco.mj_resetData(m, d)
        d.qpos[qpos("ball_x")], d.qpos[qpos("ball_y")] = x, y
        speeds = []
        for _ in range(8):
            mujoco.mj_step(m, d)
            speeds.append(round(float(np.hypot(d.qvel[qvel("ball_x")], d.qvel[qvel("ball_y")])), 1))
        print(f"  ({x}, {y}): {speeds}")


if __name__ == "__main__":
    main()
