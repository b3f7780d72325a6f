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
"""

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
