"""Issue 92's offline check of the pixel student's task: can a CNN fit a state teacher's
labels from the pictures at all? Plays `steps` steps on two tables of the teacher's run
configuration in lockstep (one observing the state, one 48 x 96 grey pictures, 3
stacked; the same seeds and actions, so the same game), the actor being the teacher
(`teacher`) or a policy holding every rod at neutral (`zero`), each action with Gaussian
noise of `noise`; labels every step with the teacher's exported policy on the state; then
fits a CNN of `configs/pixels/student-flatten.toml`'s shape (16 8x8/4, 32 4x4/2, 32
3x3/1, 256 features, MLP 128x128) with PyTorch (Adam, batch 256, one thread) on the first
80 % of the steps, printing the squared error summed over the 8 commands (the
`train/kickstart_loss` of a run) on the last 20 %.

A measuring instrument, not part of the project (a throwaway venv with numpy, torch,
onnxruntime and the Python front, `pip install ./crates/py`; the teacher exported first
with `export --run DIR --out teacher.onnx`):

    python tools/pixel_labels_fit.py RUN_DIR teacher.onnx teacher 30000 0.2 2000 1e-3
"""
import sys
import time

import numpy as np
import onnxruntime as ort
import torch
from torch import nn

from foosball_rl import _core

PICTURES = {"observation": {"kind": "image", "width": 48, "height": 96,
                            "grayscale": True, "frame_stack": 3}}


def collect(run_dir, onnx, actor, steps, noise):
    """Pictures (bytes), the teacher's labels and the states of `steps` steps."""
    config = f"{run_dir}/config.toml"
    state, picture = _core.Table(config=config), _core.Table(config=config, overrides=PICTURES)
    session = ort.InferenceSession(onnx)
    name = session.get_inputs()[0].name
    rng = np.random.default_rng(0)
    xs = np.zeros((steps, 3, 96, 48), np.uint8)
    ys = np.zeros((steps, 8), np.float32)
    seed = 100
    s, p = state.reset(seed), picture.reset(seed)
    for k in range(steps):
        label = session.run(None, {name: s[None].astype(np.float32)})[0][0]
        xs[k], ys[k] = np.round(p * 255), label
        own = label if actor == "teacher" else np.zeros(8, np.float32)
        action = np.clip(own + noise * rng.standard_normal(8), -1, 1).astype(np.float32)
        (s, _, end, cut, *_), (p, *_) = state.step(action), picture.step(action)
        if end or cut:
            seed += 1
            s, p = state.reset(seed), picture.reset(seed)
    return xs, ys


def fit(xs, ys, steps, lr):
    """Fits the CNN on the first 80 %, printing the held-out error ten times."""
    torch.set_num_threads(1)
    torch.manual_seed(0)
    x, y = torch.tensor(xs).float() / 255, torch.tensor(ys)
    cut = int(len(y) * 0.8)
    net = nn.Sequential(
        nn.Conv2d(3, 16, 8, 4), nn.ReLU(), nn.Conv2d(16, 32, 4, 2), nn.ReLU(),
        nn.Conv2d(32, 32, 3, 1), nn.ReLU(), nn.Flatten(), nn.LazyLinear(256), nn.ReLU(),
        nn.Linear(256, 128), nn.ReLU(), nn.Linear(128, 128), nn.ReLU(), nn.Linear(128, 8))
    net(x[:2])
    optimiser = torch.optim.Adam(net.parameters(), lr=lr)

    def error(rows):
        return ((net(x[rows]) - y[rows]) ** 2).sum(1).mean()

    start = time.time()
    for step in range(steps + 1):
        loss = error(torch.randint(0, cut, (256,)))
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        if step % max(steps // 10, 1) == 0:
            with torch.no_grad():
                held = error(torch.arange(cut, len(y))).item()
            print(f"step {step}: train {loss.item():.3f}, held out {held:.3f} "
                  f"({time.time() - start:.0f} s)", flush=True)


def main():
    run_dir, onnx, actor, steps, noise, fit_steps, lr = sys.argv[1:8]
    xs, ys = collect(run_dir, onnx, actor, int(steps), float(noise))
    print(f"{steps} steps; the labels' variance summed over the commands "
          f"{ys.var(0).sum():.3f} (a constant's error)")
    fit(xs, ys, int(fit_steps), float(lr))


if __name__ == "__main__":
    main()
