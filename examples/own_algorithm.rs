//! Your own algorithm through the paper's protocol on the `reference` table.
//!
//! `RandomSearch` is defined here: a linear policy `a = tanh(W [o / 50; 1])` improved by
//! basic random search (Mania et al. 2018, "Simple random search provides a competitive
//! approach to reinforcement learning", V1 with one direction): play an episode with
//! `W + nu * delta`, one with `W - nu * delta`, step `W += lr * (R+ - R-) / 2 * delta`.
//! Anything that implements [`Agent`] runs the same way: [`train_agent`] gives it the
//! protocol (evaluations every `eval_every` env steps with the best networks kept,
//! checkpoints and exact resume, logs, progress, the 1,000-episode test's metrics) and
//! the run directory every other tool reads.
//!
//! `cargo run --release --example own_algorithm` (a short protocol: 2 epochs of 4,000
//! env steps, a few seconds; CI runs it) writes `runs/own-algorithm/`, with the test's
//! five metrics in `runs/own-algorithm/test/metrics.md`. The config's `algo` only names
//! a section: the agent is this file's, and it sees the raw 38 observation values (no
//! `[normalize]` or `[fourier]`, which wrap the built-in learners).

use foosball_rl::algos::{ActMode, Agent, AgentError, Experience, Metrics};
use foosball_rl::config::RunConfig;
use foosball_rl::nets::{Snapshot, SnapshotError};
use foosball_rl::run::train::{Event, Start, train_agent};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::path::Path;

/// Basic random search over a linear policy; one training env.
struct RandomSearch {
    obs_dim: usize,
    action_dim: usize,
    /// `[action_dim, obs_dim + 1]`, row-major; the last column is the bias.
    weights: Vec<f32>,
    /// The direction being tried, the shape of `weights`.
    delta: Vec<f32>,
    /// Returns of the `+` and `-` episodes of `delta` (the `-` one is playing when set).
    plus_return: Option<f64>,
    running: f64,
    env_steps: u64,
    updates: u64,
    last_step: Option<f64>,
    rng: ChaCha8Rng,
}

const NOISE: f32 = 0.05;
const STEP: f32 = 1e-6;
const FILE: &str = "random_search.json";

impl RandomSearch {
    fn new(obs_dim: usize, action_dim: usize, seed: u64) -> Self {
        let mut this = Self {
            obs_dim,
            action_dim,
            weights: vec![0.0; action_dim * (obs_dim + 1)],
            delta: Vec::new(),
            plus_return: None,
            running: 0.0,
            env_steps: 0,
            updates: 0,
            last_step: None,
            rng: ChaCha8Rng::seed_from_u64(seed),
        };
        this.new_direction();
        this
    }

    fn new_direction(&mut self) {
        let normal = StandardNormal;
        self.delta = (0..self.weights.len())
            .map(|_| normal.sample(&mut self.rng))
            .collect();
    }

    /// The policy's actions for observations `[n, obs_dim]`, the weights moved by `sign *
    /// NOISE * delta`.
    fn policy(&self, obs: &[f32], sign: f32) -> Vec<f32> {
        let width = self.obs_dim + 1;
        obs.chunks(self.obs_dim)
            .flat_map(|o| {
                (0..self.action_dim).map(move |a| {
                    let w = |i: usize| {
                        self.weights[a * width + i] + sign * NOISE * self.delta[a * width + i]
                    };
                    let dot: f32 = o.iter().enumerate().map(|(i, x)| w(i) * x / 50.0).sum();
                    (dot + w(self.obs_dim)).tanh()
                })
            })
            .collect()
    }
}

impl Agent for RandomSearch {
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    fn action_dim(&self) -> usize {
        self.action_dim
    }

    fn act(&mut self, obs: &[f32], mode: ActMode) -> Vec<f32> {
        let sign = match (mode, self.plus_return) {
            (ActMode::Explore, None) => 1.0,
            (ActMode::Explore, Some(_)) => -1.0,
            _ => 0.0,
        };
        self.policy(obs, sign)
    }

    fn seed_sampling(&mut self, _seed: u64) {}

    fn observe(&mut self, step: &Experience<'_>) {
        self.env_steps += step.len() as u64;
        self.running += f64::from(step.rewards[0]);
        if !(step.terminated[0] || step.truncated[0]) {
            return;
        }
        let ret = std::mem::take(&mut self.running);
        match self.plus_return.take() {
            None => self.plus_return = Some(ret),
            Some(plus) => {
                let scale = STEP * (plus - ret) as f32 / 2.0;
                for (w, d) in self.weights.iter_mut().zip(&self.delta) {
                    *w += scale * d;
                }
                self.updates += 1;
                self.last_step = Some(plus - ret);
                self.new_direction();
            }
        }
    }

    fn update(&mut self, _progress_remaining: f64) -> Option<Metrics> {
        let difference = self.last_step.take()?;
        Some(Metrics(vec![("return_difference", difference.into())]))
    }

    fn env_steps(&self) -> u64 {
        self.env_steps
    }

    fn gradient_steps(&self) -> u64 {
        self.updates
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        let path = dir.join(FILE);
        let json = serde_json::to_string(&self.weights).expect("floats serialise");
        std::fs::write(&path, json).map_err(|e| AgentError::File {
            path,
            message: e.to_string(),
        })
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        let path = dir.join(FILE);
        let error = |message: String| AgentError::File {
            path: path.clone(),
            message,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| error(e.to_string()))?;
        let weights: Vec<f32> = serde_json::from_str(&text).map_err(|e| error(e.to_string()))?;
        if weights.len() != self.weights.len() {
            return Err(error(format!(
                "{} weights, expected {}",
                weights.len(),
                self.weights.len()
            )));
        }
        self.weights = weights;
        Ok(())
    }

    fn zero_obs_inputs(&mut self, _inputs: &[usize]) -> Result<(), String> {
        Err("random search starts from zero weights already".into())
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        snap.put_f32("rs.delta", self.delta.as_slice());
        snap.put_f64("rs.running", self.running);
        snap.put_f64("rs.plus_return", self.plus_return.unwrap_or(f64::NAN));
        snap.put_u64s("rs.counters", vec![self.env_steps, self.updates]);
        snap.put_rng("rs.rng", &self.rng);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        self.delta = snap.f32s_of_len("rs.delta", self.weights.len())?.to_vec();
        self.running = snap.f64("rs.running")?;
        self.plus_return = Some(snap.f64("rs.plus_return")?).filter(|r| !r.is_nan());
        if let [env_steps, updates] = *snap.u64s("rs.counters")? {
            (self.env_steps, self.updates) = (env_steps, updates);
        }
        self.rng = snap.rng("rs.rng")?;
        Ok(())
    }
}

const CONFIG: &str = r#"
algo = "ppo"            # names a section only: the agent is RandomSearch

[protocol]
seed = 0
epochs = 2
steps_per_epoch = 4000
eval_every = 2000
eval_episodes = 10
test_episodes = 100
threads = 1

[env]
preset = "reference"    # the paper code's game
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let config = RunConfig::from_toml(CONFIG, Path::new("own_algorithm.toml"))?;
    let run_dir = Path::new("runs/own-algorithm");
    std::fs::create_dir_all(run_dir)?;
    let (obs_dim, action_dim) = (
        config.env.observation.dim(),
        foosball_rl::env::layout::ACTION_DIM,
    );
    let build = |_: &RunConfig| Ok(Box::new(RandomSearch::new(obs_dim, action_dim, 7)) as _);
    let metrics = train_agent(&config, run_dir, Start::Fresh, build, |p| {
        if let Event::Evaluation {
            mean_return,
            score_rate,
        } = p.event
        {
            println!(
                "env step {}: evaluation return {mean_return:.0}, score rate {score_rate:.2}",
                p.env_steps
            );
        }
    })?;
    println!("{}", metrics.to_markdown());
    Ok(())
}
