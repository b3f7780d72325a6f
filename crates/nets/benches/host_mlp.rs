//! The host MLP path (`foosball_nets::host_mlp`) beside Burn's autodiff on the default
//! CPU backend, batch 256 at foosball's sizes (38-dim observations, 8-dim actions):
//! - one forward and backward pass (parameter gradients) of a Q-network (46 in, 1 out)
//!   and of SAC's actor (38 in, 16 out: mean and log-std), each way;
//! - the network work of one SAC gradient step on the host path: the actor on `s'`, the
//!   twin target critics on `(s', a')`, the twin critics on `(s, a)` forward and back with
//!   their Adam steps, the actor on `s`, the twin critics on `(s, a~)` walked back to `a~`
//!   only, the actor back with its Adam step, and the target critics' Polyak update. The
//!   losses' own element-wise math (a few passes over `[256, 8]`) is reduced to what
//!   links these passes, so this is a floor under a host-path SAC update, to read beside
//!   `update_speed`'s `sac_update_ms_*` (Burn's whole update) from the same machine.
//!
//! `cargo bench -p foosball-nets --bench host_mlp` (one thread: the host path runs on
//! one, and Burn is held to one with `RAYON_NUM_THREADS=1`); the figures also go to
//! `target/bench/host_mlp.json` (`burn_q_ms_64x64`, `host_q_ms_64x64`, `burn_actor_ms_*`,
//! `host_actor_ms_*`, `host_sac_networks_ms_*`).

use foosball_nets::host::lerp_into;
use foosball_nets::{
    Activation, Adam, AdamConfig, Backend, HostMlp, Mlp, MlpTape, Tensor, TensorData,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[path = "../../../benches/figures.rs"]
mod figures;
#[path = "../../../benches/timing.rs"]
mod timing;
use timing::time_ms;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const BATCH: usize = 256;
const OBS: usize = 38;
const ACT: usize = 8;

fn random(n: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-1.0..1.0)).collect()
}

/// `[s, a]` rows: `obs` `[BATCH, OBS]` beside `actions` `[BATCH, ACT]`.
fn join(out: &mut Vec<f32>, obs: &[f32], actions: &[f32]) {
    out.clear();
    for (s, a) in obs.chunks_exact(OBS).zip(actions.chunks_exact(ACT)) {
        out.extend_from_slice(s);
        out.extend_from_slice(a);
    }
}

/// `tanh` of the mean half of each actor output row (`[BATCH, 2 ACT]` -> `[BATCH, ACT]`).
fn squash(out: &mut Vec<f32>, actor_out: &[f32]) {
    out.clear();
    for row in actor_out.chunks_exact(2 * ACT) {
        out.extend(row[..ACT].iter().map(|m| m.tanh()));
    }
}

/// SAC's five networks on the host path with their buffers.
struct HostSac {
    actor: HostMlp,
    critics: [HostMlp; 2],
    targets: [HostMlp; 2],
    actor_adam: Adam,
    critic_adams: [Adam; 2],
    tapes: [MlpTape; 3],
    actor_grads: Vec<f32>,
    critic_grads: [Vec<f32>; 2],
    rows: Vec<f32>,
    actions: Vec<f32>,
    dy: Vec<f32>,
    d_rows: Vec<f32>,
    d_actor: Vec<f32>,
}

impl HostSac {
    fn new(hidden: usize, rng: &mut ChaCha8Rng) -> Self {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let mut net = |input, output| {
            let mlp = Mlp::new(
                input,
                &[hidden, hidden],
                output,
                Activation::Relu,
                rng,
                &device,
            );
            HostMlp::from_mlp(&mlp).expect("a plain MLP")
        };
        let actor = net(OBS, 2 * ACT);
        let critics = [net(OBS + ACT, 1), net(OBS + ACT, 1)];
        let adam = || Adam::new(AdamConfig::default());
        Self {
            actor_grads: vec![0.0; actor.params().len()],
            critic_grads: critics.clone().map(|c| vec![0.0; c.params().len()]),
            targets: critics.clone(),
            actor,
            critics,
            actor_adam: adam(),
            critic_adams: [adam(), adam()],
            tapes: Default::default(),
            rows: Vec::new(),
            actions: Vec::new(),
            dy: vec![0.0; BATCH],
            d_rows: vec![0.0; BATCH * (OBS + ACT)],
            d_actor: vec![0.0; BATCH * 2 * ACT],
        }
    }

    fn step(&mut self, obs: &[f32], actions: &[f32], next_obs: &[f32]) {
        let n = BATCH as f32;
        let [tape_a, tape_q1, tape_q2] = &mut self.tapes;
        // Targets: a' from the actor on s', min of the target critics on (s', a').
        squash(&mut self.actions, self.actor.forward(next_obs, tape_a));
        join(&mut self.rows, next_obs, &self.actions);
        let y: Vec<f32> = {
            let q1 = self.targets[0].forward(&self.rows, tape_q1);
            let q2 = self.targets[1].forward(&self.rows, tape_q2);
            q1.iter().zip(q2).map(|(a, b)| 0.99 * a.min(*b)).collect()
        };
        // Critics on (s, a): dL/dq = (q - y) / n, back and one Adam step each.
        join(&mut self.rows, obs, actions);
        for (k, tape) in [tape_q1, tape_q2].into_iter().enumerate() {
            let q = self.critics[k].forward(&self.rows, tape);
            for ((d, q), y) in self.dy.iter_mut().zip(q).zip(&y) {
                *d = (q - y) / n;
            }
            self.critic_grads[k].fill(0.0);
            self.critics[k].backward(tape, &self.dy, Some(&mut self.critic_grads[k]), None);
            let grads = &self.critic_grads[k];
            self.critic_adams[k].step_flat(&mut [self.critics[k].params_mut()], grads, 3e-4);
        }
        // Actor: a~ on s, the first critic walked back to a~ (dL/dq = -1/n), then the actor.
        let [tape_a, tape_q1, _] = &mut self.tapes;
        squash(&mut self.actions, self.actor.forward(obs, tape_a));
        join(&mut self.rows, obs, &self.actions);
        self.critics[0].forward(&self.rows, tape_q1);
        self.dy.fill(-1.0 / n);
        self.critics[0].backward(tape_q1, &self.dy, None, Some(&mut self.d_rows));
        for ((d, d_row), a) in self
            .d_actor
            .chunks_exact_mut(2 * ACT)
            .zip(self.d_rows.chunks_exact(OBS + ACT))
            .zip(self.actions.chunks_exact(ACT))
        {
            for k in 0..ACT {
                d[k] = d_row[OBS + k] * (1.0 - a[k] * a[k]);
            }
        }
        self.actor_grads.fill(0.0);
        self.actor
            .backward(tape_a, &self.d_actor, Some(&mut self.actor_grads), None);
        self.actor_adam
            .step_flat(&mut [self.actor.params_mut()], &self.actor_grads, 3e-4);
        for (target, online) in self.targets.iter_mut().zip(&self.critics) {
            lerp_into(target.params_mut(), online.params(), 0.005);
        }
    }
}

fn main() {
    let device = Backend::default_cpu().unwrap().device().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut figures = Vec::new();
    for hidden in [64, 256] {
        let size = format!("{hidden}x{hidden}");
        for (name, input, output) in [("q", OBS + ACT, 1), ("actor", OBS, 2 * ACT)] {
            let mlp = Mlp::new(
                input,
                &[hidden, hidden],
                output,
                Activation::Relu,
                &mut rng,
                &device,
            );
            let x = random(BATCH * input, &mut rng);
            let x_t = Tensor::<2>::from_data(TensorData::new(x.clone(), [BATCH, input]), &device);
            let t_burn = time_ms(|| drop(mlp.forward(x_t.clone()).sum().backward()));
            let host = HostMlp::from_mlp(&mlp).expect("a plain MLP");
            let (mut tape, dy) = (MlpTape::default(), vec![1.0; BATCH * output]);
            let mut grads = vec![0.0; host.params().len()];
            let t_host = time_ms(|| {
                host.forward(&x, &mut tape);
                grads.fill(0.0);
                host.backward(&mut tape, &dy, Some(&mut grads), None);
            });
            println!(
                "{name} {size}, forward + backward: Burn {t_burn:.3} ms, host {t_host:.3} ms ({:.1}x)",
                t_burn / t_host
            );
            figures.push((format!("burn_{name}_ms_{size}"), t_burn));
            figures.push((format!("host_{name}_ms_{size}"), t_host));
        }
        let mut sac = HostSac::new(hidden, &mut rng);
        let (obs, actions, next_obs) = (
            random(BATCH * OBS, &mut rng),
            random(BATCH * ACT, &mut rng),
            random(BATCH * OBS, &mut rng),
        );
        let t_sac = time_ms(|| sac.step(&obs, &actions, &next_obs));
        println!("SAC's network work of one step on the host path, {size}: {t_sac:.3} ms");
        figures.push((format!("host_sac_networks_ms_{size}"), t_sac));
    }
    let path = figures::write_figures("host_mlp", &figures);
    println!("figures in {}", path.display());
}
