"""FoosballVectorEnv: Gymnasium's SAME_STEP autoreset with final observations and episode
metrics, results independent of the thread count, seeding (the batch's seeding against
the Rust VecEnv is in test_parity.py)."""

import numpy as np
from gymnasium.vector import AutoresetMode

from foosball_rl import FoosballVectorEnv


def actions(t, n):
    k = np.arange(8)
    return np.stack([1.3 * np.sin(0.21 * t + 0.9 * k + 2.1 * i) for i in range(n)]).astype(np.float32)


def play(vec, steps):
    out = [vec.reset(seed=5)[0]]
    for t in range(steps):
        out.append(vec.step(actions(t, vec.num_envs)))
    return out


def test_same_step_autoreset_hands_back_the_final_observation():
    vec = FoosballVectorEnv(4, threads=2)
    assert vec.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    assert vec.observation_space.shape == (4, 38) and vec.action_space.shape == (4, 8)
    obs, _ = vec.reset(seed=5)
    assert vec.observation_space.contains(obs)
    seen_end = False
    for t in range(120):
        a = actions(t, 4)
        obs, rewards, terminated, truncated, infos = vec.step(a)
        done = terminated | truncated
        if done.any():
            assert (infos["_final_obs"] == done).all()
            assert infos["final_obs"].shape == (4, 38)
            assert (infos["final_obs"][~done] == 0).all()
            ep = infos["final_info"]["episode"]
            assert (ep["length"][done] > 0).all() and (ep["length"][~done] == 0).all()
            ends = infos["final_info"]["end"]
            assert all((e is not None) == d for e, d in zip(ends, done))
            seen_end = True
        else:
            assert "final_obs" not in infos
        assert infos["goal_distance"].shape == (4,) and infos["_goal_distance"].all()
    assert seen_end


def test_the_thread_count_changes_nothing():
    one = play(FoosballVectorEnv(5, threads=1), 60)
    two = play(FoosballVectorEnv(5, threads=2), 60)
    np.testing.assert_array_equal(one[0], two[0])
    for a, b in zip(one[1:], two[1:]):
        for x, y in zip(a[:4], b[:4]):
            np.testing.assert_array_equal(x, y)
        if "final_obs" in a[4]:
            np.testing.assert_array_equal(a[4]["final_obs"], b[4]["final_obs"])


def test_an_unseeded_reset_goes_on_and_a_seeded_one_repeats():
    vec = FoosballVectorEnv(3)
    first, _ = vec.reset(seed=9)
    second, _ = vec.reset()
    assert not np.array_equal(first, second)
    again, _ = vec.reset(seed=9)
    np.testing.assert_array_equal(first, again)


def test_render_gives_one_frame_per_table():
    vec = FoosballVectorEnv(2, render_mode="rgb_array", render_scale=1.0)
    vec.reset(seed=0)
    frames = vec.render()
    assert len(frames) == 2 and frames[0].dtype == np.uint8 and frames[0].shape[2] == 3


def test_a_seeded_batch_is_seeded_like_lone_tables_by_derive_seed():
    from foosball_rl import TRAIN_ENVS, FoosballEnv, derive_seed

    obs, _ = FoosballVectorEnv(3).reset(seed=12)
    for i in range(3):
        lone, _ = FoosballEnv().reset(seed=derive_seed(12, TRAIN_ENVS, i))
        np.testing.assert_array_equal(obs[i], lone)
