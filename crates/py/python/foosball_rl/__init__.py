"""foosball-rl's table for Python: Gymnasium environments over the Rust simulation.

    import gymnasium as gym
    import foosball_rl  # registers FoosballRL/<Preset>-v0

    env = gym.make("FoosballRL/Reference-v0")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

`FoosballEnv` is one table (`gymnasium.Env`), `FoosballVectorEnv` N tables stepped in
parallel by Rust (`gymnasium.vector.VectorEnv`, autoreset mode SAME_STEP). Both take
the configuration as the Rust side does: a preset name, a TOML file (a run config's
`[env]` or bare env keys) and keyword overrides (`rules={"end_on_goal": True}` or
`**{"rules.end_on_goal": True}`).

`evaluate(policy)` is the paper's standard test (1,000 episodes, five metrics with 95 %
intervals) exactly as the Rust `evaluate` plays it: the same starts, the same numbers.
"""

import json
import os
from typing import Any, Callable, Union

import numpy as np

from gymnasium.envs.registration import register

from foosball_rl._core import (
    END_REASONS,
    EVAL_ENVS,
    PRESETS,
    TEST_ENVS,
    TRAIN_ENVS,
    ActionError,
    ConfigError,
    ResetNeeded,
    derive_seed,
    standard_test,
)
from foosball_rl.env import FoosballEnv
from foosball_rl.vector import FoosballVectorEnv

__all__ = [
    "ActionError",
    "ConfigError",
    "END_REASONS",
    "EVAL_ENVS",
    "FoosballEnv",
    "FoosballVectorEnv",
    "PRESETS",
    "ResetNeeded",
    "TEST_ENVS",
    "TRAIN_ENVS",
    "derive_seed",
    "env_id",
    "evaluate",
]


def env_id(preset: str) -> str:
    """The registered id of a preset: `reference_v1` -> `FoosballRL/ReferenceV1-v0`."""
    return "FoosballRL/" + "".join(p.capitalize() for p in preset.split("_")) + "-v0"


for _preset in PRESETS:
    register(
        id=env_id(_preset),
        entry_point="foosball_rl.env:FoosballEnv",
        vector_entry_point="foosball_rl.vector:FoosballVectorEnv",
        kwargs={"preset": _preset},
    )


def evaluate(
    policy: Union[Callable[[np.ndarray], Any], str, os.PathLike],
    episodes: int = 1000,
    seed: int = 0,
    preset: Union[str, None] = None,
    config: Union[str, os.PathLike, None] = None,
    **overrides: Any,
) -> dict:
    """The paper's standard test of `policy`: `episodes` episodes from the test seeds of
    `seed` (`derive_seed(seed, TEST_ENVS, k)`), ten tables side by side, on the table of
    `preset` (default `reference`), `config` and `overrides` as `FoosballEnv` takes them.

    `policy` is a callable from observations `[n, 38]` (float32) to actions `[n, 8]`
    (anything numpy reads; values beyond [-1, 1] are clamped by the table), or the path
    of an ONNX file (input `[batch, 38]`, first output the action), run by onnxruntime.
    Returns the metrics as `evaluate` writes them to `metrics.json`: `score_rate`,
    `mean_goal_distance`, `mean_ball_speed`, `mean_return`, `mean_final_distance`,
    `mean_length` (each `{"mean", "ci95"}`), `episodes` and `end_reasons` (shares).
    The same policy and seed give the same numbers as `evaluate` in Rust.
    """
    if isinstance(policy, (str, os.PathLike)):
        try:
            import onnxruntime
        except ImportError as e:
            raise ImportError(
                "an ONNX policy needs onnxruntime (pip install onnxruntime), or test it "
                "from Rust: cargo run --release --bin evaluate -- --run FILE.onnx"
            ) from e
        session = onnxruntime.InferenceSession(
            os.fspath(policy), providers=["CPUExecutionProvider"]
        )
        name = session.get_inputs()[0].name

        def act(obs: np.ndarray) -> Any:
            return session.run(None, {name: obs})[0]

    elif callable(policy):
        act = policy
    else:
        raise TypeError("policy must be a callable or the path of an ONNX file")

    def answer(obs: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(np.asarray(act(obs), dtype=np.float32))

    text = standard_test(
        answer,
        episodes,
        seed,
        preset,
        None if config is None else os.fspath(config),
        overrides or None,
    )
    return json.loads(text)
