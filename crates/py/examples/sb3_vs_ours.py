"""Stable-Baselines3's SAC beside this project's SAC, same game, networks and budget.

    pip install ./crates/py stable-baselines3      # torch comes with it; not needed by CI
    cargo build --release --bin train
    python crates/py/examples/sb3_vs_ours.py --seeds 0,1,2 --epochs 2 --out results/sb3-vs-ours

For each seed: this project's `train --config configs/sac.toml --hidden 64,64 --epochs E
--seed S --threads 1` (SB3's defaults, the paper code's SAC) and SB3's SAC with the same
settings (MlpPolicy [64, 64], lr 3e-4, buffer 1e6, learning_starts 100, batch 256,
tau 0.005, gamma 0.99, one gradient step per env step, entropy coefficient auto from
1.0) on `FoosballRL/Reference-v0`, one torch thread. Both are evaluated every 3,000
env steps on 10 deterministic episodes (seeds `derive_seed(S, EVAL_ENVS, i)`) and tested
on 1,000 deterministic episodes of their last networks (`derive_seed(S, TEST_ENVS, i)`),
the seeds this project's test uses, so both play the very same starts. `--jobs 2`
runs two trainings at once. Writes `<out>/{ours,sb3}-sac-seed<S>/` (ours: a run
directory; SB3: evaluations.csv, test/metrics.json, wall.json) and `<out>/report.md`,
`<out>/report.json` and `<out>/curves.png` (with matplotlib).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

Z95 = 1.959963984540054


def wilson(k: int, n: int) -> list[float]:
    p = k / n
    d = 1 + Z95**2 / n
    c = (p + Z95**2 / (2 * n)) / d
    h = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / d
    return [c - h, c + h]


# Student's t, 97.5 % quantile, by degrees of freedom (seeds - 1).
T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}


def mean_ci(x) -> dict:
    """Mean over seeds with Student's t 95 % interval (seeds are few)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    h = T975.get(n - 1, Z95) * x.std(ddof=1) / math.sqrt(n) if n > 1 else 0.0
    return {"mean": float(x.mean()), "ci95": [float(x.mean() - h), float(x.mean() + h)]}


def curves(out: Path, seeds: list[int], names: dict) -> str | None:
    """curves.png: evaluation score rate and mean return against env steps, each seed thin,
    the mean over seeds bold; None where matplotlib is not installed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for (kind, name), colour in zip(names.items(), ("tab:blue", "tab:orange")):
        runs = []
        for s in seeds:
            rows = np.genfromtxt(out / f"{kind}-sac-seed{s}" / "evaluations.csv", delimiter=",", names=True)
            runs.append(rows)
        steps = runs[0]["env_step"]
        for ax, key, scale in ((axes[0], "score_rate", 100.0), (axes[1], "mean_return", 1.0)):
            for r in runs:
                ax.plot(r["env_step"], scale * r[key], color=colour, alpha=0.3, lw=0.8)
            mean = np.mean([scale * r[key] for r in runs], axis=0)
            ax.plot(steps, mean, color=colour, lw=2, label=f"{name} (mean of {len(runs)})")
    axes[0].set_ylabel("evaluation score rate (%), 10 episodes")
    axes[1].set_ylabel("evaluation mean episode reward")
    for ax in axes:
        ax.set_xlabel("env steps")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(out / "curves.png", dpi=100)
    return "curves.png"


def ratio_ci(num, den) -> dict:
    """Ratio of sums over episodes, delta-method interval with episodes as clusters."""
    num, den = np.asarray(num, float), np.asarray(den, float)
    r = num.sum() / den.sum()
    n = len(num)
    resid = (num - r * den) / den.mean()
    h = Z95 * math.sqrt((resid**2).sum() / (n * (n - 1))) if n > 1 else 0.0
    return {"mean": float(r), "ci95": [float(r - h), float(r + h)]}


def play(model, seed: int, stream: int, episodes: int) -> dict:
    """The paper's five metrics (+ length) of `episodes` deterministic episodes."""
    from foosball_rl import FoosballEnv, derive_seed

    env = FoosballEnv(preset="reference")
    rets, lens, scored, dsum, vsum, final = [], [], [], [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=derive_seed(seed, stream, i))
        while True:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                break
        ep = info["episode"]
        rets.append(ep["return"])
        lens.append(ep["length"])
        scored.append(ep["scored"])
        dsum.append(ep["mean_goal_distance"] * ep["length"])
        vsum.append(ep["mean_ball_speed"] * ep["length"])
        final.append(ep["final_goal_distance"])
    k = int(sum(scored))
    return {
        "episodes": episodes,
        "score_rate": {"mean": k / episodes, "ci95": wilson(k, episodes)},
        "mean_goal_distance": ratio_ci(dsum, lens),
        "mean_ball_speed": ratio_ci(vsum, lens),
        "mean_return": mean_ci(rets),
        "mean_final_distance": mean_ci(final),
        "mean_length": mean_ci(lens),
    }


def run_sb3(seed: int, epochs: int, out: Path) -> None:
    import gymnasium as gym
    import torch
    from stable_baselines3 import SAC
    from stable_baselines3.common.callbacks import BaseCallback

    import foosball_rl

    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    (out / "test").mkdir(exist_ok=True)
    env = gym.make("FoosballRL/Reference-v0")

    class Evaluate(BaseCallback):
        def __init__(self):
            super().__init__()
            self.rows = ["env_step,mean_return,score_rate,mean_length"]

        def _on_step(self) -> bool:
            if self.num_timesteps % 3000 == 0:
                m = play(self.model, seed, foosball_rl.EVAL_ENVS, 10)
                self.rows.append(
                    f"{self.num_timesteps},{m['mean_return']['mean']},{m['score_rate']['mean']},{m['mean_length']['mean']}"
                )
                (out / "evaluations.csv").write_text("\n".join(self.rows) + "\n")
            return True

    model = SAC(
        "MlpPolicy",
        env,
        learning_rate=3e-4,
        buffer_size=1_000_000,
        learning_starts=100,
        batch_size=256,
        tau=0.005,
        gamma=0.99,
        train_freq=1,
        gradient_steps=1,
        ent_coef="auto_1.0",
        target_update_interval=1,
        policy_kwargs={"net_arch": [64, 64]},
        seed=seed,
        device="cpu",
    )
    start = time.perf_counter()
    model.learn(total_timesteps=epochs * 100_000, callback=Evaluate())
    train_s = time.perf_counter() - start
    start = time.perf_counter()
    metrics = play(model, seed, foosball_rl.TEST_ENVS, 1000)
    test_s = time.perf_counter() - start
    (out / "test" / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    (out / "wall.json").write_text(json.dumps({"train_s": train_s, "test_s": test_s}, indent=2) + "\n")


def run_ours(seed: int, epochs: int, out: Path, train: Path) -> None:
    start = time.perf_counter()
    cmd = [str(train), "--config", "configs/sac.toml", "--hidden", "64,64", "--epochs", str(epochs),
           "--seed", str(seed), "--threads", "1", "--out", str(out)]
    if out.exists():
        cmd.append("--force")
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    (out / "wall.json").write_text(json.dumps({"train_and_test_s": time.perf_counter() - start}, indent=2) + "\n")


def job(kind: str, seed: int, epochs: int, out: Path, train: Path) -> str:
    target = out / f"{kind}-sac-seed{seed}"
    if (target / "test" / "metrics.json").exists() and (target / "wall.json").exists():
        return f"{target} already done"
    if kind == "sb3":
        run_sb3(seed, epochs, target)
    else:
        run_ours(seed, epochs, target, train)
    return f"{target} done"


def report(out: Path, seeds: list[int]) -> None:
    rows, summary = [], {}
    names = {"ours": "foosball-rl SAC (Burn)", "sb3": "Stable-Baselines3 SAC (PyTorch)"}
    for kind, name in names.items():
        rates, walls = [], []
        for s in seeds:
            d = out / f"{kind}-sac-seed{s}"
            m = json.loads((d / "test" / "metrics.json").read_text())
            w = json.loads((d / "wall.json").read_text())
            wall = w.get("train_and_test_s", w.get("train_s", 0) + w.get("test_s", 0))
            rates.append(m["score_rate"]["mean"])
            walls.append(wall)
            lo, hi = m["score_rate"]["ci95"]
            rows.append(
                f"| {name} | {s} | {100 * m['score_rate']['mean']:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}] | "
                f"{m['mean_return']['mean']:,.0f} | {m['mean_final_distance']['mean']:.1f} | {m['mean_length']['mean']:.0f} | {wall / 60:.0f} |"
            )
        summary[kind] = {"score_rates": rates, "mean_score_rate": mean_ci(rates), "wall_s": walls}
        m = summary[kind]["mean_score_rate"]
        rows.append(
            f"| **{name}** | mean of {len(seeds)} | **{100 * m['mean']:.1f} %** [{100 * m['ci95'][0]:.1f}, {100 * m['ci95'][1]:.1f}] over seeds | | | | {np.mean(walls) / 60:.0f} |"
        )
    text = [
        "# SB3's SAC beside foosball-rl's SAC",
        "",
        f"`FoosballRL/Reference-v0` (preset `reference`), 64x64 networks, SB3 defaults, {len(seeds)} seeds,",
        "1,000 deterministic test episodes of the last networks on the same starts. Made by",
        "`python crates/py/examples/sb3_vs_ours.py` (its docstring has the settings).",
        "",
        "| learner | seed | test score rate [95 % CI] | mean return | mean final distance (cm) | mean length (steps) | wall (min) |",
        "| --- | --- | --- | --- | --- | --- | --- |",
        *rows,
        "",
        "Means over seeds carry Student's t 95 % intervals; per seed, the Wilson interval over",
        "its 1,000 test episodes.",
        "",
    ]
    chart = curves(out, seeds, names)
    if chart:
        text += ["Evaluation curves (every 3,000 env steps, 10 deterministic episodes):", "", f"![curves]({chart})", ""]
    (out / "report.md").write_text("\n".join(text))
    (out / "report.json").write_text(json.dumps(summary, indent=2) + "\n")
    print("\n".join(text))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", default="0,1,2")
    p.add_argument("--epochs", type=int, default=2)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--only", choices=["ours", "sb3"])
    p.add_argument("--train", type=Path, default=Path("target/release/train"))
    p.add_argument("--out", type=Path, default=Path("results/sb3-vs-ours"))
    a = p.parse_args()
    seeds = [int(s) for s in a.seeds.split(",")]
    kinds = [a.only] if a.only else ["ours", "sb3"]
    if "ours" in kinds and not a.train.exists():
        sys.exit(f"{a.train} is missing: cargo build --release --bin train")
    with ProcessPoolExecutor(max_workers=a.jobs) as pool:
        futures = [pool.submit(job, k, s, a.epochs, a.out, a.train) for s in seeds for k in kinds]
        for f in futures:
            print(f.result(), flush=True)
    if not a.only:
        report(a.out, seeds)


if __name__ == "__main__":
    main()
