//! Your own environment, trained by this project's PPO and SAC.
//!
//! `Reach` is defined here: a point mass on a plane, pushed by a 2-D force towards the
//! origin (observation: position and velocity; reward: minus the distance, minus a
//! little effort). Any type that implements [`Env`] trains the same way: a [`VecEnv`] of
//! copies, a [`Collector`] stepping them, an [`Agent`] acting, observing and updating.
//!
//! `cargo run --release --example own_env` (about 10 s on this project's 2-core machine;
//! CI runs it). It exits with an error if either learner fails to improve on its untrained
//! return.

use foosball_rl::algos::{Agent, Collector, Ppo, PpoConfig, Sac, SacConfig, play_episode};
use foosball_rl::env::env::check_action;
use foosball_rl::env::seeding::{EVAL_ENVS, LEARNER, derive_seed};
use foosball_rl::env::{Env, EnvError, Transition, VecEnv};
use foosball_rl::nets::Backend;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A point mass on [-1, 1]^2 pushed towards the origin; 100 steps an episode.
#[derive(Clone)]
struct Reach {
    state: [f32; 4], // x, y, vx, vy
    steps: u32,
    rng: ChaCha8Rng,
}

impl Reach {
    fn new() -> Self {
        Self {
            state: [0.0; 4],
            steps: 0,
            rng: ChaCha8Rng::seed_from_u64(0),
        }
    }
}

impl Env for Reach {
    type Info = ();

    fn obs_dim(&self) -> usize {
        4
    }

    fn action_dim(&self) -> usize {
        2
    }

    fn reset_into(&mut self, seed: Option<u64>, obs: &mut [f32]) {
        if let Some(seed) = seed {
            self.rng = ChaCha8Rng::seed_from_u64(seed);
        }
        let mut start = || self.rng.random_range(-1.0..1.0);
        self.state = [start(), start(), 0.0, 0.0];
        self.steps = 0;
        obs.copy_from_slice(&self.state);
    }

    fn step_into(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Transition<()>, EnvError> {
        check_action(action, 2)?;
        let [x, y, vx, vy] = self.state;
        let (ax, ay) = (action[0].clamp(-1.0, 1.0), action[1].clamp(-1.0, 1.0));
        let dt = 0.05;
        let (vx, vy) = (0.9 * vx + ax * dt * 4.0, 0.9 * vy + ay * dt * 4.0);
        let (x, y) = (
            (x + vx * dt).clamp(-2.0, 2.0),
            (y + vy * dt).clamp(-2.0, 2.0),
        );
        self.state = [x, y, vx, vy];
        self.steps += 1;
        obs.copy_from_slice(&self.state);
        let reward = -(x * x + y * y).sqrt() - 0.01 * (ax * ax + ay * ay);
        Ok(Transition {
            reward,
            terminated: false,
            truncated: self.steps >= 100,
            info: (),
        })
    }
}

/// Mean deterministic return over 10 held-out episodes.
fn evaluate(agent: &mut dyn Agent) -> f64 {
    let mut env = Reach::new();
    let returns = (0..10).map(|k| play_episode(agent, &mut env, derive_seed(0, EVAL_ENVS, k)));
    returns
        .map(|e| e.expect("Reach takes any finite action").ret)
        .sum::<f64>()
        / 10.0
}

/// Trains `agent` for `steps` env steps on 4 copies of `Reach`; returns (before, after).
fn train(agent: &mut dyn Agent, steps: u64) -> Result<(f64, f64), Box<dyn std::error::Error>> {
    let before = evaluate(agent);
    let mut collector = Collector::new(VecEnv::new(vec![Reach::new(); 4], 1)?, 0);
    while agent.env_steps() < steps {
        let remaining = 1.0 - agent.env_steps() as f64 / steps as f64;
        collector.step(agent, remaining, |_, _, _| {})?;
    }
    Ok((before, evaluate(agent)))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let device = Backend::default_cpu()?.device()?;
    let seed = derive_seed(0, LEARNER, 0);
    let mut ppo_config = PpoConfig {
        n_steps: 256,
        ..PpoConfig::default()
    };
    ppo_config.net.hidden = vec![32, 32];
    let mut sac_config = SacConfig::default();
    sac_config.net.hidden = vec![32, 32];
    sac_config.off_policy.learning_starts = 500;
    let learners: [(&str, Box<dyn Agent>, u64); 2] = [
        (
            "PPO",
            Box::new(Ppo::new(4, 2, ppo_config, seed, &device)),
            40_000,
        ),
        (
            "SAC",
            Box::new(Sac::agent(4, 2, sac_config, seed, &device)),
            8_000,
        ),
    ];
    for (name, mut agent, steps) in learners {
        let (before, after) = train(agent.as_mut(), steps)?;
        println!(
            "{name} on Reach: mean return {before:.1} untrained, {after:.1} after {steps} env steps"
        );
        if after <= before {
            return Err(format!("{name} did not improve on Reach").into());
        }
    }
    Ok(())
}
