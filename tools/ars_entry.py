"""An outside entry from a user's own algorithm: Augmented Random Search (Mania, Guy and
Recht 2018, "Simple random search provides a competitive approach to reinforcement
learning", V2-t) in numpy, a linear policy on the Python front's `reference` tables,
exported to ONNX for the standard test (`evaluate --run FILE.onnx`) and the league.

    python tools/ars_entry.py --steps 1500000 --seed 0 --out results/outside/ars-seed0

The policy is `a = clip(M (s - mean) / std, -1, 1)` (M: 8 x 38, zero at the start; the
mean and standard deviation of every state seen so far). Each iteration tries
`--directions` random directions `d` of M, each as `M + nu d` and `M - nu d` for one
episode of the paper's reward, and moves M along the `--top` best directions by their
return differences over the returns' standard deviation. The episodes run on
`2 x --directions` tables at once, each table taking the next episode still to play as its
own ends. Writes OUT/policy.onnx (observation [batch, 38] f32 -> action [batch, 8] f32),
OUT/progress.csv (per iteration: env steps, wall s, mean and best return) and
OUT/entry.json (settings, wall time, env steps, the ONNX file's largest gap to the numpy
policy). Needs numpy, gymnasium and onnx beside the foosball_rl wheel (onnxruntime for the
gap check); a measuring instrument, not part of the project.
"""

import argparse
import csv
import json
import os
import time

import numpy as np

import foosball_rl  # noqa: F401  (registers the envs)
from foosball_rl.vector import FoosballVectorEnv

OBS, ACT = 38, 8


class Normaliser:
    """The running mean and variance of every state seen (Welford, batched)."""

    def __init__(self):
        self.count = 0
        self.mean = np.zeros(OBS)
        self.m2 = np.zeros(OBS)

    def add(self, states):
        for s in states:
            self.count += 1
            delta = s - self.mean
            self.mean += delta / self.count
            self.m2 += delta * (s - self.mean)

    def std(self):
        if self.count < 2:
            return np.ones(OBS)
        std = np.sqrt(self.m2 / (self.count - 1))
        return np.where(std < 1e-8, 1.0, std)


def returns_of(tables, policies, mean, std):
    """One episode of each policy ([k, 8, 38] matrices), played on the tables as they
    free: the episodes' returns, the states seen, and the env steps taken."""
    n = tables.num_envs
    queue = list(range(len(policies)))
    playing = [queue.pop(0) if queue else None for _ in range(n)]
    totals = np.zeros(len(policies))
    done = np.zeros(len(policies), dtype=bool)
    seen = []
    steps = 0
    obs = tables.last_obs
    while not done.all():
        actions = np.zeros((n, ACT), dtype=np.float32)
        for t, k in enumerate(playing):
            if k is not None:
                actions[t] = np.clip(policies[k] @ ((obs[t] - mean) / std), -1.0, 1.0)
        seen.append(obs[[t for t, k in enumerate(playing) if k is not None]])
        obs, rewards, terminated, truncated, _ = tables.step(actions)
        steps += n
        for t, k in enumerate(playing):
            if k is None:
                continue
            totals[k] += rewards[t]
            if terminated[t] or truncated[t]:
                done[k] = True
                playing[t] = queue.pop(0) if queue else None
    tables.last_obs = obs
    return totals, np.concatenate(seen), steps


def export(matrix, mean, std, path):
    """The policy as one ONNX graph: Sub, Div, MatMul, Clip (opset 17)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    consts = [
        numpy_helper.from_array(mean.astype(np.float32), "mean"),
        numpy_helper.from_array(std.astype(np.float32), "std"),
        numpy_helper.from_array(matrix.T.astype(np.float32), "weights"),
        numpy_helper.from_array(np.array(-1.0, dtype=np.float32), "low"),
        numpy_helper.from_array(np.array(1.0, dtype=np.float32), "high"),
    ]
    nodes = [
        helper.make_node("Sub", ["observation", "mean"], ["centred"]),
        helper.make_node("Div", ["centred", "std"], ["scaled"]),
        helper.make_node("MatMul", ["scaled", "weights"], ["linear"]),
        helper.make_node("Clip", ["linear", "low", "high"], ["action"]),
    ]
    graph = helper.make_graph(
        nodes,
        "ars_linear_policy",
        [helper.make_tensor_value_info("observation", TensorProto.FLOAT, ["batch", OBS])],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, ["batch", ACT])],
        consts,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=1_500_000, help="env steps, all tables")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--directions", type=int, default=16)
    p.add_argument("--top", type=int, default=8)
    p.add_argument("--step-size", type=float, default=0.02)
    p.add_argument("--noise", type=float, default=0.03)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--out", required=True)
    args = p.parse_args()
    if not 0 < args.top <= args.directions:
        p.error(f"--top {args.top} must be in 1..={args.directions} (--directions)")
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    tables = FoosballVectorEnv(num_envs=2 * args.directions, preset="reference", threads=args.threads)
    tables.last_obs, _ = tables.reset(seed=args.seed)
    matrix = np.zeros((ACT, OBS))
    norm = Normaliser()
    steps, iteration, start = 0, 0, time.time()
    log_path = os.path.join(args.out, "progress.csv")
    with open(log_path, "w", newline="") as log:
        writer = csv.writer(log)
        writer.writerow(["iteration", "env_steps", "wall_s", "mean_return", "best_return"])
        while steps < args.steps:
            mean, std = norm.mean.copy(), norm.std()
            deltas = rng.standard_normal((args.directions, ACT, OBS))
            policies = np.concatenate(
                [matrix + args.noise * deltas, matrix - args.noise * deltas]
            )
            totals, seen, taken = returns_of(tables, policies, mean, std)
            norm.add(seen)
            steps += taken
            plus, minus = totals[: args.directions], totals[args.directions :]
            best = np.argsort(-np.maximum(plus, minus))[: args.top]
            spread = np.concatenate([plus[best], minus[best]]).std()
            if spread > 0:
                step = ((plus[best] - minus[best])[:, None, None] * deltas[best]).sum(axis=0)
                matrix += args.step_size / (args.top * spread) * step
            iteration += 1
            wall = time.time() - start
            writer.writerow([iteration, steps, round(wall, 1), round(totals.mean(), 1), round(totals.max(), 1)])
            log.flush()
            if iteration % 20 == 0:
                print(
                    f"iteration {iteration}: {steps} env steps, {wall:.0f} s, "
                    f"mean return {totals.mean():.0f}, best {totals.max():.0f}",
                    flush=True,
                )
    wall = time.time() - start
    mean, std = norm.mean, norm.std()
    onnx_path = os.path.join(args.out, "policy.onnx")
    export(matrix, mean, std, onnx_path)
    gap = None
    try:
        import onnxruntime

        session = onnxruntime.InferenceSession(onnx_path)
        batch = rng.standard_normal((200, OBS)).astype(np.float32) * std + mean
        exported = session.run(None, {"observation": batch.astype(np.float32)})[0]
        direct = np.clip((batch - mean) / std @ matrix.T, -1.0, 1.0)
        gap = float(np.abs(exported - direct).max())
    except ImportError:
        pass
    with open(os.path.join(args.out, "entry.json"), "w") as f:
        json.dump(
            {
                "algo": "ars-v2t",
                "steps": steps,
                "iterations": iteration,
                "seed": args.seed,
                "directions": args.directions,
                "top": args.top,
                "step_size": args.step_size,
                "noise": args.noise,
                "tables": 2 * args.directions,
                "preset": "reference",
                "wall_s": round(wall, 1),
                "largest_gap_to_numpy_policy": gap,
            },
            f,
            indent=2,
        )
    print(f"ars: {steps} env steps, {iteration} iterations in {wall:.0f} s; {onnx_path} (gap {gap})")


if __name__ == "__main__":
    main()
