//! Time per gradient update of SAC, TD3 and PPO (batch 256, foosball sizes: 38-dim
//! observations, 8-dim actions), and where the time of one 7x3000 update goes.
//!
//! `cargo bench -p foosball-algos --bench update_speed -- [--sizes 64x2,256x2,3000x7] [--reps N]
//! [--algos sac,td3,ppo]`
//! (`RAYON_NUM_THREADS` sets the thread count). The figures also go to
//! `target/bench/update_speed.json` (`sac_update_ms_64x64`, ..., `sac_update_ms_7x3000`);
//! `--backend wgpu` (built with `--features wgpu`) times the GPU path and writes
//! `target/bench/update_speed_wgpu.json`; `--backend flex,host` times the host MLP path
//! (SAC) beside flex in one run (`target/bench/update_speed_flex,host.json`, the host
//! figures' keys ending in `_host`).

use burn::module::Module;
use foosball_algos::agent::{ActMode, Agent, Experience};
use foosball_algos::{NetConfig, OffPolicyConfig, Ppo, PpoConfig, Sac, SacConfig, Td3, Td3Config};
use foosball_nets::params::polyak_update;
use foosball_nets::{Activation, Adam, AdamConfig, Backend, Device, Mlp, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

#[path = "../../../benches/args.rs"]
mod args;
#[path = "../../../benches/figures.rs"]
mod figures;

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
            absorbing: vec![false],
            teacher: None,
        });
    }
}

/// Median of `reps` samples after one warm-up; each sample runs `prepare` untimed, then
/// times `work`. The device is synchronised after `prepare` and before the clock stops,
/// so on a GPU the time is that of the work's kernels, not of their queueing.
fn median<T>(
    reps: usize,
    device: &Device,
    mut prepare: impl FnMut() -> T,
    mut work: impl FnMut(T),
) -> f64 {
    let sync = || device.sync().expect("the device ran the work");
    work(prepare());
    let mut times: Vec<f64> = (0..reps)
        .map(|_| {
            let input = prepare();
            sync();
            let t = Instant::now();
            work(input);
            sync();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Seconds per gradient step, timed over `per_sample` consecutive updates (TD3 alternates
/// critic-only and delayed actor steps, so it is timed in pairs).
fn off_policy_update(
    agent: &mut dyn Agent,
    reps: usize,
    per_sample: usize,
    rng: &mut ChaCha8Rng,
    device: &Device,
) -> f64 {
    feed(agent, BATCH + 1, rng);
    let cell = std::cell::RefCell::new((agent, rng));
    median(
        reps,
        device,
        || (),
        |()| {
            let (agent, rng) = &mut *cell.borrow_mut();
            for _ in 0..per_sample {
                feed(*agent, 1, rng);
                assert!(agent.update(1.0).is_some());
            }
        },
    ) / per_sample as f64
}

/// A network size in figure names: the widths joined (`64x64`) up to three layers, else
/// depth x width (`7x3000`).
fn size_key(hidden: &[usize]) -> String {
    if hidden.len() <= 3 {
        hidden
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("x")
    } else {
        format!("{}x{}", hidden.len(), hidden[0])
    }
}

/// An off-policy learner's settings for the bench: `hidden` networks, clipped gradients,
/// updates from the first full batch on, a small buffer.
fn bench_settings(net: &mut NetConfig, schedule: &mut OffPolicyConfig, hidden: &[usize]) {
    net.hidden = hidden.to_vec();
    net.adam.max_grad_norm = Some(10.0);
    schedule.learning_starts = BATCH as u64;
    schedule.buffer_size = 10_000;
}

/// Times SAC, TD3 and PPO updates (and PPO's act) at `hidden` on `backend`; returns the
/// figures.
fn bench_size(hidden: &[usize], algos: &str, reps: usize, backend: Backend) -> Vec<(String, f64)> {
    let device = &backend.device().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let host = backend == Backend::Host;
    let label = format!(
        "{}x{}{}",
        hidden[0],
        hidden.len(),
        if host { " host" } else { "" }
    );
    let key = format!("{}{}", size_key(hidden), if host { "_host" } else { "" });
    let mut out = Vec::new();

    let wanted = |algo: &str| algos.split(',').any(|a| a == algo);
    if wanted("sac") {
        let mut sac = SacConfig::default();
        bench_settings(&mut sac.net, &mut sac.off_policy, hidden);
        let mut agent = Sac::agent(OBS, ACT, sac, 1, device);
        if host {
            agent.learner_mut().on_host_path().unwrap();
        }
        let t = off_policy_update(&mut agent, reps, 1, &mut rng, device);
        println!("{label:>8}  SAC update  {:>9.2} ms", t * 1e3);
        out.push((format!("sac_update_ms_{key}"), t * 1e3));
    }
    if wanted("td3") {
        let mut td3 = Td3Config::default();
        bench_settings(&mut td3.net, &mut td3.off_policy, hidden);
        let mut agent = Td3::agent(OBS, ACT, td3, 1, device);
        if host {
            agent.learner_mut().on_host_path().unwrap();
        }
        let t = off_policy_update(&mut agent, reps, 2, &mut rng, device);
        println!(
            "{label:>8}  TD3 update  {:>9.2} ms (mean over a critic-only and a delayed step)",
            t * 1e3
        );
        out.push((format!("td3_update_ms_{key}"), t * 1e3));
    }
    if !wanted("ppo") {
        return out;
    }

    let mut ppo = PpoConfig {
        n_steps: BATCH,
        batch_size: BATCH,
        n_epochs: 1,
        ..PpoConfig::default()
    };
    ppo.net.hidden = hidden.to_vec();
    ppo.net.activation = Activation::Relu;
    let mut agent = Ppo::new(OBS, ACT, ppo, 1, device);
    if host {
        agent.on_host_path().unwrap();
    }
    let agent = std::cell::RefCell::new(agent);
    let t = median(
        reps,
        device,
        || feed(&mut *agent.borrow_mut(), BATCH, &mut rng),
        |()| assert!(agent.borrow_mut().update(1.0).is_some()),
    );
    let mut agent = agent.into_inner();
    let obs = random(OBS, &mut ChaCha8Rng::seed_from_u64(1));
    let act = median(
        reps,
        device,
        || (),
        |()| drop(agent.act(&obs, ActMode::Deterministic)),
    );
    println!(
        "{label:>8}  PPO update  {:>9.2} ms (values of {BATCH} rows, GAE, 1 gradient step); act on 1 obs {:.2} ms",
        t * 1e3,
        act * 1e3
    );
    out.push((format!("ppo_update_ms_{key}"), t * 1e3));
    out.push((format!("ppo_act_ms_{key}"), act * 1e3));
    out
}

/// Forward+backward, Adam and polyak of one MLP, timed apart.
fn breakdown(hidden: &[usize], reps: usize, device: &Device) {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let label = format!("{}x{}", hidden[0], hidden.len());
    let net = Mlp::new(OBS + ACT, hidden, 1, Activation::Relu, &mut rng, device);
    let x = Tensor::<2>::from_data(
        TensorData::new(random(BATCH * (OBS + ACT), &mut rng), [BATCH, OBS + ACT]),
        device,
    );
    let loss = |net: &Mlp| net.forward(x.clone()).square().mean();
    let fb = median(reps, device, || (), |()| drop(loss(&net).backward()));
    let mut adam = Adam::new(AdamConfig::default());
    let net = std::cell::RefCell::new(net);
    let step = median(
        reps,
        device,
        || loss(&net.borrow()).backward(),
        |mut g| {
            adam.step_in_place(&mut *net.borrow_mut(), &mut g, 1e-4);
        },
    );
    let net = net.into_inner();
    let mut target = net.clone().no_grad();
    let polyak = median(
        reps,
        device,
        || (),
        |()| polyak_update(&mut target, &net, 0.005),
    );
    println!(
        "{label:>8}  one Q-net ({} params): forward+backward {:.1} ms, Adam {:.1} ms, polyak {:.1} ms",
        net.num_params(),
        fb * 1e3,
        step * 1e3,
        polyak * 1e3
    );
}

fn main() {
    let sizes = args::flag("--sizes").unwrap_or_else(|| "64x2,256x2,3000x7".into());
    let algos = args::flag("--algos").unwrap_or_else(|| "sac,td3,ppo".into());
    let reps: usize = args::flag("--reps").map_or(3, |r| r.parse().expect("--reps N"));
    let default = Backend::default_cpu().unwrap().to_string();
    let backend_list = args::flag("--backend").unwrap_or(default.clone());
    let backends: Vec<Backend> = backend_list
        .split(',')
        .map(|b| b.parse().unwrap())
        .collect();
    println!(
        "backends {backend_list}, {} rayon threads, batch {BATCH}",
        rayon_threads()
    );
    let mut figures = Vec::new();
    for size in sizes.split(',') {
        let (width, depth) = size.split_once('x').expect("--sizes WIDTHxDEPTH,...");
        let hidden = vec![width.parse::<usize>().unwrap(); depth.parse().unwrap()];
        let reps = if hidden[0] >= 1000 { reps } else { reps * 20 };
        for &backend in &backends {
            if backend != Backend::Host {
                breakdown(&hidden, reps, &backend.device().unwrap());
            }
            figures.extend(bench_size(&hidden, &algos, reps, backend));
        }
    }
    let bench = if backend_list == default {
        "update_speed".to_string()
    } else {
        format!("update_speed_{backend_list}")
    };
    let path = figures::write_figures(&bench, &figures);
    println!("figures in {}", path.display());
}

fn rayon_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}
