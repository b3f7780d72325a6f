//! The algorithms learn Pendulum-v1 (small networks, fixed seeds, release mode).
//!
//! Thresholds: SAC and TD3 reach a mean deterministic return >= -250 over 10 held-out
//! episodes within 20,000 env steps (RL Zoo reports about -150); PPO improves on its
//! untrained return by >= 500 within 200,000 steps and ends >= -400.
//! `cargo test --release --test suite learning:: -- --nocapture` prints the figures.

use foosball_rl::algos::{
    Agent, Collector, LrSchedule, Ppo, PpoConfig, Sac, SacConfig, Td3, Td3Config, play_episode,
};
use foosball_rl::env::seeding::{EVAL_ENVS, LEARNER, derive_seed};
use foosball_rl::env::{Pendulum, VecEnv};
use foosball_rl::nets::{Backend, Device};

const SEED: u64 = 1;

fn device() -> Device {
    Backend::default_cpu().unwrap().device().unwrap()
}

fn evaluate(agent: &mut dyn Agent) -> f64 {
    let mut env = Pendulum::new();
    let total: f64 = (0..10)
        .map(|k| {
            play_episode(agent, &mut env, derive_seed(SEED, EVAL_ENVS, k))
                .unwrap()
                .ret
        })
        .sum();
    total / 10.0
}

/// Trains for `steps` env steps on `n_envs` Pendulums; returns (before, after) evaluations.
fn train(agent: &mut dyn Agent, n_envs: usize, steps: u64) -> (f64, f64) {
    let before = evaluate(agent);
    let envs = VecEnv::new((0..n_envs).map(|_| Pendulum::new()).collect(), 1).unwrap();
    let mut collector = Collector::new(envs, SEED);
    while agent.env_steps() < steps {
        let progress = 1.0 - agent.env_steps() as f64 / steps as f64;
        collector.step(agent, progress, |_, _, _| {}).unwrap();
    }
    (before, evaluate(agent))
}

#[test]
fn sac_swings_the_pendulum_up_within_20k_steps() {
    let mut config = SacConfig::default();
    config.net.hidden = vec![64, 64];
    config.off_policy.learning_starts = 1000;
    let mut agent = Sac::agent(3, 1, config, derive_seed(SEED, LEARNER, 0), &device());
    let (before, after) = train(&mut agent, 1, 20_000);
    eprintln!("SAC Pendulum: {before:.1} -> {after:.1} after 20k steps");
    assert!(after >= -250.0, "SAC reached {after:.1}");
}

#[test]
fn td3_swings_the_pendulum_up_within_20k_steps() {
    let mut config = Td3Config::default();
    config.net.hidden = vec![64, 64];
    config.off_policy.learning_starts = 1000;
    let mut agent = Td3::agent(3, 1, config, derive_seed(SEED, LEARNER, 0), &device());
    let (before, after) = train(&mut agent, 1, 20_000);
    eprintln!("TD3 Pendulum: {before:.1} -> {after:.1} after 20k steps");
    assert!(after >= -250.0, "TD3 reached {after:.1}");
}

#[test]
fn ppo_improves_by_500_within_200k_steps() {
    // RL Zoo's Pendulum-v1 settings (without gSDE): 4 envs, 1024 steps, gamma 0.9, lr 1e-3.
    let config = PpoConfig {
        n_steps: 1024,
        gamma: 0.9,
        ..PpoConfig::default()
    };
    let config = PpoConfig {
        net: foosball_rl::algos::NetConfig {
            lr: LrSchedule::Constant(1e-3),
            ..config.net.clone()
        },
        ..config
    };
    let mut agent = Ppo::new(3, 1, config, derive_seed(SEED, LEARNER, 0), &device());
    let (before, after) = train(&mut agent, 4, 200_000);
    eprintln!("PPO Pendulum: {before:.1} -> {after:.1} after 200k steps");
    assert!(
        after - before >= 500.0,
        "PPO went from {before:.1} to {after:.1}"
    );
    assert!(after >= -400.0, "PPO reached {after:.1}");
}
