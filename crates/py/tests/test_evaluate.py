"""The standard test from Python gives the Rust `evaluate`'s numbers: the metrics of
`data/standard_test.json`, which the Rust test `tests/suite/python_fixture.rs` checks
`evaluate` still gives, for the same policies and seed; bad policies are refused."""

import json
from pathlib import Path

import numpy as np
import pytest

import foosball_rl

FIXTURE = json.loads((Path(__file__).parent / "data" / "standard_test.json").read_text())


def zero(obs):
    return np.zeros((len(obs), 8))


def swing(obs):
    action = np.empty((len(obs), 8))
    action[:, 0::2] = np.where(obs[:, 0:1] > 0, 1.0, -1.0)
    action[:, 1::2] = np.where(obs[:, 22:26] > 0, -1.0, 1.0)
    return action


@pytest.mark.parametrize("name,policy", [("zero", zero), ("swing", swing)])
def test_the_standard_test_gives_evaluates_numbers(name, policy):
    metrics = foosball_rl.evaluate(policy, episodes=40, seed=3)
    assert metrics == FIXTURE[name]
    assert set(metrics) >= {"score_rate", "mean_goal_distance", "mean_return", "end_reasons"}


def test_an_onnx_file_needs_onnxruntime_or_plays_as_its_callable(tmp_path):
    ort = pytest.importorskip("onnxruntime")
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper

    # action = sign-like: the first eight observation values after index 2, through Sign.
    graph = helper.make_graph(
        [
            helper.make_node("Slice", ["observation", "starts", "ends", "axes"], ["part"]),
            helper.make_node("Sign", ["part"], ["signed"]),
            helper.make_node("Clip", ["signed", "lo", "hi"], ["action"]),
        ],
        "sign",
        [helper.make_tensor_value_info("observation", TensorProto.FLOAT, ["batch", 38])],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, ["batch", 8])],
        [
            helper.make_tensor("starts", TensorProto.INT64, [1], [2]),
            helper.make_tensor("ends", TensorProto.INT64, [1], [10]),
            helper.make_tensor("axes", TensorProto.INT64, [1], [1]),
            helper.make_tensor("lo", TensorProto.FLOAT, [], [-1.0]),
            helper.make_tensor("hi", TensorProto.FLOAT, [], [1.0]),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    path = tmp_path / "sign.onnx"
    onnx.save(model, str(path))
    assert ort is not None
    # Sign gives 0 where a value is exactly 0; the callable below does the same.
    same = foosball_rl.evaluate(lambda obs: np.sign(obs[:, 2:10]), episodes=10, seed=5)
    assert foosball_rl.evaluate(path, episodes=10, seed=5) == same


def test_bad_policies_are_refused():
    with pytest.raises(ValueError, match=r"shape \(10, 7\)|\[10, 7\]"):
        foosball_rl.evaluate(lambda obs: np.zeros((len(obs), 7)), episodes=10)
    with pytest.raises(foosball_rl.ActionError):
        foosball_rl.evaluate(lambda obs: np.full((len(obs), 8), np.nan), episodes=3)
    with pytest.raises(ZeroDivisionError):
        foosball_rl.evaluate(lambda obs: 1 / 0, episodes=3)
    with pytest.raises(TypeError, match="callable or the path"):
        foosball_rl.evaluate(42)
    with pytest.raises(foosball_rl.ConfigError):
        foosball_rl.evaluate(zero, episodes=3, preset="no_such_table")
