"""Plays a run's networks on the paper code's MuJoCo model and reports the test's metrics
beside the run's own: does a policy trained on our table play the reference's game?

A measuring instrument, not part of the project (MuJoCo is never a dependency of the
project or of CI). It needs, in a throwaway venv, `pip install mujoco==3.3.2 numpy
gymnasium`, a checkout of the paper's code (Foosball_CU, whose
`ai_agents/v2/gym/full_information_protagonist_antagonist_gym.py` is the gym played,
unchanged) and the `act` binary of this project (`cargo build --release --bin act`):

    FOOSBALL_CU=<checkout> python tools/transfer.py results/recipe/sac-recipe-seed1 \\
        --episodes 200 --out /tmp/transfer-seed1.json

The run's networks answer the gym's observations (the same 38 values in the same joint
frame) through `act`; the gym is stepped with 20 x action, as its [-20, 20] action space
is what SB3 scaled the policy's [-1, 1] onto (a run of `env.action_map = "linear"`, whose
[-1, 1] spans each joint's control range, is stepped with action x range: the code's
action a x range / 20, which MuJoCo's clamp to the range leaves as it is). Starts are the gym's own draw,
`numpy.random.seed(seed)` before the reset of episode `seed` (0, 1, ...). The metrics are
the test's five and the episode length, each with its 95 % interval (Wilson for the
score rate, normal for the means); ends are classified as the gym decides them. The JSON
of `--out` also lists each episode's start (the ball's x and y, joint frame, cm), whether
it scored, its end and its length (`per_episode`).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tomllib
import types

import numpy as np

GOAL = (0.0, 65.0)  # the gym's reward point and goal line, joint frame


def load_gym(checkout):
    # The gym's render mixin starts GLFW in its constructor, which needs a display; the
    # tool never renders, so it gets a stand-in that starts and does nothing else.
    sys.modules["glfw"] = types.SimpleNamespace(init=lambda: True)
    os.environ.setdefault("SIM_PATH", os.path.join(checkout, "foosball_sim/v2/foosball_sim.xml"))
    sys.path.insert(0, checkout)
    from ai_agents.v2.gym.full_information_protagonist_antagonist_gym import FoosballEnv

    return FoosballEnv()


def wilson(k, n, z=1.96):
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return [p, centre - half, centre + half]


def mean_ci(values, z=1.96):
    a = np.asarray(values, dtype=float)
    m = float(a.mean())
    se = float(a.std(ddof=1) / math.sqrt(len(a))) if len(a) > 1 else 0.0
    return [m, m - z * se, m + z * se]


def run_action_map(run):
    """The action map the policy was trained under: a run's `env.action_map`; for an ONNX
    file, the exported run's (its `foosball_rl.run_config` metadata, read where the `onnx`
    package is installed), else the code's own map, `saturating` (the Python front's
    `reference`, where outside entries train)."""
    if os.path.isdir(run):
        with open(os.path.join(run, "config.toml"), "rb") as f:
            return tomllib.load(f).get("env", {}).get("action_map", "saturating")
    try:
        import onnx
    except ImportError:
        return "saturating"
    for prop in onnx.load(run).metadata_props:
        if prop.key == "foosball_rl.run_config":
            return tomllib.loads(prop.value).get("env", {}).get("action_map", "saturating")
    return "saturating"


def action_scale(action_map, env):
    """What the gym's step multiplies the policy's action by, per value: 20 under the code's
    own map (`saturating`), the control range under `linear`: the model's own `ctrlrange`
    of yellow's 8 actuators (the first 8: goalie, defence, midfield, attack, slide and turn
    each; cm of slide, rad of turn)."""
    if action_map == "saturating":
        return np.full(8, 20.0)
    if action_map == "linear":
        return env.model.actuator_ctrlrange[:8, 1].copy()
    raise SystemExit(f"env.action_map {action_map!r} is neither saturating nor linear")


def act_policy(command):
    """The policy of an `act` process (observations in, actions out, a line each), and the
    process."""
    act = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, bufsize=1)

    def policy(obs):
        act.stdin.write(" ".join(f"{v:.7g}" for v in obs) + "\n")
        act.stdin.flush()
        line = act.stdout.readline()
        if not line:
            raise RuntimeError("act stopped answering: " + act.stderr.read())
        return np.array([float(v) for v in line.split()], dtype=np.float64)

    return policy, act


def onnxruntime_policy(path):
    """An ONNX file's policy played in this process by onnxruntime (the observation as
    float32, batch of one), as a Python user plays an exported run."""
    import onnxruntime

    session = onnxruntime.InferenceSession(path)
    name = session.get_inputs()[0].name

    def policy(obs):
        batch = np.asarray(obs, dtype=np.float32)[None]
        return session.run(None, {name: batch})[0][0].astype(np.float64)

    return policy


def play(env, policy, seed, scale, record=None):
    """One episode: its summary (the test's per-episode quantities and its end). With
    `record` (a list), the episode is appended to it in the step-response fixture's
    schema: the start, each step's action in project units of the code's map (what the
    gym was given / 20) and every observation."""
    np.random.seed(seed)
    obs, _ = env.reset()
    start = [float(obs[0]), float(obs[1])]
    if record is not None:
        record.append({"name": f"episode {seed}", "ball": start, "actions": [], "obs": [obs.tolist()]})
    total, steps, distances, speeds, scored = 0.0, 0, [], [], False
    while True:
        action = policy(obs)
        obs, reward, terminated, _, _ = env.step(scale * action)
        if record is not None:
            record[-1]["actions"].append((scale * action / 20).tolist())
            record[-1]["obs"].append(obs.tolist())
        steps += 1
        total += reward
        x, y = float(obs[0]), float(obs[1])
        distances.append(math.hypot(x - GOAL[0], y - GOAL[1]))
        speeds.append(float(np.linalg.norm(obs[3:6])))
        scored = scored or y > GOAL[1]
        if terminated:
            if env.ball_stopped_count >= 10:
                end = "stagnant"
            elif env.no_progress_steps >= env.max_no_progress_steps:
                end = "no_progress"
            elif not env.is_healthy:
                end = "physics_fault"
            else:
                end = "time_limit"
            return {
                "return": total,
                "steps": steps,
                "mean_distance": float(np.mean(distances)),
                "mean_speed": float(np.mean(speeds)),
                "final_distance": distances[-1],
                "scored": scored,
                "end": end,
                "start": start,
            }


def summarise(episodes):
    n = len(episodes)
    ends = {}
    for e in episodes:
        ends[e["end"]] = ends.get(e["end"], 0) + 1
    return {
        "episodes": n,
        "score_rate": wilson(sum(e["scored"] for e in episodes), n),
        "mean_goal_distance": mean_ci([e["mean_distance"] for e in episodes]),
        "mean_ball_speed": mean_ci([e["mean_speed"] for e in episodes]),
        "mean_return": mean_ci([e["return"] for e in episodes]),
        "mean_final_distance": mean_ci([e["final_distance"] for e in episodes]),
        "mean_length": mean_ci([e["steps"] for e in episodes]),
        "end_reasons": {k: v / n for k, v in sorted(ends.items())},
    }


def ours(run):
    """The run's own test metrics as [value, low, high] (an ONNX file's: the `test/`
    folder beside it, as results/outside/ keeps them); None where there is none."""
    folder = run if os.path.isdir(run) else os.path.dirname(run)
    path = os.path.join(folder, "test", "metrics.json")
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        m = json.load(f)
    out = {}
    for key in ["score_rate", "mean_goal_distance", "mean_ball_speed", "mean_return",
                "mean_final_distance", "mean_length"]:
        e = m[key]
        out[key] = [e["mean"], *e["ci95"]]
    out["episodes"] = m["episodes"]
    out["end_reasons"] = m.get("end_reasons", {})
    return out


def table(run, theirs, mine):
    if mine is None:
        mine = {k: [float("nan")] * 3 for k in theirs if k not in ("episodes", "end_reasons")}
        mine.update(episodes=0, end_reasons={})
    rows = [f"| metric | on the MuJoCo model ({theirs['episodes']} episodes) | the run's own test ({mine['episodes']}) |",
            "| --- | --- | --- |"]
    for key, label in [("score_rate", "score rate"), ("mean_goal_distance", "mean distance to goal (cm)"),
                       ("mean_ball_speed", "mean ball speed (cm/s)"), ("mean_return", "mean episode reward"),
                       ("mean_final_distance", "mean final distance (cm)"), ("mean_length", "mean episode length (steps)")]:
        cell = lambda v: f"{v[0]:.4g} [{v[1]:.4g}, {v[2]:.4g}]"
        rows.append(f"| {label} | {cell(theirs[key])} | {cell(mine[key])} |")
    ends = lambda d: ", ".join(f"{k} {100 * v:.1f} %" for k, v in d.items())
    rows.append(f"| ends | {ends(theirs['end_reasons'])} | {ends(mine['end_reasons'])} |")
    return f"{run}\n\n" + "\n".join(rows)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("run", help="a run directory written by train, or an ONNX policy file")
    p.add_argument("--agent", help="the league's name of the agent, written into --out's JSON "
                   "(a league reads LEAGUE/mujoco/*.json into its MuJoCo column; default RUN as given)")
    p.add_argument("--checkpoint", default="last", choices=["best", "last"])
    p.add_argument("--episodes", type=int, default=200)
    p.add_argument("--act", default="target/release/act", help="the act binary")
    p.add_argument("--onnxruntime", action="store_true",
                   help="play the ONNX file in this process by onnxruntime instead of through act")
    p.add_argument("--out", help="write the summary as JSON here")
    p.add_argument("--record", help="write the episodes (actions and observations, the step-response "
                   "fixture's schema) as JSON here")
    p.add_argument("--seeds", help="play these episodes (comma separated) instead of 0 .. episodes - 1")
    a = p.parse_args()
    env = load_gym(os.environ["FOOSBALL_CU"])
    act = None
    if a.onnxruntime:
        if os.path.isdir(a.run):
            raise SystemExit(f"--onnxruntime plays an ONNX file; {a.run} is a run directory (export it)")
        policy = onnxruntime_policy(a.run)
    else:
        command = [a.act, "--run", a.run] + (["--checkpoint", a.checkpoint] if os.path.isdir(a.run) else [])
        policy, act = act_policy(command)
    scale = action_scale(run_action_map(a.run), env)
    seeds = [int(v) for v in a.seeds.split(",")] if a.seeds else range(a.episodes)
    record = [] if a.record else None
    episodes = [play(env, policy, seed, scale, record) for seed in seeds]
    if a.record:
        with open(a.record, "w") as f:
            json.dump({"what": f"{a.run} ({a.checkpoint}) on the paper code's gym, episodes {list(seeds)}",
                       "dt": float(env.model.opt.timestep), "cases": record}, f)
    if act is not None:
        act.stdin.close()
        act.wait()
    theirs = summarise(episodes)
    mine = ours(a.run)
    print(table(a.run, theirs, mine))
    if a.out:
        with open(a.out, "w") as f:
            per_episode = [{k: e[k] for k in ("start", "scored", "end", "steps")} for e in episodes]
            agent = a.agent or a.run
            json.dump({"agent": agent, "run": a.run, "checkpoint": a.checkpoint, "mujoco": theirs, "ours": mine,
                       "per_episode": per_episode}, f, indent=1)


if __name__ == "__main__":
    main()
