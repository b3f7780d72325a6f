"""Measures the paper code's MuJoCo model (../shared/reference/foosball_cu) for the
calibration figures in docs/reference_parity.md. A measuring instrument, not part of the
project: it needs `pip install mujoco==3.3.2 numpy` in a throwaway venv, and its output
(a JSON file) is what the parity notes quote.

    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml \\
        python tools/measure_reference.py /tmp/reference_probes.json
"""
import json
import os
import sys

import mujoco
import numpy as np

def load():
    """The model of a Foosball_CU checkout (its foosball_sim/v2 folder has every mesh the
    scene names): the path in FOOSBALL_CU_SIM, e.g. .../foosball_sim/v2/foosball_sim.xml."""
    return mujoco.MjModel.from_xml_path(os.environ["FOOSBALL_CU_SIM"])


def qadr(m, name):
    return m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]


def vadr(m, name):
    return m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]


def actuator(m, name):
    return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)


def bumper_travel(m, d):
    """Slide reached when each yellow rod is commanded to either end of its ctrlrange."""
    out = {}
    for rod in ["goal", "def", "mid", "attack"]:
        ends = []
        for sign in [-1.0, 1.0]:
            mujoco.mj_resetData(m, d)
            d.qpos[qadr(m, "ball_x")] = -30.0  # out of the way
            d.qpos[qadr(m, "ball_y")] = 40.0
            d.ctrl[actuator(m, f"y_{rod}_linear")] = sign * 100.0
            for _ in range(1500):
                mujoco.mj_step(m, d)
            ends.append(float(d.qpos[qadr(m, f"y_{rod}_linear")]))
        out[rod] = ends
    return out


def glide(m, d, vx, vy, steps, x=-0.5, y=0.0):
    """The ball's path with every rod held at neutral: rows [step, x, y, vx, vy] (qpos)."""
    mujoco.mj_resetData(m, d)
    d.qpos[qadr(m, "ball_x")] = x
    d.qpos[qadr(m, "ball_y")] = y
    d.qvel[vadr(m, "ball_x")] = vx
    d.qvel[vadr(m, "ball_y")] = vy
    rows = []
    for k in range(steps + 1):
        if k % 5 == 0:
            rows.append([k] + [float(v) for v in (d.qpos[qadr(m, "ball_x")], d.qpos[qadr(m, "ball_y")],
                                                 d.qvel[vadr(m, "ball_x")], d.qvel[vadr(m, "ball_y")])])
        mujoco.mj_step(m, d)
    return rows


def main():
    m = load()
    # One MjData for every probe: the SDF plugin builds its distance grids (minutes) for
    # each new MjData.
    d = mujoco.MjData(m)
    out = {
        "mujoco": mujoco.__version__,
        "bumper_travel_cm": bumper_travel(m, d),
        # A diagonal glide: both axes lose the same speed per step.
        "glide_diagonal_200_100": glide(m, d, 200.0, 100.0, 300),
        # Into a black man at speed: the ball at the yellow midfield line rolling +y.
        "into_black_man_400": glide(m, d, 0.0, 400.0, 120, x=0.0, y=-2.0),
        # Oblique into the side wall.
        "wall_oblique_300_150": glide(m, d, 300.0, 150.0, 200, x=0.0, y=20.0),
    }
    # The SDF plugin prints its own notes on stdout: the figures go to a file.
    with open(sys.argv[1], "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
