//! The training logs of a run: CSV files, and TensorBoard event files holding the same
//! scalars.
//!
//! Every [`crate::run::protocol::LOG_EVERY`] env steps (and at each epoch end) one window of
//! training is summarised under these tags, in `scalars.csv` (`env_step,tag,value`) and
//! in `RUN/tensorboard/`:
//!
//! | tag | value over the window |
//! | --- | --- |
//! | `rollout/ep_return_mean`, `rollout/ep_length_mean`, `rollout/score_rate`, `rollout/episodes` | training episodes that ended |
//! | `rollout/end_<reason>` | share of those episodes that ended for `<reason>` (scored, conceded, stagnant, no_progress, time_limit, physics_fault, spin_foul) |
//! | `rollout/spins_per_minute` | spins of the learner's rods ([`foosball_env::spin`]) per minute of those episodes' play |
//! | `train/<name>` | the algorithm's metrics (losses, entropy, alpha, ...), averaged |
//! | `time/steps_per_second`, `time/updates_per_second` | env steps and gradient steps per second |
//!
//! Each evaluation adds `eval/<metric>` (the test metrics of its episodes) and
//! `eval/end_<reason>` there and a
//! row to `evaluations.csv`; each training episode is a row of `episodes.csv`.

use crate::files::{RunFileError, append_csv};
use crate::play::metrics::{TestMetrics, end_shares};
use foosball_algos::{Episode, Metrics};
use foosball_env::{EndReason, FoosballInfo};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tensorboard_proto::event::{Event, SessionLog, SessionLog_SessionStatus};
use tensorboard_rs::summary::scalar;
use tensorboard_rs::summary_writer::FileWriter;

/// The append-only CSV files of a run, in the order their lengths are checkpointed.
pub const CSV_FILES: [&str; 3] = ["episodes.csv", "evaluations.csv", "scalars.csv"];

const EPISODES_HEADER: &str = "env_step,return,length,scored,end";
const SCALARS_HEADER: &str = "env_step,tag,value";

/// Training speed over one logging window (or, in [`super::progress::Event::Tick`], since the
/// process started training).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Speed {
    /// Env steps per second.
    pub steps_per_second: f64,
    /// Gradient steps per second.
    pub updates_per_second: f64,
}

/// One row of `evaluations.csv`: the env step and the mean metrics of an evaluation's
/// episodes. The one schema its writer and its readers share; readers go by column name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvaluationRow {
    /// Env steps done when the evaluation ran.
    pub env_step: u64,
    /// The metrics, in [`EvaluationRow::METRICS`] order.
    pub values: [f64; 6],
}

impl EvaluationRow {
    /// Metric columns after `env_step` (also the `eval/<name>` TensorBoard tags).
    pub const METRICS: [&'static str; 6] = [
        "mean_return",
        "score_rate",
        "mean_goal_distance",
        "mean_ball_speed",
        "mean_final_distance",
        "mean_length",
    ];

    /// The row of an evaluation at `env_step`.
    pub fn new(env_step: u64, m: &TestMetrics) -> Self {
        let values = [
            m.mean_return.mean,
            m.score_rate.mean,
            m.mean_goal_distance.mean,
            m.mean_ball_speed.mean,
            m.mean_final_distance.mean,
            m.mean_length.mean,
        ];
        Self { env_step, values }
    }

    /// The header line.
    pub fn header() -> String {
        std::iter::once("env_step")
            .chain(Self::METRICS)
            .collect::<Vec<_>>()
            .join(",")
    }

    /// The CSV line.
    pub fn line(&self) -> String {
        std::iter::once(self.env_step.to_string())
            .chain(self.values.iter().map(f64::to_string))
            .collect::<Vec<_>>()
            .join(",")
    }

    /// The value of metric `name` (one of [`EvaluationRow::METRICS`]).
    pub fn get(&self, name: &str) -> Option<f64> {
        Self::METRICS
            .iter()
            .position(|m| *m == name)
            .map(|k| self.values[k])
    }

    /// Reads `evaluations.csv` by its header's column names (a missing file has no rows);
    /// the error names the line or the missing column.
    pub fn read(path: &Path) -> Result<Vec<Self>, String> {
        let Ok(text) = std::fs::read_to_string(path) else {
            return Ok(Vec::new());
        };
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
        let column = |name: &str| {
            header
                .iter()
                .position(|h| *h == name)
                .ok_or_else(|| format!("no `{name}` column"))
        };
        let step = column("env_step")?;
        let metrics: Vec<usize> = Self::METRICS
            .iter()
            .map(|m| column(m))
            .collect::<Result<_, _>>()?;
        lines
            .enumerate()
            .map(|(i, line)| {
                let cols: Vec<&str> = line.split(',').collect();
                let bad = || format!("line {}: not a number", i + 2);
                let num = |k: usize| cols.get(k).and_then(|v| v.parse::<f64>().ok());
                let mut values = [0.0; 6];
                for (v, &k) in values.iter_mut().zip(&metrics) {
                    *v = num(k).ok_or_else(bad)?;
                }
                Ok(Self {
                    env_step: cols
                        .get(step)
                        .and_then(|v| v.parse().ok())
                        .ok_or_else(bad)?,
                    values,
                })
            })
            .collect()
    }
}

/// A training episode as logged.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TrainingEpisode {
    env_step: u64,
    episode: Episode,
    scored: bool,
    end: Option<EndReason>,
    spins: u32,
}

/// End-reason shares ([`crate::play::metrics::end_shares`]) as scalars `<prefix>/end_<reason>`
/// (every reason, zeros included, so the tags are the same in every window).
fn end_rows<'a>(
    prefix: &'a str,
    shares: &'a BTreeMap<String, f64>,
) -> impl Iterator<Item = (String, f64)> + 'a {
    EndReason::ALL.iter().map(move |r| {
        (
            format!("{prefix}/end_{}", r.name()),
            shares.get(r.name()).copied().unwrap_or(0.0),
        )
    })
}

/// What the training loop writes while it runs.
pub struct RunLog {
    dir: PathBuf,
    tensorboard: FileWriter,
    episodes: Vec<TrainingEpisode>,
    updates: Vec<Metrics>,
    window_start: Instant,
    window_env_steps: u64,
    window_gradient_steps: u64,
    agent_dt: f32,
}

impl RunLog {
    /// Opens `run_dir`'s logs with the CSV files cut back to `csv_bytes` (in
    /// [`CSV_FILES`] order; zeros for a fresh run) and a new TensorBoard event file. A
    /// run resumed from a checkpoint at env step `resumed_at` marks the restart there, so
    /// TensorBoard drops what the interrupted process logged after the checkpoint.
    /// `agent_dt`: seconds of play per agent step (for rates per minute).
    pub fn open(
        run_dir: &Path,
        csv_bytes: &[u64],
        resumed_at: Option<u64>,
        (env_steps, gradient_steps): (u64, u64),
        agent_dt: f32,
    ) -> Result<Self, RunFileError> {
        for (name, &len) in CSV_FILES.iter().zip(csv_bytes) {
            cut_file(&run_dir.join(name), len)?;
        }
        let tb_dir = run_dir.join("tensorboard");
        std::fs::create_dir_all(&tb_dir).map_err(RunFileError::at(&tb_dir))?;
        let mut tensorboard = FileWriter::new(&tb_dir);
        if let Some(step) = resumed_at {
            let mut log = SessionLog::new();
            log.set_status(SessionLog_SessionStatus::START);
            let mut event = Event::new();
            event.set_session_log(log);
            tensorboard.add_event(&event, step as usize);
        }
        Ok(Self {
            dir: run_dir.to_path_buf(),
            tensorboard,
            episodes: Vec::new(),
            updates: Vec::new(),
            window_start: Instant::now(),
            window_env_steps: env_steps,
            window_gradient_steps: gradient_steps,
            agent_dt,
        })
    }

    /// The CSV files' lengths now, in [`CSV_FILES`] order (0 for a file not yet made).
    pub fn csv_bytes(&self) -> Result<Vec<u64>, RunFileError> {
        CSV_FILES
            .iter()
            .map(|name| {
                let path = self.dir.join(name);
                match std::fs::metadata(&path) {
                    Ok(m) => Ok(m.len()),
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(0),
                    Err(source) => Err(RunFileError { path, source }),
                }
            })
            .collect()
    }

    /// Records a training episode that ended at env step `env_step`, its last step's
    /// `info`.
    pub fn episode(&mut self, env_step: u64, episode: Episode, info: &FoosballInfo) {
        self.episodes.push(TrainingEpisode {
            env_step,
            episode,
            scored: info.scored(),
            end: info.end,
            spins: info.spins[0],
        });
    }

    /// Records the metrics of one training round.
    pub fn update(&mut self, metrics: Metrics) {
        self.updates.push(metrics);
    }

    /// Writes the window that ends at `env_step` (after `gradient_steps` gradient steps in
    /// all) and starts the next; `None` when no env step was taken since the last window.
    pub fn end_window(
        &mut self,
        env_step: u64,
        gradient_steps: u64,
    ) -> Result<Option<Speed>, RunFileError> {
        if env_step == self.window_env_steps {
            return Ok(None);
        }
        let seconds = self.window_start.elapsed().as_secs_f64().max(1e-9);
        let speed = Speed {
            steps_per_second: (env_step - self.window_env_steps) as f64 / seconds,
            updates_per_second: (gradient_steps - self.window_gradient_steps) as f64 / seconds,
        };
        let mut rows: Vec<(String, f64)> = Vec::new();
        if !self.episodes.is_empty() {
            let n = self.episodes.len() as f64;
            let sum = |f: fn(&TrainingEpisode) -> f64| self.episodes.iter().map(f).sum::<f64>();
            rows.push(("rollout/ep_return_mean".into(), sum(|e| e.episode.ret) / n));
            rows.push((
                "rollout/ep_length_mean".into(),
                sum(|e| e.episode.len as f64) / n,
            ));
            rows.push((
                "rollout/score_rate".into(),
                sum(|e| f64::from(u8::from(e.scored))) / n,
            ));
            rows.push(("rollout/episodes".into(), n));
            let minutes = sum(|e| e.episode.len as f64) * f64::from(self.agent_dt) / 60.0;
            rows.push((
                "rollout/spins_per_minute".into(),
                sum(|e| f64::from(e.spins)) / minutes,
            ));
            let shares = end_shares(self.episodes.iter().filter_map(|e| e.end));
            rows.extend(end_rows("rollout", &shares));
        }
        for (name, value) in Metrics::mean(std::mem::take(&mut self.updates)).read() {
            rows.push((format!("train/{name}"), value));
        }
        rows.push(("time/steps_per_second".into(), speed.steps_per_second));
        rows.push(("time/updates_per_second".into(), speed.updates_per_second));
        let lines: Vec<String> = self
            .episodes
            .iter()
            .map(|e| {
                format!(
                    "{},{},{},{},{}",
                    e.env_step,
                    e.episode.ret,
                    e.episode.len,
                    u8::from(e.scored),
                    e.end.map_or("", EndReason::name)
                )
            })
            .collect();
        append_csv(&self.dir.join(CSV_FILES[0]), EPISODES_HEADER, &lines)?;
        self.scalars(env_step, &rows)?;
        self.episodes.clear();
        self.updates.clear();
        self.window_start = Instant::now();
        self.window_env_steps = env_step;
        self.window_gradient_steps = gradient_steps;
        Ok(Some(speed))
    }

    /// Writes an evaluation's metrics at `env_step`.
    pub fn evaluation(&mut self, env_step: u64, m: &TestMetrics) -> Result<(), RunFileError> {
        let row = EvaluationRow::new(env_step, m);
        append_csv(
            &self.dir.join(CSV_FILES[1]),
            &EvaluationRow::header(),
            &[row.line()],
        )?;
        let mut rows: Vec<(String, f64)> = EvaluationRow::METRICS
            .iter()
            .zip(row.values)
            .map(|(name, v)| (format!("eval/{name}"), v))
            .collect();
        rows.extend(end_rows("eval", &m.end_reasons));
        self.scalars(env_step, &rows)
    }

    fn scalars(&mut self, env_step: u64, rows: &[(String, f64)]) -> Result<(), RunFileError> {
        let lines: Vec<String> = rows
            .iter()
            .map(|(tag, v)| format!("{env_step},{tag},{v}"))
            .collect();
        append_csv(&self.dir.join(CSV_FILES[2]), SCALARS_HEADER, &lines)?;
        for (tag, v) in rows {
            self.tensorboard
                .add_summary(scalar(tag, *v as f32), env_step as usize);
        }
        self.tensorboard.flush();
        Ok(())
    }
}

/// Cuts `path` back to `len` bytes (a missing file stands for an empty one).
fn cut_file(path: &Path, len: u64) -> Result<(), RunFileError> {
    let err = RunFileError::at(path);
    let file = match std::fs::OpenOptions::new().write(true).open(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound && len == 0 => return Ok(()),
        other => other.map_err(err)?,
    };
    let have = file.metadata().map_err(err)?.len();
    if have < len {
        return Err(err(std::io::Error::other(format!(
            "holds {have} bytes but the checkpoint logged {len}"
        ))));
    }
    file.set_len(len).map_err(err)
}
