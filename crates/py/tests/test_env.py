"""FoosballEnv as Gymnasium sees it: the env checker, registered ids, spaces, seeding,
info and episode metrics, rendering, configuration layers."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import foosball_rl
from foosball_rl import FoosballEnv


@pytest.mark.filterwarnings("ignore:.*Box observation space (minimum|maximum) value is.*infinity")
def test_gymnasiums_env_checker_passes():
    # Made through gym.make so that the checker can try the render modes; the state is
    # unbounded (velocities), which the checker only warns about.
    env = gym.make("FoosballRL/Reference-v0", render_mode="rgb_array").unwrapped
    check_env(env, skip_render_check=False)


@pytest.mark.parametrize("preset", foosball_rl.PRESETS)
def test_every_preset_is_registered_and_made(preset):
    env = gym.make(foosball_rl.env_id(preset))
    assert f'preset = "{preset}"' in env.unwrapped.config_toml
    obs, info = env.reset(seed=1)
    assert obs.shape == (38,) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)


def test_spaces_are_the_rust_bounds():
    env = FoosballEnv()
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (8,), np.float32)
    assert env.observation_space.shape == (38,)
    assert env.observation_space.dtype == np.float32
    image = FoosballEnv(observation={"kind": "image", "width": 48, "height": 40, "frame_stack": 2})
    assert image.observation_space.shape == (2, 40, 48)
    obs, _ = image.reset(seed=0)
    assert obs.shape == (2, 40, 48) and 0.0 <= obs.min() and obs.max() <= 1.0


def test_a_seed_fixes_the_episode_and_no_seed_goes_on():
    env = FoosballEnv()
    first, _ = env.reset(seed=11)
    again, _ = env.reset(seed=11)
    np.testing.assert_array_equal(first, again)
    other, _ = env.reset()
    assert not np.array_equal(first, other)
    # Two envs seeded alike play alike.
    a, b = FoosballEnv(), FoosballEnv()
    a.reset(seed=4)
    b.reset(seed=4)
    for t in range(30):
        act = np.full(8, np.sin(t), dtype=np.float32)
        ra, rb = a.step(act), b.step(act)
        np.testing.assert_array_equal(ra[0], rb[0])
        assert ra[1:4] == rb[1:4]


def test_the_last_step_reports_the_end_and_the_episode_metrics():
    env = FoosballEnv()
    env.reset(seed=2)
    rewards, distances, speeds = [], [], []
    for t in range(20_000):
        obs, reward, terminated, truncated, info = env.step(np.zeros(8, np.float32))
        rewards.append(reward)
        distances.append(info["goal_distance"])
        speeds.append(info["ball_speed"])
        assert info["steps"] == t + 1
        if terminated or truncated:
            break
    assert info["end"] in foosball_rl.END_REASONS
    ep = info["episode"]
    assert ep["length"] == len(rewards)
    assert ep["return"] == pytest.approx(sum(rewards), rel=1e-6)
    assert ep["mean_goal_distance"] == pytest.approx(np.mean(distances), rel=1e-6)
    assert ep["mean_ball_speed"] == pytest.approx(np.mean(speeds), rel=1e-6, abs=1e-9)
    assert ep["final_goal_distance"] == pytest.approx(distances[-1])
    assert ep["scored"] is False
    # A zero policy never touches the ball: the start ball stagnates; no rod spins.
    assert info["end"] == "stagnant"
    assert info["spins"] == [0, 0]
    assert info["goals"] == [0, 0] and info["serves"] == 0


def test_render_draws_the_table():
    env = FoosballEnv(render_mode="rgb_array", render_scale=2.0)
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    big = FoosballEnv(render_mode="rgb_array", render_scale=4.0)
    big.reset(seed=0)
    assert big.render().shape[0] == pytest.approx(2 * frame.shape[0], abs=1)
    # The white ball is in the picture.
    assert (frame == 255).all(axis=2).any()


def test_config_layers_preset_file_overrides(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text('algo = "sac"\n[env]\npreset = "paper"\nframe_skip = 3\n')
    env = FoosballEnv(config=path)
    assert 'preset = "paper"' in env.config_toml and "frame_skip = 3" in env.config_toml
    # Keyword overrides win over the file, nested or dotted.
    env = FoosballEnv(config=path, frame_skip=2, rules={"end_on_goal": True}, **{"reward.beta": 10.0})
    toml = env.config_toml
    assert "frame_skip = 2" in toml and "end_on_goal = true" in toml and "beta = 10.0" in toml
    # A bare env table works as well, and the pinned TOML reproduces the config.
    bare = tmp_path / "env.toml"
    bare.write_text(toml)
    assert FoosballEnv(config=bare).config_toml == toml


def test_a_config_file_that_extends_another_gives_the_merged_env(tmp_path):
    (tmp_path / "base.toml").write_text('algo = "sac"\n[env]\npreset = "paper"\nframe_skip = 3\n')
    study = tmp_path / "study"
    study.mkdir()
    (study / "run.toml").write_text('extends = "../base.toml"\n[env.reward]\nbeta = 10.0\n')
    toml = FoosballEnv(config=study / "run.toml").config_toml
    assert 'preset = "paper"' in toml and "frame_skip = 3" in toml and "beta = 10.0" in toml


def test_reset_places_the_ball_and_a_probe_runs_past_the_end_rules():
    env = FoosballEnv(rules={"end_episodes": False})
    obs, _ = env.reset(seed=3, options={"ball": (5.0, 40.0)})
    # The reference's joint frame: x, y, and y again in the z slot; at rest.
    assert obs[:3].tolist() == [5.0, 40.0, 40.0] and not obs[3:6].any()
    # Held still, the ball stays; the stagnation rule (10 steps) would have ended it.
    for _ in range(30):
        obs, reward, terminated, truncated, info = env.step(np.zeros(8, dtype=np.float32))
        assert not (terminated or truncated)
    assert obs[:2].tolist() == [5.0, 40.0]


@pytest.mark.parametrize(
    "options, message",
    [({"ball": (0.0, 500.0)}, "not on the playfield"), ({"ball": (1.0,)}, "must be"), ({"bal": (0, 0)}, "not known")],
)
def test_bad_reset_options_name_what_is_wrong(options, message):
    env = FoosballEnv()
    with pytest.raises(ValueError, match=message):
        env.reset(seed=0, options=options)
