"""`FoosballEnv`: one table as a `gymnasium.Env`."""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np

from foosball_rl._core import ActionError, Table


class FoosballEnv(gym.Env):
    """The ITSF Tornado T-3000 table: yellow (the agent) against black.

    Observation: the 38-dim state, float32 (ball position 0:3 cm and velocity 3:6 cm/s,
    rod slides 6:14 cm and their velocities 14:22, rod angles 22:30 rad and their
    velocities 30:38; yellow's rods first, goalie to attack), or for
    `observation={"kind": "image"}` stacked top-down frames `[channels, height, width]`
    with values in [0, 1]. Action: 8 values in [-1, 1] (slide, then turn, of yellow's
    goalie, defence, midfield and attack rods). Reward and episode rules: the preset's
    (`reference` is the paper code's game). `info` holds the end reason and the paper's
    metrics (`goal_distance` cm, `ball_speed` cm/s, `scored`; `episode` with the
    episode's return, length and means on its last step).

    Args:
        preset: a preset name (`foosball_rl.PRESETS`), default `reference`.
        config: a TOML file: a run config (its `[env]` section) or bare env keys.
        render_mode: None or "rgb_array" (top-down frames, uint8 `[H, W, 3]`).
        render_scale: pixels per cm of the rendered frames.
        **overrides: env keys over the preset and the file, nested dicts or dotted
            names (`**{"rules.end_on_goal": True}`).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        preset: str | None = None,
        config: str | os.PathLike | None = None,
        render_mode: str | None = None,
        render_scale: float = 4.0,
        **overrides: Any,
    ) -> None:
        _check_render_mode(render_mode)
        self._table = Table(preset, None if config is None else os.fspath(config), overrides)
        self.render_mode = render_mode
        self.render_scale = float(render_scale)
        shape = tuple(self._table.obs_shape)
        low, high = (0.0, 1.0) if self._table.image_obs else (-np.inf, np.inf)
        self.observation_space = gym.spaces.Box(low, high, shape, dtype=np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (self._table.action_dim,), dtype=np.float32)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self._table.agent_dt)}

    @property
    def config_toml(self) -> str:
        """The whole configuration, every value pinned, as TOML."""
        return self._table.config_toml

    @property
    def max_episode_steps(self) -> int:
        """Agent steps after which the table truncates an episode itself."""
        return self._table.max_episode_steps

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Starts an episode. With `seed` the table restarts its random stream from it;
        without, the first reset draws a seed from `np_random` and later ones go on.
        `options={"ball": (x, y)}` places the ball at rest there (cm, in the config's ball
        frame) instead of drawing its start; an unknown option or a ball off the playfield
        raises ValueError."""
        _check_seed(seed)
        ball = None
        if options:
            unknown = sorted(set(options) - {"ball"})
            if unknown:
                raise ValueError(f"reset options {unknown} are not known; the one option is 'ball'")
            ball = options["ball"]
            if ball is not None:
                ball = tuple(float(v) for v in ball)
                if len(ball) != 2:
                    raise ValueError(f"reset option 'ball' must be (x, y), got {options['ball']!r}")
        super().reset(seed=seed)
        if seed is None and not getattr(self, "_started", False):
            seed = int(self.np_random.integers(0, 2**63))
        self._started = True
        return self._table.reset(seed, ball), {}

    def step(self, action):
        """One agent step: `(obs, reward, terminated, truncated, info)`."""
        a = np.ascontiguousarray(action, dtype=np.float32)
        if a.shape != self.action_space.shape:
            raise ActionError(f"action has shape {a.shape}, expected {self.action_space.shape}")
        return self._table.step(a)

    def render(self):
        """The current table as uint8 `[height, width, 3]` (render_mode "rgb_array")."""
        if self.render_mode is None:
            gym.logger.warn("render() without render_mode: make the env with render_mode='rgb_array'")
            return None
        return self._table.render(self.render_scale)

    def state(self) -> np.ndarray | None:
        """The noise-free 38-dim state, whatever the observation kind."""
        return self._table.state()


def _check_seed(seed) -> None:
    """Refuses a seed the Rust table cannot take (a u64)."""
    if seed is not None and not (isinstance(seed, (int, np.integer)) and 0 <= seed < 2**64):
        raise ValueError(f"seed must be an integer in [0, 2**64), got {seed!r}")


def _check_render_mode(render_mode) -> None:
    """Refuses a render mode other than None or "rgb_array"."""
    if render_mode not in (None, "rgb_array"):
        raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
