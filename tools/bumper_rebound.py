"""Issue 91's bumper residual on the paper code's MuJoCo model: yellow's defence rod
driven to +20 cm (its bumper stops it at 17.43) from rest, the slide and its velocity at
each step about the stop, under the model's own contacts and under three changes: the
elliptic cone, every geom frictionless (`condim` 1), and the pads alone frictionless
(given priority so that their `condim` decides their contacts).

A measuring instrument, not part of the project (`pip install mujoco==3.3.2 numpy` in a
throwaway venv):

    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/bumper_rebound.py
"""
import os
import sys

import mujoco

sys.path.insert(0, os.path.dirname(__file__))
from measure_reference import actuator, load, qadr, vadr  # noqa: E402


def run(m, d, label):
    """Prints the steps about the stop: (step, slide cm, slide velocity cm/s)."""
    mujoco.mj_resetData(m, d)
    d.qpos[qadr(m, "ball_x")] = -30.0  # out of the way
    d.qpos[qadr(m, "ball_y")] = 40.0
    d.ctrl[actuator(m, "y_def_linear")] = 20.0
    rows = []
    for k in range(40):
        mujoco.mj_step(m, d)
        rows.append((k, round(float(d.qpos[qadr(m, "y_def_linear")]), 4),
                     round(float(d.qvel[vadr(m, "y_def_linear")]), 1)))
    print(f"{label}: {rows[14:22]}")


def main():
    m = load()
    d = mujoco.MjData(m)
    pads = [i for i in range(m.ngeom)
            if (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, i) or "").endswith("rubber")]
    run(m, d, "the model (pyramidal cone, condim 4)")
    m.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    run(m, d, "elliptic cone")
    m.opt.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    condim = m.geom_condim.copy()
    m.geom_condim[:] = 1
    run(m, d, "every geom frictionless (condim 1)")
    m.geom_condim[:] = condim
    m.geom_priority[pads] = 5
    m.geom_condim[pads] = 1
    run(m, d, "the pads frictionless (priority, condim 1)")


if __name__ == "__main__":
    main()
