"""Python plays the Rust env bit for bit: the trajectories of
`data/trajectories.json`, which the Rust test `tests/suite/python_fixture.rs` checks the Rust
env still writes, replayed through FoosballEnv and FoosballVectorEnv."""

import json
from pathlib import Path

import numpy as np

from foosball_rl import FoosballEnv, FoosballVectorEnv

FIXTURE = json.loads((Path(__file__).parent / "data" / "trajectories.json").read_text())


def f32(rows):
    return np.array(rows, dtype=np.float32)


def test_one_table_replays_the_rust_trajectory():
    single = FIXTURE["single"]
    env = FoosballEnv(preset=FIXTURE["preset"])
    for n, episode in enumerate(single["episodes"]):
        obs, _ = env.reset(seed=single["seed"]) if n == 0 else env.reset()
        np.testing.assert_array_equal(obs, f32(episode["obs"][0]))
        for t, reward in enumerate(episode["rewards"]):
            obs, r, terminated, truncated, info = env.step(f32(episode["actions"][t]))
            np.testing.assert_array_equal(obs, f32(episode["obs"][t + 1]), err_msg=f"episode {n} step {t}")
            assert np.float32(r) == np.float32(reward)
            assert (terminated, truncated) == (episode["terminated"][t], episode["truncated"][t])
        assert info["end"] == episode["end"]


def test_a_batch_replays_the_rust_vecenv():
    v = FIXTURE["vector"]
    n = v["num_envs"]
    vec = FoosballVectorEnv(n, preset=FIXTURE["preset"], threads=2)
    obs, _ = vec.reset(seed=v["seed"])
    np.testing.assert_array_equal(obs.ravel(), f32(v["obs"][0]))
    finals = {(s, i): f32(o) for s, i, o in v["final_obs"]}
    for t in range(len(v["rewards"])):
        a = f32(v["actions"][t]).reshape(n, 8)
        obs, rewards, terminated, truncated, infos = vec.step(a)
        np.testing.assert_array_equal(obs.ravel(), f32(v["obs"][t + 1]), err_msg=f"step {t}")
        np.testing.assert_array_equal(rewards, f32(v["rewards"][t]))
        np.testing.assert_array_equal(terminated, v["terminated"][t])
        np.testing.assert_array_equal(truncated, v["truncated"][t])
        for i in range(n):
            if (t, i) in finals:
                assert infos["_final_obs"][i]
                np.testing.assert_array_equal(infos["final_obs"][i], finals[(t, i)])
            elif "final_obs" in infos:
                assert not infos["_final_obs"][i]
