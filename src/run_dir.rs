//! The files of a run directory, written atomically ([`foosball_nets::atomic_file`]) but
//! for the append-only CSV logs, which a resume cuts back to its checkpoint.
//!
//! ```text
//! RUN/config.toml          effective configuration
//! RUN/episodes.csv         env_step,return,length,scored,end  (training episodes)
//! RUN/evaluations.csv      env_step and the mean metrics ([`crate::run_log::EvaluationRow`])
//! RUN/scalars.csv          env_step,tag,value                 (every TensorBoard scalar)
//! RUN/tensorboard/         TensorBoard event files
//! RUN/last/, RUN/best/     networks (Burn records) after the last epoch / best evaluation
//! RUN/test/metrics.json    the paper's five metrics with 95 % intervals
//! RUN/test/metrics.md      the same as a markdown table
//! RUN/test/trajectories.bin  every test episode's steps (format below)
//! ```
//!
//! `trajectories.bin`, little-endian: magic `FSBT`, `u32` version 1, `u32` obs_dim,
//! `u32` action_dim, `u64` episodes; then per episode `u64` seed, `u32` steps T,
//! `f32` observations `[T, obs_dim]`, `f32` actions `[T, action_dim]`, `f32` rewards `[T]`.

use crate::evaluation::PlayedEpisode;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file of the run that could not be written or read.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct RunFileError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub source: std::io::Error,
}

impl RunFileError {
    /// The error constructor for `path`, for `map_err`.
    pub fn at(path: &Path) -> impl Fn(std::io::Error) -> Self + Copy + '_ {
        move |source| Self {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Writes `bytes` to `path` atomically (creating its directory), so a crash leaves either
/// the old file or the new one ([`foosball_nets::atomic_file`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RunFileError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(RunFileError::at(path))?;
    }
    foosball_nets::atomic_file::write_atomic(path, bytes).map_err(RunFileError::at(path))
}

/// Appends lines to a CSV file, writing the header first when the file is new or empty;
/// no lines, no I/O.
pub fn append_csv(path: &Path, header: &str, lines: &[String]) -> Result<(), RunFileError> {
    if lines.is_empty() {
        return Ok(());
    }
    let err = RunFileError::at(path);
    let new = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(err)?;
    let mut text = String::new();
    if new {
        text.push_str(header);
        text.push('\n');
    }
    for line in lines {
        text.push_str(line);
        text.push('\n');
    }
    file.write_all(text.as_bytes()).map_err(err)
}

/// The `trajectories.bin` bytes of `episodes` (recorded ones only).
pub fn trajectories_bytes(
    episodes: &[PlayedEpisode],
    obs_dim: usize,
    action_dim: usize,
) -> Vec<u8> {
    let recorded: Vec<&PlayedEpisode> =
        episodes.iter().filter(|e| e.trajectory.is_some()).collect();
    let mut out = Vec::new();
    out.extend_from_slice(b"FSBT");
    out.extend_from_slice(&1u32.to_le_bytes());
    out.extend_from_slice(&(obs_dim as u32).to_le_bytes());
    out.extend_from_slice(&(action_dim as u32).to_le_bytes());
    out.extend_from_slice(&(recorded.len() as u64).to_le_bytes());
    for e in recorded {
        let t = e.trajectory.as_ref().expect("filtered");
        out.extend_from_slice(&e.seed.to_le_bytes());
        out.extend_from_slice(&(t.rewards.len() as u32).to_le_bytes());
        for x in t.obs.iter().chain(&t.actions).chain(&t.rewards) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// One episode read back from `trajectories.bin`.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedEpisode {
    /// The seed it was reset with.
    pub seed: u64,
    /// Its steps.
    pub trajectory: crate::evaluation::Trajectory,
}

impl RecordedEpisode {
    /// Its undiscounted return.
    pub fn ret(&self) -> f64 {
        self.trajectory.rewards.iter().map(|&r| f64::from(r)).sum()
    }

    /// Whether the ball was seen in black's goal: some observed ball y at or past
    /// `goal_line_y`, cm (the rules' `reward.goal_line_y`; foosball's 38-dim layout).
    pub fn scored(&self, goal_line_y: f32) -> bool {
        use foosball_env::layout;
        self.trajectory
            .obs
            .chunks_exact(layout::OBS_DIM)
            .any(|o| o[layout::BALL_POS.start + 1] >= goal_line_y)
    }
}

/// Indices of `episodes` from the highest return to the lowest (ties in index order).
pub fn by_return(episodes: &[RecordedEpisode]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..episodes.len()).collect();
    order.sort_by(|&a, &b| episodes[b].ret().total_cmp(&episodes[a].ret()));
    order
}

/// Reads a `trajectories.bin` written by [`trajectories_bytes`] (any observation and action
/// widths); the error says what is wrong with the file (another format or version, cut
/// short).
pub fn read_trajectories(path: &Path) -> Result<Vec<RecordedEpisode>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let fail = |what: String| format!("{}: {what}", path.display());
    let mut cursor = Cursor {
        bytes: &bytes,
        at: 0,
    };
    if cursor.take(4).map_err(&fail)? != b"FSBT" {
        return Err(fail("not a trajectories file (no FSBT magic)".into()));
    }
    let version = cursor.u32().map_err(&fail)?;
    if version != 1 {
        return Err(fail(format!(
            "format version {version}; this build reads version 1"
        )));
    }
    let obs_dim = cursor.u32().map_err(&fail)? as usize;
    let action_dim = cursor.u32().map_err(&fail)? as usize;
    let n = cursor.u64().map_err(&fail)?;
    (0..n)
        .map(|_| {
            let seed = cursor.u64()?;
            let steps = cursor.u32()? as usize;
            Ok(RecordedEpisode {
                seed,
                trajectory: crate::evaluation::Trajectory {
                    obs: cursor.f32s(steps * obs_dim)?,
                    actions: cursor.f32s(steps * action_dim)?,
                    rewards: cursor.f32s(steps)?,
                },
            })
        })
        .collect::<Result<_, String>>()
        .map_err(fail)
}

/// Little-endian reads from a byte slice; running out is an error naming the offset.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let chunk = self.bytes.get(self.at..self.at + n).ok_or_else(|| {
            format!(
                "truncated at byte {} (file of {} bytes)",
                self.at,
                self.bytes.len()
            )
        })?;
        self.at += n;
        Ok(chunk)
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    fn f32s(&mut self, n: usize) -> Result<Vec<f32>, String> {
        Ok(self
            .take(4 * n)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect())
    }
}
