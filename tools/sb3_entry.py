"""An outside entry, trained as an SB3 user would: Stable-Baselines3 PPO or SAC on the
Python front's `reference` table, the deterministic actor exported to ONNX for the
standard test (`evaluate --run FILE.onnx`) and the league.

    python tools/sb3_entry.py --algo ppo --steps 1500000 --seed 0 --out runs/sb3-ppo-seed0

writes OUT/model.zip (SB3's own save), OUT/policy.onnx (observation [batch, 38] f32 ->
action [batch, 8] f32, what `export` writes for our runs) and OUT/entry.json (the
settings, wall time, env steps). SB3's defaults throughout (PPO: 64x64 tanh, n_steps
2048; SAC: 256x256 relu, buffer 1e6, one gradient step per step of the vector env), on
8 tables (`--envs`; with SAC that is one gradient step per 8 env steps, `--envs 1` the
paper's one per env step, about 6 times slower here). `--checkpoint-every N` saves the
model and the replay buffer to OUT/checkpoint every N env steps and `--resume` goes on
from there, so a run of hours survives an interrupted session. A
measuring instrument, not part of the project: it needs stable-baselines3, torch and
onnx beside the foosball_rl wheel (docs/python.md).
"""

import argparse
import json
import os
import time

import gymnasium as gym
import numpy as np
import torch

import foosball_rl  # noqa: F401  (registers the envs)


class DeterministicActor(torch.nn.Module):
    """SB3's deterministic action, clipped to [-1, 1] as SB3's predict() clips it."""

    def __init__(self, policy):
        super().__init__()
        self.policy = policy

    def forward(self, observation):
        action = self.policy._predict(observation, deterministic=True)
        return torch.clamp(action, -1.0, 1.0)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--algo", choices=["ppo", "sac"], required=True)
    p.add_argument("--steps", type=int, default=1_500_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--envs", type=int, default=8, help="tables stepped together")
    p.add_argument("--checkpoint-every", type=int, default=0, help="env steps; 0: never")
    p.add_argument("--resume", action="store_true", help="go on from OUT/checkpoint")
    p.add_argument("--out", required=True)
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    torch.set_num_threads(1)

    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.env_util import make_vec_env

    env_id = foosball_rl.env_id("reference")
    algo = {"ppo": PPO, "sac": SAC}[args.algo]
    env = make_vec_env(env_id, n_envs=args.envs, seed=args.seed)
    checkpoint = os.path.join(args.out, "checkpoint")
    state_path = os.path.join(args.out, "checkpoint.json")
    wall_before = 0.0
    if args.resume:
        model = algo.load(checkpoint + ".zip", env=env, device="cpu")
        if hasattr(model, "load_replay_buffer"):
            model.load_replay_buffer(checkpoint + "-replay.pkl")
        with open(state_path) as f:
            wall_before = json.load(f)["wall_s"]
        print(f"resumed at {model.num_timesteps} env steps", flush=True)
    else:
        model = algo("MlpPolicy", env, seed=args.seed, verbose=0, device="cpu")
    start = time.time()

    def save_checkpoint():
        model.save(checkpoint + ".zip")
        if hasattr(model, "save_replay_buffer"):
            model.save_replay_buffer(checkpoint + "-replay.pkl")
        wall = wall_before + time.time() - start
        with open(state_path + ".tmp", "w") as f:
            json.dump({"env_steps": model.num_timesteps, "wall_s": wall}, f)
        os.replace(state_path + ".tmp", state_path)
        rate = (model.num_timesteps) / max(wall, 1e-9)
        print(f"{model.num_timesteps} env steps, {wall:.0f} s, {rate:.0f} steps/s", flush=True)

    while model.num_timesteps < args.steps:
        chunk = args.steps - model.num_timesteps
        if args.checkpoint_every:
            chunk = min(chunk, args.checkpoint_every)
        model.learn(total_timesteps=chunk, reset_num_timesteps=False, progress_bar=False)
        if args.checkpoint_every:
            save_checkpoint()
    wall = wall_before + time.time() - start
    model.save(os.path.join(args.out, "model.zip"))

    actor = DeterministicActor(model.policy).eval()
    example = torch.zeros((1, 38), dtype=torch.float32)
    onnx_path = os.path.join(args.out, "policy.onnx")
    torch.onnx.export(
        actor,
        example,
        onnx_path,
        input_names=["observation"],
        output_names=["action"],
        dynamic_axes={"observation": {0: "batch"}, "action": {0: "batch"}},
        opset_version=17,
        dynamo=False,
    )
    # The export acts as SB3's predict() on observations of the table.
    table = gym.make(env_id)
    obs, _ = table.reset(seed=123)
    rows = []
    for _ in range(200):
        rows.append(obs)
        obs, _, terminated, truncated, _ = table.step(table.action_space.sample())
        if terminated or truncated:
            obs, _ = table.reset()
    batch = np.asarray(rows, dtype=np.float32)
    predicted, _ = model.predict(batch, deterministic=True)
    with torch.no_grad():
        exported = actor(torch.from_numpy(batch)).numpy()
    gap = float(np.abs(predicted - exported).max())
    with open(os.path.join(args.out, "entry.json"), "w") as f:
        json.dump(
            {
                "algo": args.algo,
                "steps": args.steps,
                "seed": args.seed,
                "envs": args.envs,
                "env_id": env_id,
                "wall_s": round(wall, 1),
                "stable_baselines3": __import__("stable_baselines3").__version__,
                "torch": torch.__version__,
                "largest_gap_to_predict": gap,
            },
            f,
            indent=2,
        )
    print(f"{args.algo}: {args.steps} env steps in {wall:.0f} s; {onnx_path} (gap {gap:.2e})")


if __name__ == "__main__":
    main()
