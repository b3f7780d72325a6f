"""Stable-Baselines3's SAC and TD3 gradient update timed beside ours, on one core, in one run.

The CPU reference for `update_speed` (crates/algos/benches/update_speed.rs): the same sizes
(38-dim observations, 8-dim actions, batch 256, hidden layers WIDTHxDEPTH, ReLU), SB3's
own `SAC.train` / `TD3.train` (everything SB3 does per update: sampling the replay buffer,
losses, Adam, Polyak, its logger), one torch thread. TD3's figure is the mean over two
gradient steps, a critic-only one and a delayed one with the actor (policy_delay 2), as
ours. Our bench runs first, then SB3, both pinned to the same core (`taskset`), so the
ratio is read from one run on one machine. A measuring instrument, not part of the project
(torch and SB3 are not its dependencies, nor CI's):

    python3 -m venv /tmp/sb3 && /tmp/sb3/bin/pip install stable-baselines3
    /tmp/sb3/bin/python tools/sb3_update_speed.py [--sizes 64x2,256x2] [--reps 40] [--core 0]
        [--bench target/release/deps/update_speed-HASH]

Writes `target/bench/update_vs_sb3.json` (the figures and their ratios per algorithm and
size: ours on flex, ours on the host MLP path where it runs the algorithm, SB3) and prints
a markdown table. `--skip-ours` times SB3 alone; `--bench` runs an already built bench
binary instead of `cargo bench` (which builds with the package's own features).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import time
from pathlib import Path

OBS, ACT, BATCH = 38, 8, 256
ROOT = Path(__file__).resolve().parent.parent


def parse_sizes(text: str) -> list[tuple[int, int]]:
    sizes = []
    for item in text.split(","):
        width, depth = item.split("x")
        sizes.append((int(width), int(depth)))
    return sizes


def sb3_model(algo: str, width: int, depth: int):
    """An SB3 model on a 38 -> 8 box env, its replay buffer filled with 10,000 random
    transitions, its logger silent."""
    import gymnasium as gym
    import numpy as np
    from stable_baselines3 import SAC, TD3
    from stable_baselines3.common.logger import configure

    class Box(gym.Env):
        observation_space = gym.spaces.Box(-1.0, 1.0, (OBS,), dtype=np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (ACT,), dtype=np.float32)

        def reset(self, *, seed=None, options=None):
            return np.zeros(OBS, dtype=np.float32), {}

        def step(self, action):
            return np.zeros(OBS, dtype=np.float32), 0.0, False, False, {}

    cls = {"sac": SAC, "td3": TD3}[algo]
    model = cls(
        "MlpPolicy",
        Box(),
        policy_kwargs={"net_arch": [width] * depth},
        batch_size=BATCH,
        learning_starts=0,
        seed=0,
        device="cpu",
    )
    model.set_logger(configure(None, []))
    rng = np.random.default_rng(0)
    for _ in range(10_000):
        model.replay_buffer.add(
            rng.uniform(-1, 1, (1, OBS)).astype(np.float32),
            rng.uniform(-1, 1, (1, OBS)).astype(np.float32),
            rng.uniform(-1, 1, (1, ACT)).astype(np.float32),
            rng.uniform(-1, 1, 1).astype(np.float32),
            np.zeros(1),
            [{}],
        )
    return model


def sb3_update_ms(algo: str, width: int, depth: int, reps: int) -> float:
    """Median milliseconds of one SB3 gradient step (TD3: of a pair, halved)."""
    model = sb3_model(algo, width, depth)
    steps = 2 if algo == "td3" else 1
    model.train(gradient_steps=steps, batch_size=BATCH)  # warm-up
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        model.train(gradient_steps=steps, batch_size=BATCH)
        times.append((time.perf_counter() - t) * 1e3 / steps)
    return statistics.median(times)


def ours(sizes: str, reps: int, core: int, bench: str | None) -> dict:
    """Runs our update bench on `core`, one rayon thread, flex then the host path; its
    figures by key (the host path's ending in `_host`)."""
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    if bench:
        cmd = [bench]
    else:
        cmd = ["cargo", "bench", "-p", "foosball-algos", "--bench", "update_speed", "--"]
    cmd += ["--sizes", sizes, "--reps", str(reps), "--algos", "sac,td3"]
    cmd += ["--backend", "flex,host"]
    subprocess.run(["taskset", "-c", str(core), *cmd], cwd=ROOT, env=env, check=True)
    return json.loads((ROOT / "target/bench/update_speed_flex,host.json").read_text())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", default="64x2,256x2")
    p.add_argument("--reps", type=int, default=40)
    p.add_argument("--core", type=int, default=0)
    p.add_argument("--skip-ours", action="store_true")
    p.add_argument("--bench", help="a built update_speed bench binary")
    args = p.parse_args()
    if shutil.which("taskset") is None:
        raise SystemExit("taskset (util-linux) is needed to pin both benches to one core")

    ours_ms = {} if args.skip_ours else ours(args.sizes, args.reps, args.core, args.bench)
    os.sched_setaffinity(0, {args.core})
    import torch

    torch.set_num_threads(1)
    rows = []
    for width, depth in parse_sizes(args.sizes):
        size = "x".join([str(width)] * depth)
        for algo in ("sac", "td3"):
            sb3 = sb3_update_ms(algo, width, depth, args.reps)
            mine = ours_ms.get(f"{algo}_update_ms_{size}")
            host = ours_ms.get(f"{algo}_update_ms_{size}_host")
            rows.append(
                {
                    "algo": algo,
                    "hidden": size,
                    "ours_ms": mine,
                    "ours_host_ms": host,
                    "sb3_ms": sb3,
                    "sb3_over_ours": sb3 / mine if mine else None,
                    "sb3_over_ours_host": sb3 / host if host else None,
                }
            )
    versions = {"torch": torch.__version__}
    import stable_baselines3

    versions["stable_baselines3"] = stable_baselines3.__version__
    out = {"core": args.core, "threads": 1, "batch": BATCH, "versions": versions, "rows": rows}
    path = ROOT / "target/bench/update_vs_sb3.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")

    print(
        "| update (1 thread, batch 256) | ours, flex (ms) | ours, host (ms) | SB3 (ms) "
        "| SB3 / flex | SB3 / host |"
    )
    print("| --- | --- | --- | --- | --- | --- |")

    def cell(value, unit: str) -> str:
        return f"{value:.{3 if unit == '' else 2}f}{unit}" if value else "-"

    for r in rows:
        print(
            f"| {r['algo'].upper()} {r['hidden']} | {cell(r['ours_ms'], '')} "
            f"| {cell(r['ours_host_ms'], '')} | {r['sb3_ms']:.3f} "
            f"| {cell(r['sb3_over_ours'], 'x')} | {cell(r['sb3_over_ours_host'], 'x')} |"
        )
    print(f"figures in {path} ({', '.join(f'{k} {v}' for k, v in versions.items())})")


if __name__ == "__main__":
    main()
