//! A seed sweep: algorithms x seeds trained into one directory, several runs at a time,
//! each an ordinary run directory (`<algo>-seed<k>/`), plus the scripted baselines on
//! the same table (`<policy>-<preset>/`).
//!
//! The sweep's runs are fixed by `sweep.toml` (the seeds and each algorithm's run
//! configuration). Running the same sweep again skips finished runs, resumes the others
//! from their last checkpoint, and starts the rest; a directory holding another sweep is
//! refused unless forced. A killed sweep loses at most the unfinished epochs of the runs
//! then running.

use crate::config::{Algo, RunConfig, migrate_legacy_keys};
use crate::files::write_atomic;
use crate::play::metrics::TestMetrics;
use crate::play::scripted::{Baseline, ScriptedPolicy};
use crate::run::checkpoint;
use crate::run::train::{Progress, Start, TrainError, train};
use serde::{Deserialize, Serialize};
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
    /// The run directory name of `algo` with `seed`.
    pub fn run_name(algo: Algo, seed: u64) -> String {
        format!("{algo}-seed{seed}")
    }

    /// Takes `out` for this sweep: checks that the `sweep.toml` there, if any, is this
    /// sweep's (`force` replaces another), plans every run, then writes `sweep.toml`.
    pub fn open(&self, out: &Path, force: bool) -> Result<Vec<SweepRun>, SweepError> {
        let path = out.join("sweep.toml");
        if let Ok(old) = std::fs::read_to_string(&path)
            && !force
            && toml::from_str::<SweepSpec>(&migrate_legacy_keys(&old))
                .ok()
                .as_ref()
                != Some(self)
        {
            return Err(SweepError::Other(out.to_path_buf()));
        }
        let runs = self.plan(out, force)?;
        let text = toml::to_string_pretty(self).expect("a sweep always serialises");
        write_atomic(&path, text.as_bytes()).map_err(|e| SweepError::File {
            path: e.path,
            message: e.source.to_string(),
        })?;
        Ok(runs)
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

/// Trains `run` in its directory (created if needed).
pub fn train_run(
    run: &SweepRun,
    report: impl FnMut(&Progress) + Send,
) -> Result<Option<TestMetrics>, TrainError> {
    let Some(start) = run.start else {
        return Ok(None);
    };
    std::fs::create_dir_all(&run.dir).map_err(crate::files::RunFileError::at(&run.dir))?;
    train(&run.config, &run.dir, start, report).map(Some)
}

/// Plays `policy` on `spec`'s table (the first run's `[env]`, seed and test episodes)
/// into `out/<policy>-<preset>/`, unless it is there already; returns its directory.
pub fn baseline(
    spec: &SweepSpec,
    policy: ScriptedPolicy,
    out: &Path,
) -> Result<PathBuf, TrainError> {
    let base = &spec.runs[0];
    let dir = out.join(format!("{}-{}", policy.name(), base.env.preset.name()));
    let record = Baseline {
        policy,
        seed: spec.seeds[0],
        env: base.env.clone(),
    };
    let done =
        Baseline::read(&dir).is_ok_and(|b| b == record && dir.join("metrics.json").is_file());
    if !done {
        record.test(base.protocol.test_episodes, &dir, false)?;
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
