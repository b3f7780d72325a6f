"""`FoosballVectorEnv`: N tables stepped in parallel by Rust, as a Gymnasium VectorEnv."""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from foosball_rl._core import ActionError, VecTable
from foosball_rl.env import _check_render_mode, _check_seed

# Per-step info keys, each a [num_envs] array.
_STEP_KEYS = (
    "goal_distance",
    "ball_speed",
    "steps",
    "in_goal",
    "in_own_goal",
    "scored",
    "conceded",
    "spins",
    "goals",
    "serves",
)
_EPISODE_KEYS = ("return", "length", "scored", "mean_goal_distance", "mean_ball_speed", "final_goal_distance")


class FoosballVectorEnv(VectorEnv):
    """`num_envs` tables of one configuration (see `FoosballEnv` for the arguments),
    stepped on `threads` Rust threads with the GIL released.

    Autoreset is Gymnasium's SAME_STEP mode (the Rust VecEnv's): a table whose episode
    ends on a step is reset within it; `obs` holds the next episode's first observation
    and `infos["final_obs"]` / `infos["final_info"]` (masks `_final_obs` / `_final_info`)
    the ended episode's last ones, `final_info["episode"]` its metrics. `reset(seed=s)`
    seeds table i with `derive_seed(s, TRAIN_ENVS, i)`, as a Rust training run does.
    """

    metadata = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self,
        num_envs: int = 8,
        preset: str | None = None,
        config: str | os.PathLike | None = None,
        threads: int | None = None,
        render_mode: str | None = None,
        render_scale: float = 4.0,
        **overrides: Any,
    ) -> None:
        _check_render_mode(render_mode)
        self._tables = VecTable(
            num_envs, threads, preset, None if config is None else os.fspath(config), overrides
        )
        self.num_envs = num_envs
        self.render_mode = render_mode
        self.render_scale = float(render_scale)
        shape = tuple(self._tables.obs_shape)
        image = len(shape) == 3
        low, high = (0.0, 1.0) if image else (-np.inf, np.inf)
        self.single_observation_space = gym.spaces.Box(low, high, shape, dtype=np.float32)
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (8,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._all = np.ones(num_envs, dtype=bool)
        self._seeded = False

    @property
    def config_toml(self) -> str:
        """The tables' configuration, every value pinned, as TOML."""
        return self._tables.config_toml

    @property
    def threads(self) -> int:
        """Rust worker threads stepping the tables."""
        return self._tables.threads

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        """Starts an episode on every table: `(obs [num_envs, ...], infos)`. A single
        seed seeds the batch (table i: `derive_seed(seed, TRAIN_ENVS, i)`); without one the
        first reset draws a seed from `np_random` and later ones go on."""
        if isinstance(seed, (list, tuple)):
            raise ValueError("FoosballVectorEnv.reset takes one seed for the batch (table i is seeded from it and i)")
        _check_seed(seed)
        self._np_random_seed = seed
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        if seed is None and not self._seeded:
            seed = int(self.np_random.integers(0, 2**63))
        self._seeded = True
        return self._tables.reset(seed), {}

    def step(self, actions):
        """Steps every table: `(obs, rewards, terminations, truncations, infos)`."""
        a = np.ascontiguousarray(actions, dtype=np.float32)
        if a.shape != self.action_space.shape:
            raise ActionError(f"actions have shape {a.shape}, expected {self.action_space.shape}")
        obs, rewards, terminated, truncated, step_infos, ended = self._tables.step(a)
        infos: dict[str, Any] = step_infos
        for key in _STEP_KEYS:
            infos["_" + key] = self._all
        if ended is not None:
            done = ended["done"]
            final_info: dict[str, Any] = {key: step_infos[key] for key in _STEP_KEYS}
            final_info.update({"_" + key: done for key in _STEP_KEYS})
            final_info["end"] = np.array(ended["end"], dtype=object)
            final_info["_end"] = done
            final_info["episode"] = {key: ended[key] for key in _EPISODE_KEYS}
            final_info["episode"].update({"_" + key: done for key in _EPISODE_KEYS})
            final_info["_episode"] = done
            infos["final_obs"] = ended["final_obs"]
            infos["_final_obs"] = done
            infos["final_info"] = final_info
            infos["_final_info"] = done
        return obs, rewards, terminated, truncated, infos

    def render(self):
        """Every table's frame, a tuple of uint8 `[height, width, 3]` (render_mode "rgb_array")."""
        if self.render_mode is None:
            gym.logger.warn("render() without render_mode: make the env with render_mode='rgb_array'")
            return None
        return tuple(self._tables.render(self.render_scale))
