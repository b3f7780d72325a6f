"""Env steps/s of the Python front against the Rust-native loop, same process and build.

    python crates/py/bench/speed.py [--seconds 3] [--repeats 3] [--out target/bench/python_speed.json]

For one table (`FoosballEnv.step`, autoreset in Python) and for `FoosballVectorEnv`
with 1, 2, 8 and 64 tables (one thread per core): the Python loop steps for about
`--seconds`, then `VecTable.step_native` replays the same actions in Rust without
coming back to Python between steps (same stepping code: autoreset, metrics, copies).
Cases alternate and the best of `--repeats` rounds is kept, so load elsewhere on the
machine hurts both loops alike. Prints a markdown table and writes the figures as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from foosball_rl import FoosballEnv, FoosballVectorEnv
from foosball_rl._core import VecTable

# The paper code's MuJoCo model, measured on this machine kind (docs/table.md, "Speed"):
# physics steps/s at its 2 ms step, i.e. env steps/s of the reference gym (frame skip 1).
REFERENCE_GYM_STEPS_PER_S = 32.1


def python_single(env: FoosballEnv, actions: np.ndarray, seconds: float) -> tuple[int, float]:
    env.reset(seed=0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
        steps += len(actions)
    return steps, time.perf_counter() - start


def python_vector(vec: FoosballVectorEnv, actions: np.ndarray, seconds: float) -> tuple[int, float]:
    vec.reset(seed=0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        for a in actions:
            vec.step(a)
        steps += len(actions)
    return steps, time.perf_counter() - start


def native(tables: VecTable, actions: np.ndarray, steps: int) -> float:
    tables.reset(0)
    elapsed, done = 0.0, 0
    while done < steps:
        elapsed += tables.step_native(actions)
        done += len(actions)
    return elapsed * steps / done


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("target/bench/python_speed.json"))
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    rng = np.random.default_rng(0)
    rows = []

    env = FoosballEnv()
    one = VecTable(1, 1)
    acts = rng.uniform(-1, 1, (200, 8)).astype(np.float32)
    best_py = best_rs = 0.0
    for _ in range(args.repeats):
        steps, secs = python_single(env, acts, args.seconds)
        best_py = max(best_py, steps / secs)
        best_rs = max(best_rs, steps / native(one, acts[:, None, :].copy(), steps))
    rows.append({"case": "FoosballEnv (1 table)", "tables": 1, "threads": 1, "python": best_py, "rust": best_rs})

    for n in (1, 2, 8, 64):
        threads = min(n, cores)
        vec = FoosballVectorEnv(n, threads=threads)
        tables = VecTable(n, threads)
        acts = rng.uniform(-1, 1, (max(20, 1600 // n), n, 8)).astype(np.float32)
        best_py = best_rs = 0.0
        for _ in range(args.repeats):
            steps, secs = python_vector(vec, acts, args.seconds)
            best_py = max(best_py, n * steps / secs)
            best_rs = max(best_rs, n * steps / native(tables, acts, steps))
        rows.append({"case": f"FoosballVectorEnv ({n} table{'s' if n > 1 else ''})", "tables": n, "threads": threads, "python": best_py, "rust": best_rs})

    print(f"Env steps/s, `reference` preset, {cores} cores, best of {args.repeats} rounds of {args.seconds:g} s:\n")
    print("| case | threads | Python env steps/s | Rust-native env steps/s | Python / Rust | Python overhead per call (µs) | Python / reference MuJoCo gym |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        r["ratio"] = r["python"] / r["rust"]
        r["overhead_us_per_call"] = 1e6 * r["tables"] * (1 / r["python"] - 1 / r["rust"])
        r["vs_reference_gym"] = r["python"] / REFERENCE_GYM_STEPS_PER_S
        print(
            f"| {r['case']} | {r['threads']} | {r['python']:,.0f} | {r['rust']:,.0f} | {r['ratio']:.0%} | "
            f"{r['overhead_us_per_call']:.1f} | {r['vs_reference_gym']:,.0f}x |"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"reference_gym_steps_per_s": REFERENCE_GYM_STEPS_PER_S, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
