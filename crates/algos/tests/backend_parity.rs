//! The GPU path computes what the CPU path computes: one SAC, TD3 and PPO update on
//! wgpu, and on wgpu pinned to Vulkan/SPIR-V when built with `--features vulkan`
//! (lavapipe, Mesa's software Vulkan driver, in CI; a real GPU where there is one)
//! against the same update on flex, from the same seed and the same transitions.
//!
//! Compared: the update's losses (they use the pre-update networks, so they differ by
//! float rounding only) and the deterministic actions on held-out observations after the
//! update. Kernels sum in a different order on each backend, so parity is to a tolerance,
//! not bit-for-bit; the tolerances below are ~10x the largest gap measured on lavapipe
//! and on an H100 (README, "GPU backends"), and each test also checks that the update moved
//! the actions by much more than the tolerance, so a backend that skipped it would fail.
//!
//! The same GPU path waits for the device only where it must: an off-policy update reads
//! nothing back (losses, norms, the temperature and the optimiser's clipping and
//! non-finite guard stay on the device) and a log window's metrics come back in one read;
//! a PPO update (all its epochs and minibatches) reads once, for the bootstrap values, and
//! once more per minibatch only when `target_kl` must compare the KL estimate (SB3's early
//! stop). Reads are counted by `foosball_nets::host::reads`.
//!
//! `cargo test -p foosball-algos --release --features vulkan --test backend_parity`

use foosball_algos::agent::{ActMode, Agent, Experience, Metrics};
use foosball_algos::{
    LrSchedule, NetConfig, OffPolicyConfig, Ppo, PpoConfig, Sac, SacConfig, Td3, Td3Config,
};
use foosball_nets::host::reads;
use foosball_nets::{Backend, Device};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const OBS: usize = 38;
const ACT: usize = 8;
const BATCH: usize = 64;
const HIDDEN: [usize; 2] = [32, 32];
/// Relative gap allowed between the backends' losses.
const LOSS_TOLERANCE: f64 = 1e-5;
/// Absolute gap allowed between the backends' post-update actions (actions lie in [-1, 1]).
const ACTION_TOLERANCE: f32 = 1e-5;

/// The CPU device and each GPU backend compiled in (wgpu always: this test needs
/// `--features wgpu`) with its device.
fn devices() -> (Device, Vec<(Backend, Device)>) {
    let gpus = [Backend::Wgpu, Backend::Vulkan]
        .into_iter()
        .filter(|b| b.is_compiled())
        .map(|b| (b, b.device().expect("a compiled-in backend has a device")))
        .collect::<Vec<_>>();
    assert!(!gpus.is_empty(), "this test needs --features wgpu");
    (Backend::Flex.device().expect("flex is compiled in"), gpus)
}

/// Feeds `n` transitions whose observations and rewards come from `seed`; actions are the
/// agent's own exploring actions.
fn feed(agent: &mut dyn Agent, n: usize, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut obs: Vec<f32> = (0..OBS).map(|_| rng.random_range(-1.0..1.0)).collect();
    for _ in 0..n {
        let actions = agent.act(&obs, ActMode::Explore);
        let next: Vec<f32> = (0..OBS).map(|_| rng.random_range(-1.0..1.0)).collect();
        agent.observe(&Experience {
            obs: &obs,
            actions: &actions,
            rewards: &[rng.random_range(-1.0..1.0)],
            next_obs: &next,
            final_obs: vec![None],
            terminated: &[rng.random_bool(0.05)],
            truncated: &[false],
            absorbing: vec![false],
            teacher: None,
        });
        obs = next;
    }
}

/// Deterministic actions on 16 held-out observations, flattened.
fn probe(agent: &mut dyn Agent) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    (0..16)
        .flat_map(|_| {
            let obs: Vec<f32> = (0..OBS).map(|_| rng.random_range(-1.0..1.0)).collect();
            agent.act(&obs, ActMode::Deterministic)
        })
        .collect()
}

/// Small networks with a large step size, so that one update visibly moves the actions;
/// replay batches of [`BATCH`] rows from the first [`BATCH`] transitions on.
fn shrink(net: &mut NetConfig, off_policy: Option<&mut OffPolicyConfig>) {
    net.hidden = HIDDEN.to_vec();
    net.lr = LrSchedule::Constant(1e-2);
    if let Some(o) = off_policy {
        o.batch_size = BATCH;
        o.learning_starts = BATCH as u64;
    }
}

fn max_gap(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// Runs `updates` updates on both agents after feeding them `n` transitions, and checks
/// losses and post-update actions against the tolerances.
fn check(name: &str, cpu: &mut dyn Agent, gpu: &mut dyn Agent, n: usize, updates: usize) {
    let before = probe(cpu);
    feed(cpu, n, 7);
    feed(gpu, n, 7);
    for step in 0..updates {
        if step > 0 {
            // One env step per gradient step (train_freq 1) for the off-policy learners.
            feed(cpu, 1, 100 + step as u64);
            feed(gpu, 1, 100 + step as u64);
        }
        let (Some(a), Some(b)) = (cpu.update(1.0), gpu.update(1.0)) else {
            panic!("{name}: update {step} did not run");
        };
        let (a, b): (Vec<_>, Vec<_>) = (a.read(), b.read());
        for ((key, x), (_, y)) in a.iter().zip(&b) {
            if x.is_nan() && y.is_nan() {
                continue; // TD3's actor loss before its first delayed step
            }
            let gap = (x - y).abs() / x.abs().max(1e-3);
            println!("{name} update {step} {key}: flex {x:.6} gpu {y:.6} (relative gap {gap:.2e})");
            assert!(
                gap <= LOSS_TOLERANCE,
                "{name} {key}: flex {x}, gpu {y}, relative gap {gap:.2e} > {LOSS_TOLERANCE:e}"
            );
        }
    }
    let (after_cpu, after_gpu) = (probe(cpu), probe(gpu));
    let gap = max_gap(&after_cpu, &after_gpu);
    let moved = max_gap(&before, &after_cpu);
    println!("{name}: post-update actions gap {gap:.2e}, the update moved them by {moved:.2e}");
    assert!(
        gap <= ACTION_TOLERANCE,
        "{name}: actions differ by {gap:.2e} > {ACTION_TOLERANCE:e}"
    );
    assert!(
        moved >= 10.0 * ACTION_TOLERANCE,
        "{name}: the update moved the actions by {moved:.2e} only, too little to compare"
    );
}

#[test]
fn sac_update_matches_cpu() {
    let mut config = SacConfig::default();
    shrink(&mut config.net, Some(&mut config.off_policy));
    let (cpu, gpus) = devices();
    for (backend, gpu) in gpus {
        check(
            &format!("SAC on {backend}"),
            &mut Sac::agent(OBS, ACT, config.clone(), 3, &cpu),
            &mut Sac::agent(OBS, ACT, config.clone(), 3, &gpu),
            BATCH + 1,
            2,
        );
    }
}

#[test]
fn td3_update_matches_cpu() {
    let mut config = Td3Config::default();
    shrink(&mut config.net, Some(&mut config.off_policy));
    let (cpu, gpus) = devices();
    for (backend, gpu) in gpus {
        // Two updates: TD3 moves its actor on every second one.
        check(
            &format!("TD3 on {backend}"),
            &mut Td3::agent(OBS, ACT, config.clone(), 3, &cpu),
            &mut Td3::agent(OBS, ACT, config.clone(), 3, &gpu),
            BATCH + 1,
            2,
        );
    }
}

#[test]
fn ppo_update_matches_cpu() {
    let mut config = PpoConfig {
        n_steps: BATCH,
        batch_size: BATCH / 2,
        n_epochs: 1,
        ..PpoConfig::default()
    };
    shrink(&mut config.net, None);
    let (cpu, gpus) = devices();
    for (backend, gpu) in gpus {
        check(
            &format!("PPO on {backend}"),
            &mut Ppo::new(OBS, ACT, config.clone(), 3, &cpu),
            &mut Ppo::new(OBS, ACT, config.clone(), 3, &gpu),
            BATCH,
            1,
        );
    }
}

/// Host reads made by `f` on this thread.
fn reads_in<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let before = reads();
    let out = f();
    (out, reads() - before)
}

/// `window` off-policy updates (feeding one transition before each, outside the count)
/// read nothing from the device; their metrics then come back in one read, all finite.
fn check_window(name: &str, agent: &mut dyn Agent, window: usize) {
    feed(agent, BATCH, 7);
    let mut rounds = Vec::new();
    for step in 0..window {
        feed(agent, 1, 100 + step as u64);
        let (metrics, n) = reads_in(|| agent.update(1.0));
        rounds.push(metrics.expect("an update ran"));
        assert_eq!(n, 0, "{name}: update {step} read the device {n} times");
    }
    let (values, n) = reads_in(|| Metrics::mean(rounds).read());
    assert_eq!(n, 1, "{name}: the window's metrics took {n} reads");
    // TD3's actor loss is NaN until its first delayed step, so the window's mean is too.
    assert!(
        values
            .iter()
            .all(|(key, v)| v.is_finite() || *key == "actor_loss"),
        "{name}: {values:?}"
    );
}

#[test]
fn off_policy_updates_read_nothing_back_until_the_log_window_ends() {
    let mut sac = SacConfig::default();
    shrink(&mut sac.net, Some(&mut sac.off_policy));
    let mut td3 = Td3Config::default();
    shrink(&mut td3.net, Some(&mut td3.off_policy));
    for (backend, gpu) in devices().1 {
        let sac_agent = &mut Sac::agent(OBS, ACT, sac.clone(), 3, &gpu);
        check_window(&format!("SAC on {backend}"), sac_agent, 6);
        let td3_agent = &mut Td3::agent(OBS, ACT, td3.clone(), 3, &gpu);
        check_window(&format!("TD3 on {backend}"), td3_agent, 6);
    }
}

#[test]
fn a_ppo_update_reads_once_for_its_bootstrap_and_per_minibatch_only_with_target_kl() {
    let config = |target_kl| {
        let mut config = PpoConfig {
            n_steps: BATCH,
            batch_size: BATCH / 4,
            n_epochs: 2,
            target_kl,
            ..PpoConfig::default()
        };
        shrink(&mut config.net, None);
        config
    };
    let minibatches = 2 * 4;
    // A target the KL estimate never reaches here, so every minibatch runs and reads it.
    for (target_kl, reads) in [(None, 1), (Some(1e3), minibatches + 1)] {
        for (backend, gpu) in devices().1 {
            let agent = &mut Ppo::new(OBS, ACT, config(target_kl), 3, &gpu);
            feed(agent, BATCH, 7);
            let (metrics, n) = reads_in(|| agent.update(1.0));
            assert_eq!(n, reads, "PPO on {backend}, target_kl {target_kl:?}");
            let (values, n) = reads_in(|| metrics.expect("an update ran").read());
            assert_eq!(n, 1, "PPO on {backend}");
            assert!(values.iter().all(|(_, v)| v.is_finite()), "{values:?}");
        }
    }
}
