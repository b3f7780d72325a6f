//! An image learner improves: PPO with a small CNN learns the "Block" sub-task (slide the
//! goalie to the ball, seen only as a 36 x 36 grey picture of the table) within 16,384
//! env steps, seed 1, release mode.
//!
//! Threshold: the mean deterministic reward over 50 held-out episodes rises by >= 0.25
//! and ends >= -0.25 (0 is a perfect block; the untrained policy, whose action barely
//! depends on the picture, earns about -0.5, the mean |x| / 10 of a ball at x ~ U(-10,
//! 10) cm). Measured: seed 1 -0.474 -> -0.092, seed 2 -0.503 -> -0.155, seed 3 -0.548 ->
//! -0.135, about 18 s each. `cargo test --release --test suite learning_images:: -- --nocapture`
//! prints the figures.

use foosball_rl::algos::{Agent, Collector, LrSchedule, NetConfig, Ppo, PpoConfig, play_episode};
use foosball_rl::env::VecEnv;
use foosball_rl::env::block::Block;
use foosball_rl::env::seeding::{EVAL_ENVS, derive_seed};
use foosball_rl::nets::{Backend, CnnConfig, ConvLayer, ObsShape};

const SEED: u64 = 1;
const SIDE: usize = 36;

fn evaluate(agent: &mut dyn Agent) -> f64 {
    let mut env = Block::new(SIDE, SIDE);
    let total: f64 = (0..50)
        .map(|k| {
            play_episode(agent, &mut env, derive_seed(SEED, EVAL_ENVS, k))
                .unwrap()
                .ret
        })
        .sum();
    total / 50.0
}

#[test]
fn ppo_with_a_cnn_learns_to_block_from_pixels() {
    let conv = |channels, kernel, stride| ConvLayer {
        channels,
        kernel,
        stride,
    };
    let base = PpoConfig::default();
    let config = PpoConfig {
        n_steps: 256,
        batch_size: 64,
        n_epochs: 4,
        net: NetConfig {
            hidden: vec![32],
            lr: LrSchedule::Constant(1e-3),
            cnn: CnnConfig {
                convs: vec![conv(8, 4, 2), conv(16, 3, 2)],
                features: 32,
                ..CnnConfig::default()
            },
            ..base.net.clone()
        },
        ..base
    };
    let shape = ObsShape::Image {
        channels: 1,
        height: SIDE,
        width: SIDE,
    };
    let device = Backend::default_cpu().unwrap().device().unwrap();
    let mut agent = Ppo::new(shape, 1, config, SEED, &device);
    let before = evaluate(&mut agent);
    let envs = VecEnv::new((0..4).map(|_| Block::new(SIDE, SIDE)).collect(), 1).unwrap();
    let mut collector = Collector::new(envs, SEED);
    let steps = 16_384;
    while agent.env_steps() < steps {
        let progress = 1.0 - agent.env_steps() as f64 / steps as f64;
        collector.step(&mut agent, progress, |_, _, _| {}).unwrap();
    }
    let after = evaluate(&mut agent);
    eprintln!("PPO + CNN on Block (36 x 36 pixels): {before:.3} -> {after:.3} after {steps} steps");
    assert!(after - before >= 0.25, "{before} -> {after}");
    assert!(after >= -0.25, "{after}");
}
