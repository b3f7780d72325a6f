//! A training run: the protocol ([`super::protocol`]) composed with what the run's
//! configuration adds ([`super::hooks`]): self-play, DAgger, a curriculum, drills, a
//! kickstart teacher, demonstrations.

use super::checkpoint::{self, CheckpointError, LoopState};
use super::curriculum::{CurriculumState, SuccessSchedule, load_teacher, training_envs};
use super::dagger::{Dagger, DaggerState};
use super::demonstrations::give_demonstrations;
use super::hooks::Hooks;
use super::init::init_networks;
use super::kickstart::teacher_labels;
use super::lock::RunLock;
use super::log::{CSV_FILES, RunLog};
use super::protocol::{LOG_EVERY, Protocol, restart_seeds};
use crate::agents::{build_agent, device};
use crate::config::RunConfig;
use crate::files::write_atomic;
use crate::play::metrics::TestMetrics;
use crate::self_play::SelfPlay;
use crate::self_play::pool::PoolState;
use foosball_algos::{Agent, Collector};
use foosball_env::{FoosballEnv, VecEnv};
use foosball_nets::{Snapshot, SnapshotError};
use std::path::Path;

pub use super::error::TrainError;
pub use super::progress::{Event, Progress};

/// How a run begins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// From scratch; files of an earlier run in the directory are replaced.
    Fresh,
    /// From the directory's last checkpoint.
    Resume,
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

/// Trains `config`'s algorithm (PPO, SAC or TD3, [`build_agent`]) in `run_dir` (which
/// must exist), then tests the final networks: [`train_agent`] with the configured
/// learner.
pub fn train(
    config: &RunConfig,
    run_dir: &Path,
    start: Start,
    report: impl FnMut(&Progress) + Send,
) -> Result<TestMetrics, TrainError> {
    let build = |config: &RunConfig| Ok(build_agent(config, &device(config)?));
    train_agent(config, run_dir, start, build, report)
}

/// Trains the agent that `build` makes for `config` (any [`Agent`]: the configured
/// algorithm, or one of the caller's own) in `run_dir` through the protocol
/// ([`Protocol::run`]) with the hooks the configuration asks for, then tests it.
/// `Start::Resume` goes on from the directory's last checkpoint, so a resumed run ends
/// as the uninterrupted one would. `report` hears of every window, evaluation and
/// checkpoint.
///
/// The run directory is locked for the whole call ([`RunLock`]): a second process gets
/// [`TrainError::Locked`]. After [`super::interrupt::install`], a stop signal ends the
/// loop between two env steps with [`TrainError::Interrupted`].
pub fn train_agent(
    config: &RunConfig,
    run_dir: &Path,
    start: Start,
    build: impl FnOnce(&RunConfig) -> Result<Box<dyn Agent + Send>, TrainError> + Send,
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
        let mut agent = build(config)?;
        // With `[dagger]` the teacher hands the files with its labels (its hook), once.
        if config.dagger.is_none() {
            give_demonstrations(config, agent.as_mut()).map_err(TrainError::Init)?;
        }
        let (state, snap) = match start {
            Start::Resume => {
                let dir = checkpoint::find(run_dir)
                    .ok_or_else(|| TrainError::NoCheckpoint(run_dir.to_path_buf()))?;
                let (state, snap) = checkpoint::load(&dir, agent.as_mut())?;
                (state, Some((dir, snap)))
            }
            Start::Fresh => {
                init_networks(config, agent.as_mut()).map_err(TrainError::Init)?;
                clear_run_dir(run_dir)?;
                write_atomic(&run_dir.join("config.toml"), config.to_toml().as_bytes())?;
                let state = LoopState {
                    epoch: 0,
                    next_eval: p.eval_every,
                    next_log: LOG_EVERY,
                    best: f64::NEG_INFINITY,
                    log_bytes: vec![0; CSV_FILES.len()],
                };
                (state, None)
            }
        };
        let log = RunLog::open(
            run_dir,
            &state.log_bytes,
            (start == Start::Resume).then_some(agent.env_steps()),
            (agent.env_steps(), agent.gradient_steps()),
            config.env.agent_dt(),
        )?;
        let resumed = snap.as_ref().map(|(dir, snap)| (dir.as_path(), snap));
        let (hooks, envs) = hooks_and_envs(config, run_dir, agent.env_steps(), resumed)?;
        let envs = envs
            .into_iter()
            .map(|env| env.with_drills(config.drills.clone()));
        let envs = VecEnv::new(envs.collect(), threads)?;
        let mut collector =
            Collector::with_seeds(envs, &restart_seeds(p.seed, state.epoch, p.envs));
        if let Some(labels) = teacher_labels(config).map_err(TrainError::Init)? {
            collector = collector.with_teacher(labels);
        }
        Protocol {
            config,
            run_dir,
            agent: agent.as_mut(),
            collector,
            log,
            hooks,
            state,
            report: &mut report,
        }
        .run()
    })
}

/// The hooks of `config`'s run (self-play, the curriculum's success schedule, DAgger;
/// on a resume, each from the state it saved in the checkpoint `resumed` names and holds)
/// and its `protocol.envs` training envs: the self-play pool's, else the table's with the
/// curriculum's starts, if any, from `env_steps` on.
fn hooks_and_envs(
    config: &RunConfig,
    run_dir: &Path,
    env_steps: u64,
    resumed: Option<(&Path, &Snapshot<'_>)>,
) -> Result<(Hooks, Vec<FoosballEnv>), TrainError> {
    let n = config.protocol.envs;
    let mut hooks: Hooks = Vec::new();
    let teacher = load_teacher(config).map_err(TrainError::Init)?;
    let schedule_state = saved_state(resumed, CurriculumState::load)?;
    let schedule = SuccessSchedule::start(config, teacher.as_ref(), schedule_state);
    let envs = match &config.self_play {
        Some(sp) => {
            let pool = saved_state(resumed, PoolState::load)?;
            let self_play = SelfPlay::start(config, sp, run_dir, n, pool.as_ref())?;
            let envs = self_play.envs(n)?;
            hooks.push(Box::new(self_play));
            envs
        }
        None => training_envs(config, teacher.as_ref(), schedule.as_ref(), n, env_steps)
            .map_err(TrainError::Init)?,
    };
    if let Some(schedule) = schedule {
        hooks.push(Box::new(schedule));
    }
    let dagger_state = saved_state(resumed, DaggerState::load)?;
    if let Some(dagger) = Dagger::start(config, dagger_state).map_err(TrainError::Init)? {
        hooks.push(Box::new(dagger));
    }
    Ok((hooks, envs))
}

/// A hook's state as `load` reads it from the checkpoint `resumed` names and holds
/// (`None` on a fresh start, or where the checkpoint holds none); a torn entry names the
/// checkpoint.
fn saved_state<T>(
    resumed: Option<(&Path, &Snapshot<'_>)>,
    load: fn(&Snapshot<'_>) -> Result<Option<T>, SnapshotError>,
) -> Result<Option<T>, CheckpointError> {
    let Some((dir, snap)) = resumed else {
        return Ok(None);
    };
    load(snap).map_err(|source| CheckpointError::State {
        path: dir.to_path_buf(),
        source,
    })
}
