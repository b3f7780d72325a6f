//! The training loop shared by PPO, SAC and TD3: rollout workers, evaluation on a
//! schedule counted in env steps, best and last networks, then the test phase.

use crate::config::{Algo, RunConfig};
use crate::evaluation::{PlayedEpisode, play_deterministic};
use crate::metrics::{EpisodeSummary, TestMetrics};
use crate::run_dir::{RunFileError, append_csv, trajectories_bytes, write_atomic};
use foosball_algos::{Agent, AgentError, Collector, Metrics, Ppo, Sac, Td3};
use foosball_env::seeding::{EVAL_ENVS, LEARNER, TEST_ENVS, derive_seed};
use foosball_env::{EnvError, FoosballEnv, VecEnv, VecEnvError, layout};
use foosball_nets::{Backend, BackendError, Device};
use std::path::Path;
use std::time::Instant;

/// Deterministic episodes played side by side in evaluations and tests (part of the
/// protocol: it fixes the policy's batch shape).
pub const EVAL_BATCH: usize = 10;

/// Env steps between rows of `updates.csv` (metrics averaged over them).
pub const LOG_EVERY: u64 = 1_000;

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The backend is unknown or not compiled in.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// An environment refused its settings or an action.
    #[error("environment: {0}")]
    Env(String),
    /// A run file could not be written.
    #[error(transparent)]
    File(#[from] RunFileError),
    /// Networks could not be saved.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The rayon pool could not be built.
    #[error("thread pool: {0}")]
    Threads(String),
}

impl From<VecEnvError> for TrainError {
    fn from(e: VecEnvError) -> Self {
        TrainError::Env(e.to_string())
    }
}

impl From<EnvError> for TrainError {
    fn from(e: EnvError) -> Self {
        TrainError::Env(e.to_string())
    }
}

/// What the loop reports after each evaluation.
#[derive(Clone, Debug)]
pub struct Progress {
    /// Env steps done.
    pub env_steps: u64,
    /// Env steps of the whole run.
    pub total_steps: u64,
    /// Env steps per second since the start.
    pub steps_per_second: f64,
    /// Mean return of the last evaluation.
    pub eval_return: f64,
    /// Score rate of the last evaluation.
    pub eval_score_rate: f64,
}

/// The agent `config` asks for, its networks drawn from the learner stream.
pub fn build_agent(config: &RunConfig, device: &Device) -> Box<dyn Agent + Send> {
    let seed = derive_seed(config.protocol.seed, LEARNER, 0);
    let (o, a) = (layout::OBS_DIM, layout::ACTION_DIM);
    match config.algo {
        Algo::Ppo => Box::new(Ppo::new(
            o,
            a,
            config.ppo.clone().expect("filled"),
            seed,
            device,
        )),
        Algo::Sac => Box::new(Sac::agent(
            o,
            a,
            config.sac.clone().expect("filled"),
            seed,
            device,
        )),
        Algo::Td3 => Box::new(Td3::agent(
            o,
            a,
            config.td3.clone().expect("filled"),
            seed,
            device,
        )),
    }
}

/// The device of the configured backend (the default CPU backend when unset).
pub fn device(config: &RunConfig) -> Result<Device, TrainError> {
    let backend = match config.protocol.backend {
        Some(b) => b,
        None => Backend::default_cpu()?,
    };
    Ok(backend.device()?)
}

fn foosball_envs(config: &RunConfig, n: usize) -> Result<Vec<FoosballEnv>, TrainError> {
    (0..n)
        .map(|_| {
            FoosballEnv::new(config.env.clone()).map_err(|e| TrainError::Env(format!("env.{e}")))
        })
        .collect()
}

/// Deterministic episodes on the `stream`'s seeds `0..n`.
pub fn play(
    agent: &mut dyn Agent,
    config: &RunConfig,
    stream: u64,
    n: u32,
    record: bool,
) -> Result<Vec<PlayedEpisode>, TrainError> {
    let seeds: Vec<u64> = (0..u64::from(n))
        .map(|k| derive_seed(config.protocol.seed, stream, k))
        .collect();
    let mut envs = foosball_envs(config, EVAL_BATCH.min(seeds.len()))?;
    Ok(play_deterministic(agent, &mut envs, &seeds, record)?)
}

/// Writes `metrics.json`, `metrics.md` and `trajectories.bin` into `dir`.
pub fn write_test(dir: &Path, episodes: &[PlayedEpisode]) -> Result<TestMetrics, TrainError> {
    let summaries: Vec<EpisodeSummary> = episodes.iter().map(|e| e.summary).collect();
    let metrics = TestMetrics::from_episodes(&summaries);
    let json = serde_json::to_string_pretty(&metrics).expect("metrics serialise");
    write_atomic(&dir.join("metrics.json"), json.as_bytes())?;
    write_atomic(&dir.join("metrics.md"), metrics.to_markdown().as_bytes())?;
    let bytes = trajectories_bytes(episodes, layout::OBS_DIM, layout::ACTION_DIM);
    write_atomic(&dir.join("trajectories.bin"), &bytes)?;
    Ok(metrics)
}

/// Trains `config` into `run_dir` (which must exist), then tests the final networks.
/// `report` is called after every evaluation.
pub fn train(
    config: &RunConfig,
    run_dir: &Path,
    mut report: impl FnMut(&Progress) + Send,
) -> Result<TestMetrics, TrainError> {
    write_atomic(&run_dir.join("config.toml"), config.to_toml().as_bytes())?;
    let p = &config.protocol;
    let threads = match p.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| TrainError::Threads(e.to_string()))?;
    pool.install(|| {
        let device = device(config)?;
        let mut agent = build_agent(config, &device);
        let envs = VecEnv::new(foosball_envs(config, p.envs)?, threads)?;
        let mut collector = Collector::new(envs, p.seed);
        let total = u64::from(p.epochs) * p.steps_per_epoch;
        let (mut next_eval, mut next_log) = (p.eval_every, LOG_EVERY);
        let mut best = f64::NEG_INFINITY;
        let mut pending: Vec<Metrics> = Vec::new();
        let start = Instant::now();
        for epoch in 1..=u64::from(p.epochs) {
            while agent.env_steps() < epoch * p.steps_per_epoch {
                let progress = 1.0 - agent.env_steps() as f64 / total as f64;
                let steps = agent.env_steps();
                let mut episodes = Vec::new();
                let update = collector.step(agent.as_mut(), progress, |_, e, info| {
                    episodes.push(format!(
                        "{},{},{},{}",
                        steps,
                        e.ret,
                        e.len,
                        u8::from(info.scored())
                    ));
                })?;
                append_csv(
                    &run_dir.join("episodes.csv"),
                    "env_step,return,length,scored",
                    &episodes,
                )?;
                pending.extend(update);
                if agent.env_steps() >= next_log && !pending.is_empty() {
                    let lines: Vec<String> = Metrics::mean(&pending)
                        .0
                        .iter()
                        .map(|(name, v)| format!("{},{name},{v}", agent.env_steps()))
                        .collect();
                    append_csv(&run_dir.join("updates.csv"), "env_step,name,value", &lines)?;
                    pending.clear();
                    next_log += LOG_EVERY;
                }
                if agent.env_steps() >= next_eval {
                    next_eval += p.eval_every;
                    let played = play(agent.as_mut(), config, EVAL_ENVS, p.eval_episodes, false)?;
                    let m = TestMetrics::from_episodes(
                        &played.iter().map(|e| e.summary).collect::<Vec<_>>(),
                    );
                    let line = format!(
                        "{},{},{},{}",
                        agent.env_steps(),
                        m.mean_return.mean,
                        m.score_rate.mean,
                        m.mean_goal_distance.mean
                    );
                    append_csv(
                        &run_dir.join("evaluations.csv"),
                        "env_step,mean_return,score_rate,mean_goal_distance",
                        &[line],
                    )?;
                    if m.mean_return.mean > best {
                        best = m.mean_return.mean;
                        save(agent.as_ref(), &run_dir.join("best"))?;
                    }
                    report(&Progress {
                        env_steps: agent.env_steps(),
                        total_steps: total,
                        steps_per_second: agent.env_steps() as f64 / start.elapsed().as_secs_f64(),
                        eval_return: m.mean_return.mean,
                        eval_score_rate: m.score_rate.mean,
                    });
                }
            }
            save(agent.as_ref(), &run_dir.join("last"))?;
        }
        let played = play(agent.as_mut(), config, TEST_ENVS, p.test_episodes, true)?;
        write_test(&run_dir.join("test"), &played)
    })
}

fn save(agent: &dyn Agent, dir: &Path) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(|source| RunFileError {
        path: dir.to_path_buf(),
        source,
    })?;
    Ok(agent.save(dir)?)
}
