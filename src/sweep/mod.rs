//! A seed sweep: algorithms x seeds trained into one directory, several runs at a time,
//! each an ordinary run directory (`<algo>-seed<k>/`), plus the scripted baselines on
//! the same table (`<policy>-<preset>/`).
//!
//! The sweep's runs are fixed by `sweep.toml` (the seeds and each algorithm's run
//! configuration). Running the same sweep again skips finished runs, resumes the others
//! from their last checkpoint, and starts the rest; a directory holding another sweep is
//! refused unless forced. A killed sweep loses at most the unfinished epochs of the runs
//! then running.
//!
//! Each run and each baseline is a [`Task`] that one process can do alone (`sweep --task
//! I`), which is how [`slurm`] spreads a sweep over a cluster's job array; [`status`] tells
//! where every task stands.

pub mod slurm;
pub mod status;

use crate::config::{Algo, RunConfig, migrate_legacy_keys};
use crate::files::write_atomic;
use crate::play::metrics::TestMetrics;
use crate::play::scripted::{Baseline, ScriptedPolicy};
use crate::run::checkpoint;
use crate::run::train::{Progress, Start, TrainError, train};
use serde::{Deserialize, Serialize};
use slurm::SlurmError;
use std::path::{Path, PathBuf};

/// What a sweep trains: `runs` (one base configuration per algorithm) x `seeds`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Run seeds.
    pub seeds: Vec<u64>,
    /// Scripted policies tested on the runs' table (the first run's `[env]`).
    pub baselines: Vec<ScriptedPolicy>,
    /// One configuration per algorithm; its `protocol.seed` is replaced by each seed.
    pub runs: Vec<RunConfig>,
}

/// A sweep that cannot start; the message names the flag, file or directory at fault.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// A seed list that does not parse.
    #[error("--seeds `{0}`: expected a range `A..B` (B excluded), a list `1,4,7` or one seed")]
    Seeds(String),
    /// The directory holds another sweep.
    #[error(
        "{0}: holds a sweep of another configuration (see its sweep.toml): pass --force to replace it or choose another --out"
    )]
    Other(PathBuf),
    /// A run directory of the sweep holds a run of another configuration.
    #[error("{0}: holds a run of another configuration: pass --force to replace it")]
    OtherRun(PathBuf),
    /// A sweep file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// No sweep in the directory (for `--task`, `--status`, `--report-only`).
    #[error(
        "{0}: no sweep here (no sweep.toml): start one with `sweep --out {0}` or `sweep --slurm --out {0}`"
    )]
    Missing(PathBuf),
    /// A task index beyond the sweep's tasks.
    #[error(
        "--task {index}: the sweep in {out} has tasks 0 to {last} (its runs, then its baselines)"
    )]
    Task {
        /// The index asked for.
        index: usize,
        /// The sweep directory.
        out: PathBuf,
        /// Its last task index.
        last: usize,
    },
    /// The scheduler refused or a SLURM file failed.
    #[error(transparent)]
    Slurm(SlurmError),
}

/// Why the last process that trained a run stopped before the end (`RUN/stopped.txt`,
/// written by [`train_run`], removed when the run starts again).
pub const STOPPED_FILE: &str = "stopped.txt";

/// What one process of a sweep does: train (or resume) a run, or test a baseline.
#[derive(Clone, Debug, PartialEq)]
pub enum Task {
    /// A training run.
    Run(Box<SweepRun>),
    /// A scripted baseline on the runs' table.
    Baseline(ScriptedPolicy),
}

impl Task {
    /// Its directory name inside the sweep.
    pub fn name(&self, spec: &SweepSpec) -> String {
        match self {
            Task::Run(r) => SweepSpec::run_name(r.config.algo(), r.config.protocol.seed),
            Task::Baseline(p) => format!("{}-{}", p.name(), spec.runs[0].env.preset.name()),
        }
    }

    /// Its directory.
    pub fn dir(&self, spec: &SweepSpec, out: &Path) -> PathBuf {
        match self {
            Task::Run(r) => r.dir.clone(),
            Task::Baseline(_) => out.join(self.name(spec)),
        }
    }

    /// Whether it has nothing left to do.
    pub fn finished(&self, spec: &SweepSpec, out: &Path) -> bool {
        match self {
            Task::Run(r) => r.start.is_none(),
            Task::Baseline(p) => {
                let dir = self.dir(spec, out);
                Baseline::read(&dir).is_ok_and(|b| b == baseline_record(spec, *p))
                    && dir.join("metrics.json").is_file()
            }
        }
    }
}

/// Parses `A..B` (B excluded), `a,b,c` or `a`.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>, SweepError> {
    let bad = || SweepError::Seeds(text.to_string());
    let seeds: Vec<u64> = if let Some((a, b)) = text.split_once("..") {
        let (a, b) = (
            a.trim().parse::<u64>().map_err(|_| bad())?,
            b.trim().parse::<u64>().map_err(|_| bad())?,
        );
        (a..b).collect()
    } else {
        text.split(',')
            .map(|s| s.trim().parse::<u64>().map_err(|_| bad()))
            .collect::<Result<_, _>>()?
    };
    let mut unique = seeds.clone();
    unique.sort_unstable();
    unique.dedup();
    if seeds.is_empty() || unique.len() != seeds.len() {
        return Err(bad());
    }
    Ok(seeds)
}

/// One run of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepRun {
    /// Its directory.
    pub dir: PathBuf,
    /// Its configuration (the algorithm's with the run's seed).
    pub config: RunConfig,
    /// How it goes on: `None` when it has finished its test.
    pub start: Option<Start>,
}

impl SweepRun {
    /// Env steps of the whole run.
    pub fn total_steps(&self) -> u64 {
        self.config.protocol.total_env_steps()
    }
}

impl SweepSpec {
    /// The sweep written in `out/sweep.toml`.
    pub fn load(out: &Path) -> Result<Self, SweepError> {
        let path = out.join("sweep.toml");
        let text = std::fs::read_to_string(&path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => SweepError::Missing(out.to_path_buf()),
            _ => SweepError::File {
                path: path.clone(),
                message: e.to_string(),
            },
        })?;
        toml::from_str(&migrate_legacy_keys(&text)).map_err(|e| SweepError::File {
            path,
            message: e.to_string(),
        })
    }

    /// Every task of the sweep in `out`: the runs in plan order, then the baselines; a
    /// task's index here is its SLURM array index. A run directory holding another
    /// configuration is refused, as by [`SweepSpec::open`].
    pub fn tasks(&self, out: &Path) -> Result<Vec<Task>, SweepError> {
        Ok(self.with_baselines(self.plan(out, false)?))
    }

    /// The tasks of `runs` (as planned by [`SweepSpec::open`] or [`SweepSpec::check`])
    /// followed by the baselines, in task index order.
    pub fn with_baselines(&self, runs: Vec<SweepRun>) -> Vec<Task> {
        let runs = runs.into_iter().map(|r| Task::Run(Box::new(r)));
        runs.chain(self.baselines.iter().map(|&p| Task::Baseline(p)))
            .collect()
    }

    /// The run directory name of `algo` with `seed`.
    pub fn run_name(algo: Algo, seed: u64) -> String {
        format!("{algo}-seed{seed}")
    }

    /// Takes `out` for this sweep: checks that the `sweep.toml` there, if any, is this
    /// sweep's (`force` replaces another), plans every run, then writes `sweep.toml`.
    pub fn open(&self, out: &Path, force: bool) -> Result<Vec<SweepRun>, SweepError> {
        let runs = self.check(out, force)?;
        let path = out.join("sweep.toml");
        let text = toml::to_string_pretty(self).expect("a sweep always serialises");
        write_atomic(&path, text.as_bytes()).map_err(|e| SweepError::File {
            path: e.path,
            message: e.source.to_string(),
        })?;
        Ok(runs)
    }

    /// What [`SweepSpec::open`] checks and plans, writing nothing.
    pub fn check(&self, out: &Path, force: bool) -> Result<Vec<SweepRun>, SweepError> {
        if !force && out.join("sweep.toml").is_file() && Self::load(out).ok().as_ref() != Some(self)
        {
            return Err(SweepError::Other(out.to_path_buf()));
        }
        self.plan(out, force)
    }

    /// Every run in order (seed-major, so that each seed's algorithms finish together),
    /// with how it goes on. A run directory holding another configuration is refused
    /// unless `force` (then it starts afresh).
    fn plan(&self, out: &Path, force: bool) -> Result<Vec<SweepRun>, SweepError> {
        let mut runs = Vec::new();
        for &seed in &self.seeds {
            for base in &self.runs {
                let mut config = base.clone();
                config.protocol.seed = seed;
                let dir = out.join(Self::run_name(config.algo(), seed));
                let saved = RunConfig::load_run(&dir).ok();
                let same = saved.as_ref().is_some_and(|s| same_run(s, &config));
                if saved.is_some() && !same && !force {
                    return Err(SweepError::OtherRun(dir));
                }
                let start = if !same {
                    Some(Start::Fresh)
                } else if dir.join("test/metrics.json").is_file() {
                    None
                } else if checkpoint::find(&dir).is_some() {
                    Some(Start::Resume)
                } else {
                    Some(Start::Fresh)
                };
                runs.push(SweepRun { dir, config, start });
            }
        }
        Ok(runs)
    }
}

/// Two configurations give the same run (the thread count does not change results).
fn same_run(a: &RunConfig, b: &RunConfig) -> bool {
    let mut a = a.clone();
    a.protocol.threads = b.protocol.threads;
    &a == b
}

/// Trains `run` in its directory (created if needed). Why it stopped, when it stops
/// before the end, is written to [`STOPPED_FILE`] for `sweep --status` (unless another
/// process holds the run, whose own file that is).
pub fn train_run(
    run: &SweepRun,
    report: impl FnMut(&Progress) + Send,
) -> Result<Option<TestMetrics>, TrainError> {
    let Some(start) = run.start else {
        return Ok(None);
    };
    std::fs::create_dir_all(&run.dir).map_err(crate::files::RunFileError::at(&run.dir))?;
    let stopped = run.dir.join(STOPPED_FILE);
    let result = train(&run.config, &run.dir, start, report);
    match &result {
        Ok(_) => crate::files::remove_file(&stopped)?,
        Err(TrainError::Locked(_)) => {}
        Err(e) => write_atomic(&stopped, format!("{e}\n").as_bytes())?,
    }
    result.map(Some)
}

/// Does task `index` of the sweep in `out` with `threads` threads per run: trains or
/// resumes its run, or tests its baseline; a finished task does nothing. Returns the
/// task's name and its test metrics (`None` when it had finished before).
pub fn run_task(
    out: &Path,
    index: usize,
    threads: usize,
    report: impl FnMut(&Progress) + Send,
) -> Result<(String, Option<TestMetrics>), String> {
    let spec = SweepSpec::load(out).map_err(|e| e.to_string())?;
    // sweep.toml is the truth: whoever wrote it was allowed to replace the runs there.
    let mut tasks = spec.with_baselines(spec.plan(out, true).map_err(|e| e.to_string())?);
    let last = tasks.len() - 1;
    let task = tasks.get_mut(index).ok_or_else(|| {
        SweepError::Task {
            index,
            out: out.to_path_buf(),
            last,
        }
        .to_string()
    })?;
    let name = task.name(&spec);
    if task.finished(&spec, out) {
        return Ok((name, None));
    }
    match task {
        Task::Run(run) => {
            run.config.protocol.threads = threads;
            train_run(run, report)
                .map(|m| (name, m))
                .map_err(|e| e.to_string())
        }
        Task::Baseline(p) => {
            let m = test_baseline(&spec, *p, &out.join(&name)).map_err(|e| e.to_string())?;
            Ok((name, Some(m)))
        }
    }
}

/// Plays baseline `policy`'s test episodes into `dir`.
fn test_baseline(
    spec: &SweepSpec,
    policy: ScriptedPolicy,
    dir: &Path,
) -> Result<TestMetrics, crate::play::evaluation::PlayError> {
    baseline_record(spec, policy).test(spec.runs[0].protocol.test_episodes, dir, false)
}

/// What a baseline of `spec` plays: `policy` on the first run's table and seed.
fn baseline_record(spec: &SweepSpec, policy: ScriptedPolicy) -> Baseline {
    Baseline {
        policy,
        seed: spec.seeds[0],
        env: spec.runs[0].env.clone(),
        planner: None,
    }
}

/// Plays `policy` on `spec`'s table (the first run's `[env]`, seed and test episodes)
/// into `out/<policy>-<preset>/`, unless it is there already; returns its directory.
pub fn baseline(
    spec: &SweepSpec,
    policy: ScriptedPolicy,
    out: &Path,
) -> Result<PathBuf, TrainError> {
    let task = Task::Baseline(policy);
    let dir = task.dir(spec, out);
    if !task.finished(spec, out) {
        test_baseline(spec, policy, &dir)?;
    }
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_parse_as_ranges_lists_or_one() {
        assert_eq!(parse_seeds("0..5").unwrap(), vec![0, 1, 2, 3, 4]);
        assert_eq!(parse_seeds("3, 9,1").unwrap(), vec![3, 9, 1]);
        assert_eq!(parse_seeds("7").unwrap(), vec![7]);
        for bad in ["", "5..5", "a..3", "1,1", "1;2", "-1"] {
            let e = parse_seeds(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--seeds `{bad}`")), "{e}");
        }
    }
}
