//! Time per gradient update of SAC, TD3 and PPO (batch 256, foosball sizes: 38-dim
//! observations, 8-dim actions), and where the time of one 7x3000 update goes.
//!
//! `cargo bench -p foosball-algos --bench update_speed -- [--sizes 256x2,3000x7] [--reps N]`
//! (`RAYON_NUM_THREADS` sets the thread count).

use burn::module::Module;
use foosball_algos::agent::{ActMode, Agent, Experience};
use foosball_algos::{Ppo, PpoConfig, Sac, SacConfig, Td3, Td3Config};
use foosball_nets::params::polyak_update;
use foosball_nets::{Activation, Adam, AdamConfig, Backend, Device, Mlp, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// Large tensors are freed and allocated every step; glibc returns blocks above 32 MiB
/// to the OS and page-faults them back in each time, which costs more than Adam.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const OBS: usize = 38;
const ACT: usize = 8;
const BATCH: usize = 256;

fn random(n: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-1.0..1.0)).collect()
}

/// Feeds `n` random single-env transitions.
fn feed(agent: &mut dyn Agent, n: usize, rng: &mut ChaCha8Rng) {
    for _ in 0..n {
        let obs = random(OBS, rng);
        let actions = agent.act(&obs, ActMode::Explore);
        let next = random(OBS, rng);
        agent.observe(&Experience {
            obs: &obs,
            actions: &actions,
            rewards: &[rng.random_range(-1.0..1.0)],
            next_obs: &next,
            final_obs: vec![None],
            terminated: &[false],
            truncated: &[false],
        });
    }
}

/// Median seconds of `reps` calls of `f` after one warm-up call.
fn median(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut times: Vec<f64> = (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn off_policy_update(agent: &mut dyn Agent, reps: usize, rng: &mut ChaCha8Rng) -> f64 {
    feed(agent, BATCH + 1, rng);
    median(reps, || {
        feed(agent, 1, rng);
        assert!(agent.update(1.0).is_some());
    })
}

fn bench_size(hidden: &[usize], reps: usize, device: &Device) {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let label = format!("{}x{}", hidden[0], hidden.len());

    let mut sac = SacConfig::default();
    sac.net.hidden = hidden.to_vec();
    sac.net.adam.max_grad_norm = Some(10.0);
    sac.off_policy.learning_starts = BATCH as u64;
    sac.off_policy.buffer_size = 10_000;
    let t = off_policy_update(&mut Sac::agent(OBS, ACT, sac, 1, device), reps, &mut rng);
    println!("{label:>8}  SAC update  {:>9.1} ms", t * 1e3);

    let mut td3 = Td3Config::default();
    td3.net.hidden = hidden.to_vec();
    td3.net.adam.max_grad_norm = Some(10.0);
    td3.off_policy.learning_starts = BATCH as u64;
    td3.off_policy.buffer_size = 10_000;
    // Two consecutive calls: one critic-only step and one delayed actor + target step.
    let mut agent = Td3::agent(OBS, ACT, td3, 1, device);
    let t = off_policy_update(&mut agent, reps, &mut rng);
    println!(
        "{label:>8}  TD3 update  {:>9.1} ms (mean of critic-only and delayed steps: median of both)",
        t * 1e3
    );

    let mut ppo = PpoConfig {
        n_steps: BATCH,
        batch_size: BATCH,
        n_epochs: 1,
        ..PpoConfig::default()
    };
    ppo.net.hidden = hidden.to_vec();
    ppo.net.activation = Activation::Relu;
    let mut agent = Ppo::new(OBS, ACT, ppo, 1, device);
    let t = median(reps, || {
        feed(&mut agent, BATCH, &mut rng);
        assert!(agent.update(1.0).is_some());
    });
    // The rollout's forward passes (act) are inside `feed`; time them apart.
    let act = median(reps, || {
        let obs = random(OBS, &mut rng);
        agent.act(&obs, ActMode::Deterministic);
    });
    println!(
        "{label:>8}  PPO rollout of {BATCH} + 1 gradient step {:>9.1} ms (single-obs act {:.2} ms)",
        t * 1e3,
        act * 1e3
    );
}

/// Forward+backward, Adam and polyak of one MLP, timed apart.
fn breakdown(hidden: &[usize], reps: usize, device: &Device) {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let label = format!("{}x{}", hidden[0], hidden.len());
    let mut net = Mlp::new(OBS + ACT, hidden, 1, Activation::Relu, &mut rng, device);
    let x = Tensor::<2>::from_data(
        TensorData::new(random(BATCH * (OBS + ACT), &mut rng), [BATCH, OBS + ACT]),
        device,
    );
    let mut adam = Adam::new(AdamConfig::default());
    let mut grads = None;
    let fb = median(reps, || {
        let loss = net.forward(x.clone()).square().mean();
        let g = loss.backward();
        grads = Some(g);
    });
    let step = median(reps, || {
        let mut g = net.forward(x.clone()).square().mean().backward();
        adam.step_in_place(&mut net, &mut g, 1e-4);
    }) - fb;
    let mut target = net.clone().no_grad();
    let polyak = median(reps, || polyak_update(&mut target, &net, 0.005));
    println!(
        "{label:>8}  one Q-net ({} params): forward+backward {:.1} ms, Adam {:.1} ms, polyak {:.1} ms",
        net.num_params(),
        fb * 1e3,
        step * 1e3,
        polyak * 1e3
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .map(|i| args[i + 1].clone())
    };
    let sizes = value("--sizes").unwrap_or_else(|| "256x2,3000x7".into());
    let reps: usize = value("--reps").map_or(3, |r| r.parse().expect("--reps N"));
    let backend =
        value("--backend").map_or_else(|| Backend::default_cpu().unwrap(), |b| b.parse().unwrap());
    let device = backend.device().unwrap();
    println!(
        "backend {backend}, {} rayon threads, batch {BATCH}",
        rayon_threads()
    );
    for size in sizes.split(',') {
        let (width, depth) = size.split_once('x').expect("--sizes WIDTHxDEPTH,...");
        let hidden = vec![width.parse::<usize>().unwrap(); depth.parse().unwrap()];
        let reps = if hidden[0] >= 1000 { reps } else { reps * 20 };
        breakdown(&hidden, reps, &device);
        bench_size(&hidden, reps, &device);
    }
}

fn rayon_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}
