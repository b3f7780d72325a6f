"""One SAC gradient update as Stable-Baselines3 does it, in plain PyTorch, timed on a GPU.

The reference figure for `update_speed` (crates/algos/benches/update_speed.rs): the same
sizes (38-dim observations, 8-dim actions, batch 256, hidden layers WIDTHxDEPTH, ReLU),
the same work per update as SB3's `SAC.train` with `gradient_steps=1`: twin-critic loss
against the target critics and the entropy-regularised next action, one Adam step of
the critics, the actor loss through the critics, one Adam step of the actor, one of the
log-temperature, and the Polyak update of the target critics (tau 0.005). No gradient
clipping (SB3's SAC has none). A measuring instrument, not part of the project:

    python3 tools/torch_sac_update.py [--sizes 64x2,256x2,3000x7] [--reps 20] [--tf32]

Prints one line per size: the median milliseconds of one update, the device synchronised
around each timed update (CUDA events would give the same).
"""

import argparse
import time

import torch
from torch import nn

OBS, ACT, BATCH = 38, 8, 256


def mlp(inp, hidden, out):
    layers, width = [], inp
    for h in hidden:
        layers += [nn.Linear(width, h), nn.ReLU()]
        width = h
    layers.append(nn.Linear(width, out))
    return nn.Sequential(*layers)


class Sac:
    def __init__(self, hidden, device):
        self.actor = mlp(OBS, hidden, 2 * ACT).to(device)
        self.q = nn.ModuleList([mlp(OBS + ACT, hidden, 1) for _ in range(2)]).to(device)
        self.q_target = nn.ModuleList([mlp(OBS + ACT, hidden, 1) for _ in range(2)]).to(device)
        self.q_target.load_state_dict(self.q.state_dict())
        self.log_alpha = torch.zeros(1, device=device, requires_grad=True)
        self.opt_actor = torch.optim.Adam(self.actor.parameters(), lr=3e-4)
        self.opt_q = torch.optim.Adam(self.q.parameters(), lr=3e-4)
        self.opt_alpha = torch.optim.Adam([self.log_alpha], lr=3e-4)

    def sample(self, obs):
        mean, log_std = self.actor(obs).chunk(2, dim=-1)
        log_std = log_std.clamp(-20, 2)
        std = log_std.exp()
        u = mean + std * torch.randn_like(mean)
        a = torch.tanh(u)
        logp = (-0.5 * ((u - mean) / std) ** 2 - log_std - 0.9189385332046727).sum(-1)
        logp = logp - torch.log(1 - a.pow(2) + 1e-6).sum(-1)
        return a, logp

    def update(self, obs, act, rew, next_obs, done):
        a_pi, logp = self.sample(obs)
        alpha_loss = -(self.log_alpha * (logp + (-ACT)).detach()).mean()
        self.opt_alpha.zero_grad()
        alpha_loss.backward()
        self.opt_alpha.step()
        alpha = self.log_alpha.detach().exp()
        with torch.no_grad():
            a_next, logp_next = self.sample(next_obs)
            x = torch.cat([next_obs, a_next], -1)
            q_next = torch.min(self.q_target[0](x), self.q_target[1](x)).squeeze(-1)
            target = rew + 0.99 * (1 - done) * (q_next - alpha * logp_next)
        x = torch.cat([obs, act], -1)
        q_loss = sum(0.5 * ((q(x).squeeze(-1) - target) ** 2).mean() for q in self.q)
        self.opt_q.zero_grad()
        q_loss.backward()
        self.opt_q.step()
        x = torch.cat([obs, a_pi], -1)
        q_pi = torch.min(self.q[0](x), self.q[1](x)).squeeze(-1)
        actor_loss = (alpha * logp - q_pi).mean()
        self.opt_actor.zero_grad()
        actor_loss.backward()
        self.opt_actor.step()
        with torch.no_grad():
            for p, t in zip(self.q.parameters(), self.q_target.parameters()):
                t.mul_(0.995).add_(p, alpha=0.005)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", default="64x2,256x2,3000x7")
    parser.add_argument("--reps", type=int, default=20)
    parser.add_argument("--tf32", action="store_true", help="TF32 matmuls (PyTorch's default is off)")
    args = parser.parse_args()
    torch.backends.cuda.matmul.allow_tf32 = args.tf32
    device = torch.device("cuda" if torch.cuda.is_available() else "cpu")
    sync = torch.cuda.synchronize if device.type == "cuda" else (lambda: None)
    print(f"torch {torch.__version__} on {torch.cuda.get_device_name() if device.type == 'cuda' else 'cpu'}, "
          f"TF32 {'on' if args.tf32 else 'off'}, batch {BATCH}")
    for size in args.sizes.split(","):
        width, depth = (int(v) for v in size.split("x"))
        sac = Sac([width] * depth, device)
        batch = [torch.randn(BATCH, OBS, device=device), torch.rand(BATCH, ACT, device=device) * 2 - 1,
                 torch.randn(BATCH, device=device), torch.randn(BATCH, OBS, device=device),
                 torch.zeros(BATCH, device=device)]
        for _ in range(3):
            sac.update(*batch)
        times = []
        for _ in range(args.reps):
            sync()
            t = time.perf_counter()
            sac.update(*batch)
            sync()
            times.append(time.perf_counter() - t)
        times.sort()
        params = sum(p.numel() for p in sac.q[0].parameters())
        print(f"{width}x{depth}  one Q-net {params} params  SAC update {1e3 * times[len(times) // 2]:.2f} ms")


if __name__ == "__main__":
    main()
