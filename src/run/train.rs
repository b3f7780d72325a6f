//! The training loop shared by PPO, SAC and TD3: rollout workers, evaluation on a
//! schedule counted in env steps, best and last networks, checkpoints at epoch ends
//! (resumable), then the test phase.

use super::checkpoint::{self, CheckpointError, LoopState};
use super::curriculum::{SuccessSchedule, load_teacher, training_envs};
use super::dagger::Dagger;
use super::demonstrations::give_demonstrations;
use super::init::init_networks;
use super::interrupt;
use super::kickstart::teacher_labels;
use super::lock::{LockError, RunLock};
use super::log::{CSV_FILES, RunLog, Speed};
use crate::agents::{build_agent, device};
use crate::config::{BestBy, Checkpoint, RunConfig, TestActions};
use crate::files::{RunFileError, write_atomic};
use crate::play::evaluation::{Episodes, PlayError, play_agent, write_test};
use crate::play::metrics::TestMetrics;
use crate::self_play::{SelfPlay, SelfPlayError};
use foosball_algos::{Agent, AgentError, Collector};
use foosball_env::seeding::{EVAL_ENVS, TEST_ENVS, TRAIN_ENVS, derive_seed};
use foosball_env::{EnvError, FoosballInfo, VecEnv, VecEnvError};
use foosball_nets::BackendError;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Env steps between rows of training scalars (metrics averaged over them).
pub const LOG_EVERY: u64 = 1_000;

/// Wall time between [`Event::Tick`]s.
pub const TICK: Duration = Duration::from_secs(2);

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The backend is unknown or not compiled in.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// An environment refused its settings or an action.
    #[error("environment: {0}")]
    Env(String),
    /// The network backend's device failed to run queued work.
    #[error("device of protocol.backend: {0}")]
    Device(String),
    /// A run file could not be written.
    #[error(transparent)]
    File(#[from] RunFileError),
    /// Networks could not be saved.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The rayon pool could not be built.
    #[error("thread pool: {0}")]
    Threads(String),
    /// A checkpoint could not be written or read.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// Evaluation or test episodes could not be played or written.
    #[error(transparent)]
    Play(#[from] PlayError),
    /// `--resume` on a directory without a checkpoint.
    #[error("{0}: no checkpoint to resume from (none is written before the first epoch ends)")]
    NoCheckpoint(PathBuf),
    /// `protocol.init_from` names networks that cannot start this run, or
    /// `protocol.demonstrations` episodes it cannot learn from.
    #[error("{0}")]
    Init(String),
    /// Self-play's pool could not be saved, loaded or written.
    #[error(transparent)]
    SelfPlay(#[from] SelfPlayError),
    /// Another process trains the run, or its lock file could not be written.
    #[error(transparent)]
    Locked(#[from] LockError),
    /// A stop signal came ([`interrupt`]); the run resumes from its last checkpoint.
    #[error(
        "{dir}: stopped by a signal at env step {env_steps}; resumes from {from} (`train --resume` or the same sweep again)"
    )]
    Interrupted {
        /// The run directory.
        dir: PathBuf,
        /// Env steps done when it stopped.
        env_steps: u64,
        /// Where a resume starts.
        from: String,
    },
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

/// What the loop has just done, for progress displays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// The loop starts (after a resume, at the checkpoint's env steps).
    Started,
    /// A logging window ended ([`LOG_EVERY`] env steps or an epoch end).
    Window(Speed),
    /// At most every [`TICK`] of wall time: the speed since this process started training,
    /// for progress displays only (nothing is logged), so that an estimate shows before the
    /// first window ends even where one update takes seconds.
    Tick(Speed),
    /// An evaluation ended; its mean return and score rate.
    Evaluation {
        /// Mean return of the evaluation episodes.
        mean_return: f64,
        /// Share of evaluation episodes that scored.
        score_rate: f64,
    },
    /// Epoch `n` ended and was checkpointed.
    Checkpoint(u64),
    /// The final test started.
    Test,
}

/// Where the run stands when the loop reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Env steps done.
    pub env_steps: u64,
    /// Env steps of the whole run.
    pub total_steps: u64,
    /// What just happened.
    pub event: Event,
}

/// How a run begins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// From scratch; files of an earlier run in the directory are replaced.
    Fresh,
    /// From the directory's last checkpoint.
    Resume,
}

/// Seeds of the training envs from the start of epoch `epoch` (0-based) on: env `i`
/// restarts from `derive_seed(seed, TRAIN_ENVS, epoch * n + i)` (epoch 0 is
/// `VecEnv::reset(seed)`).
pub fn restart_seeds(seed: u64, epoch: u64, n: usize) -> Vec<u64> {
    (0..n as u64)
        .map(|i| derive_seed(seed, TRAIN_ENVS, epoch * n as u64 + i))
        .collect()
}

/// Removes what an earlier run left in `run_dir` (a fresh start with `--force`).
fn clear_run_dir(run_dir: &Path) -> Result<(), TrainError> {
    // `evaluate`'s outputs of the replaced run.
    if let Ok(entries) = std::fs::read_dir(run_dir) {
        for entry in entries.flatten() {
            if entry.file_name().to_string_lossy().starts_with("evaluate-") {
                checkpoint::remove_dir(&entry.path())?;
            }
        }
    }
    for dir in [
        "checkpoint",
        "checkpoint.old",
        "checkpoint.tmp",
        "best",
        "last",
        "test",
        "tensorboard",
        crate::self_play::POOL_DIR,
    ] {
        checkpoint::remove_dir(&run_dir.join(dir))?;
    }
    Ok(())
}

/// Trains `config` in `run_dir` (which must exist), then tests the final networks.
///
/// The loop: collect (VecEnv) -> store -> update, logging every [`LOG_EVERY`] env steps,
/// evaluating every `eval_every` env steps (best networks kept in `best/`); at each epoch
/// end the training envs restart (episodes still running are cut as truncations) and
/// the networks (`last/`) and a checkpoint are written. `Start::Resume` goes on from the
/// checkpoint, so a resumed run ends as the uninterrupted one would. `report` hears of
/// every window, evaluation and checkpoint.
///
/// The run directory is locked for the whole call ([`RunLock`]): a second process gets
/// [`TrainError::Locked`]. After [`interrupt::install`], a stop signal ends the loop between
/// two env steps with [`TrainError::Interrupted`].
pub fn train(
    config: &RunConfig,
    run_dir: &Path,
    start: Start,
    mut report: impl FnMut(&Progress) + Send,
) -> Result<TestMetrics, TrainError> {
    let p = &config.protocol;
    let threads = match p.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| TrainError::Threads(e.to_string()))?;
    let _lock = RunLock::acquire(run_dir)?;
    pool.install(|| {
        let device = device(config)?;
        let mut agent = build_agent(config, &device);
        // With `[dagger]` the teacher hands the files with its labels (below), once.
        if config.dagger.is_none() {
            give_demonstrations(config, agent.as_mut()).map_err(TrainError::Init)?;
        }
        let teacher = load_teacher(config).map_err(TrainError::Init)?;
        let state = match start {
            Start::Resume => {
                let dir = checkpoint::find(run_dir)
                    .ok_or_else(|| TrainError::NoCheckpoint(run_dir.to_path_buf()))?;
                checkpoint::load(&dir, agent.as_mut())?
            }
            Start::Fresh => {
                init_networks(config, agent.as_mut()).map_err(TrainError::Init)?;
                clear_run_dir(run_dir)?;
                write_atomic(&run_dir.join("config.toml"), config.to_toml().as_bytes())?;
                LoopState {
                    epoch: 0,
                    next_eval: p.eval_every,
                    next_log: LOG_EVERY,
                    best: f64::NEG_INFINITY,
                    log_bytes: vec![0; CSV_FILES.len()],
                    self_play: None,
                    dagger: None,
                    curriculum: None,
                }
            }
        };
        let LoopState {
            epoch: done,
            mut next_eval,
            mut next_log,
            mut best,
            ..
        } = state;
        let mut dagger = Dagger::start(config, state.dagger.clone()).map_err(TrainError::Init)?;
        if let Some(d) = &dagger {
            d.hand(agent.as_mut()).map_err(TrainError::Init)?;
        }
        let mut log = RunLog::open(
            run_dir,
            &state.log_bytes,
            (start == Start::Resume).then_some(agent.env_steps()),
            (agent.env_steps(), agent.gradient_steps()),
            config.env.agent_dt(),
        )?;
        let n = p.envs;
        let mut self_play = match &config.self_play {
            Some(sp) => Some(SelfPlay::start(
                config,
                sp,
                run_dir,
                n,
                state.self_play.as_ref(),
            )?),
            None => None,
        };
        let mut schedule =
            SuccessSchedule::start(config, teacher.as_ref(), state.curriculum.clone());
        let envs = match &self_play {
            Some(s) => s.envs(n)?,
            None => training_envs(
                config,
                teacher.as_ref(),
                schedule.as_ref(),
                n,
                agent.env_steps(),
            )
            .map_err(TrainError::Init)?,
        };
        let envs = envs
            .into_iter()
            .map(|env| env.with_drills(config.drills.clone()))
            .collect();
        let envs = VecEnv::new(envs, threads)?;
        let mut collector = Collector::with_seeds(envs, &restart_seeds(p.seed, done, n));
        if let Some(labels) = teacher_labels(config) {
            collector = collector.with_teacher(labels);
        }
        let total = p.total_env_steps();
        let progress = |env_steps, event| Progress {
            env_steps,
            total_steps: total,
            event,
        };
        let started = (Instant::now(), agent.env_steps(), agent.gradient_steps());
        report(&progress(started.1, Event::Started));
        let mut last_tick = started.0;
        if let Some(s) = &mut self_play {
            s.after_step(agent.env_steps(), agent.as_ref())?;
        }
        for epoch in done + 1..=u64::from(p.epochs) {
            let end = epoch * p.steps_per_epoch;
            while agent.env_steps() < end {
                let steps = agent.env_steps();
                let remaining = 1.0 - steps as f64 / total as f64;
                let on_episode = |i, e, info: &FoosballInfo| {
                    log.episode(steps, e, info);
                    if let Some(s) = &self_play {
                        s.on_episode(i, info);
                    }
                    if let Some(m) = schedule.as_mut().and_then(|s| s.on_episode(info)) {
                        log.update(m);
                    }
                };
                let update = if steps + n as u64 >= end {
                    let seeds = restart_seeds(p.seed, epoch, n);
                    collector.step_then_restart(agent.as_mut(), remaining, &seeds, on_episode)
                } else {
                    collector.step(agent.as_mut(), remaining, on_episode)
                }?;
                if let Some(m) = update {
                    log.update(m);
                }
                let steps = agent.env_steps();
                if let Some(s) = &mut self_play {
                    s.after_step(steps, agent.as_ref())?;
                }
                if interrupt::requested() {
                    return Err(interrupted(run_dir, steps, epoch - 1));
                }
                if last_tick.elapsed() >= TICK {
                    last_tick = Instant::now();
                    let seconds = started.0.elapsed().as_secs_f64();
                    let speed = Speed {
                        steps_per_second: (steps - started.1) as f64 / seconds,
                        updates_per_second: (agent.gradient_steps() - started.2) as f64 / seconds,
                    };
                    report(&progress(steps, Event::Tick(speed)));
                }
                if steps >= next_log {
                    next_log += LOG_EVERY;
                    if let Some(speed) = log.end_window(steps, agent.gradient_steps())? {
                        report(&progress(steps, Event::Window(speed)));
                    }
                }
                if steps >= next_eval {
                    next_eval += p.eval_every;
                    let episodes = Episodes {
                        env: &config.env,
                        seed: p.seed,
                        stream: EVAL_ENVS,
                        n: p.eval_episodes,
                        record: false,
                    };
                    let played = play_agent(agent.as_mut(), TestActions::Deterministic, &episodes)?;
                    let m = TestMetrics::from_episodes(
                        &played.iter().map(|e| e.summary).collect::<Vec<_>>(),
                    );
                    log.evaluation(steps, &m)?;
                    let rank = best_key(p.best_by, &m);
                    if rank > best {
                        best = rank;
                        save(agent.as_ref(), &run_dir.join(Checkpoint::Best.name()))?;
                    }
                    let event = Event::Evaluation {
                        mean_return: m.mean_return.mean,
                        score_rate: m.score_rate.mean,
                    };
                    report(&progress(steps, event));
                }
                if let Some(d) = dagger.as_mut().filter(|d| steps >= d.next_round_at()) {
                    let round = d.round(agent.as_mut()).map_err(TrainError::Init)?;
                    log.update(round.metrics(d.label_rows()));
                }
            }
            let steps = agent.env_steps();
            if let Some(speed) = log.end_window(steps, agent.gradient_steps())? {
                report(&progress(steps, Event::Window(speed)));
            }
            save(agent.as_ref(), &run_dir.join(Checkpoint::Last.name()))?;
            let state = LoopState {
                epoch,
                next_eval,
                next_log,
                best,
                log_bytes: log.csv_bytes()?,
                self_play: self_play.as_ref().map(SelfPlay::state),
                dagger: dagger.as_ref().map(|d| d.state().clone()),
                curriculum: schedule.as_ref().map(SuccessSchedule::state),
            };
            checkpoint::write(run_dir, agent.as_ref(), &state)?;
            if let Some(s) = &self_play {
                s.write_records(steps)?;
            }
            report(&progress(steps, Event::Checkpoint(epoch)));
        }
        report(&progress(agent.env_steps(), Event::Test));
        if p.test_networks == Checkpoint::Best {
            agent.load(&run_dir.join(Checkpoint::Best.name()))?;
        }
        let episodes = Episodes {
            env: &config.env,
            seed: p.seed,
            stream: TEST_ENVS,
            n: p.test_episodes,
            record: true,
        };
        let played = play_agent(agent.as_mut(), p.test_actions, &episodes)?;
        Ok(write_test(&run_dir.join("test"), &played)?)
    })
}

/// The error of a run stopped by a signal at `env_steps`, `epochs` epochs checkpointed.
fn interrupted(run_dir: &Path, env_steps: u64, epochs: u64) -> TrainError {
    TrainError::Interrupted {
        dir: run_dir.to_path_buf(),
        env_steps,
        from: match epochs {
            0 => "the start (no epoch was checkpointed)".into(),
            k => format!("the checkpoint of epoch {k}"),
        },
    }
}

fn save(agent: &dyn Agent, dir: &Path) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(RunFileError::at(dir))?;
    Ok(agent.save(dir)?)
}

/// An evaluation's rank under `by` (higher is better): the mean return, or the score rate
/// first and the mean return second, as `1e12 * score_rate + mean_return` (a step of the
/// score rate, at least 1e-4 for up to 10,000 episodes, outweighs any return of the
/// table: below 3e7 in magnitude).
fn best_key(by: BestBy, m: &TestMetrics) -> f64 {
    match by {
        BestBy::Return => m.mean_return.mean,
        BestBy::ScoreRate => 1e12 * m.score_rate.mean + m.mean_return.mean,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::play::metrics::EpisodeSummary;

    /// Metrics of one episode of return `ret`, scored or not.
    fn one(ret: f64, scored: bool) -> TestMetrics {
        let summary = EpisodeSummary {
            steps: 10,
            ret,
            scored,
            ..EpisodeSummary::default()
        };
        TestMetrics::from_episodes(&[summary])
    }

    #[test]
    fn the_best_evaluation_is_ranked_by_return_or_by_score_rate_first() {
        let (goal, long) = (one(9_000.0, true), one(2.5e7, false));
        assert!(best_key(BestBy::Return, &long) > best_key(BestBy::Return, &goal));
        assert!(best_key(BestBy::ScoreRate, &goal) > best_key(BestBy::ScoreRate, &long));
        let better_goal = one(9_500.0, true);
        assert!(best_key(BestBy::ScoreRate, &better_goal) > best_key(BestBy::ScoreRate, &goal));
    }
}
