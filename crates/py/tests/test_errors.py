"""Bad input raises a Python exception that names what is at fault; a refused step
leaves the table as it was."""

import numpy as np
import pytest

import foosball_rl
from foosball_rl import ActionError, ConfigError, FoosballEnv, FoosballVectorEnv, ResetNeeded


@pytest.mark.parametrize(
    "kwargs, named",
    [
        ({"rules": {"bogus": 1}}, "rules.bogus"),
        ({"reward.beta": "x"}, "reward.beta"),
        ({"ball": {"model": "cube"}}, "ball.model"),
        ({"frame_skip": 0}, "frame_skip"),
        ({"preset": "nope"}, "nope"),
        ({"observation": {"kind": "pixels"}}, "observation.kind"),
        ({"rules": {"stagnant_steps": object()}}, "rules.stagnant_steps"),
    ],
)
def test_a_bad_setting_is_refused_by_key(kwargs, named):
    with pytest.raises(ConfigError, match=named.replace(".", r"\.")):
        FoosballEnv(**kwargs)
    # ConfigError is a ValueError.
    with pytest.raises(ValueError):
        FoosballVectorEnv(2, **kwargs)


def test_a_bad_file_is_named(tmp_path):
    with pytest.raises(ConfigError, match="missing.toml"):
        FoosballEnv(config=tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[env\n")
    with pytest.raises(ConfigError, match="bad.toml"):
        FoosballEnv(config=bad)
    # A base that is missing is named with the file that names it.
    orphan = tmp_path / "orphan.toml"
    orphan.write_text('extends = "gone.toml"\n')
    with pytest.raises(ConfigError, match=r"orphan.toml: extends = \"gone.toml\": cannot read"):
        FoosballEnv(config=orphan)


def test_a_refused_action_leaves_the_table_as_it_was():
    env, twin = FoosballEnv(), FoosballEnv()
    env.reset(seed=3)
    twin.reset(seed=3)
    for bad, message in [
        (np.array([np.nan] + [0.0] * 7), r"action\[0\] is not finite"),
        (np.array([0.0] * 5 + [np.inf, 0.0, 0.0]), r"action\[5\] is not finite"),
        (np.zeros(7), r"shape \(7,\)"),
        (np.zeros((2, 8)), r"shape \(2, 8\)"),
    ]:
        with pytest.raises(ActionError, match=message):
            env.step(bad)
    a = np.full(8, 0.5, np.float32)
    np.testing.assert_array_equal(env.step(a)[0], twin.step(a)[0])


def test_stepping_needs_a_reset():
    env = FoosballEnv()
    with pytest.raises(ResetNeeded):
        env.step(np.zeros(8, np.float32))
    env.reset(seed=0)
    while True:
        _, _, terminated, truncated, _ = env.step(np.zeros(8, np.float32))
        if terminated or truncated:
            break
    with pytest.raises(ResetNeeded):
        env.step(np.zeros(8, np.float32))
    vec = FoosballVectorEnv(2)
    with pytest.raises(ResetNeeded):
        vec.step(np.zeros((2, 8), np.float32))


def test_a_bad_row_of_a_batch_names_its_table_and_moves_none():
    vec, twin = FoosballVectorEnv(3), FoosballVectorEnv(3)
    vec.reset(seed=1)
    twin.reset(seed=1)
    actions = np.zeros((3, 8), np.float32)
    actions[2, 4] = np.nan
    with pytest.raises(ActionError, match=r"env 2: action\[4\] is not finite"):
        vec.step(actions)
    with pytest.raises(ActionError, match=r"shape \(3, 7\)"):
        vec.step(np.zeros((3, 7)))
    good = np.full((3, 8), -0.4, np.float32)
    np.testing.assert_array_equal(vec.step(good)[0], twin.step(good)[0])


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="render_mode"):
        FoosballEnv(render_mode="human")
    with pytest.raises(ValueError, match="num_envs"):
        FoosballVectorEnv(0)
    with pytest.raises(ValueError, match="seed"):
        FoosballEnv().reset(seed=-1)
    env = FoosballEnv(render_mode="rgb_array", render_scale=-1.0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="render scale"):
        env.render()
    assert foosball_rl.ResetNeeded.__mro__[1] is RuntimeError
