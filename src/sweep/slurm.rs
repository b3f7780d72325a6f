//! A sweep as a SLURM job array: the batch scripts, their submission and what the
//! scheduler says of them.
//!
//! `sweep --slurm` writes `OUT/slurm/tasks.sbatch`, an array with one task per
//! unfinished run or baseline ([`super::Task`], indexed as [`super::SweepSpec::tasks`]
//! orders them), and `OUT/slurm/report.sbatch`, the report, submitted to run after the
//! array whatever its tasks' fate (`afterany`). Each task runs `sweep --task I`: it trains
//! its run into its own run directory, resuming from the run's checkpoint when there is
//! one, so a requeued or preempted task loses at most its epoch in flight; SLURM's SIGTERM
//! stops it between two env steps ([`crate::run::interrupt`]). Every submission is
//! recorded in `OUT/slurm/jobs.toml`, which [`queued`] and `sweep --status` read back.

use crate::files::write_atomic;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The folder of a sweep's SLURM files.
pub const SLURM_DIR: &str = "slurm";

/// What the batch scripts ask of the scheduler.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SlurmOptions {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--time` of each task (`[D-]HH:MM:SS` or minutes).
    pub time: Option<String>,
    /// `--cpus-per-task`; each run trains with this many threads.
    pub cpus_per_task: usize,
    /// More `#SBATCH` lines, without the `#SBATCH ` prefix (e.g. `--qos=long`).
    pub extra: Vec<String>,
}

/// A SLURM command that failed or a SLURM file that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SlurmError {
    /// A scheduler command could not be run or refused.
    #[error("`{command}`: {message}")]
    Command {
        /// The command line.
        command: String,
        /// What it said.
        message: String,
    },
    /// A file of `OUT/slurm/` could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// One submission of a sweep: the array job, its task indices and the report job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Submission {
    /// Job id of the array.
    pub array_job: String,
    /// Its task indices.
    pub tasks: Vec<usize>,
    /// Job id of the report that runs after it.
    pub report_job: String,
}

/// `OUT/slurm/jobs.toml`: every submission of the sweep, oldest first.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Submissions {
    /// The submissions.
    #[serde(default)]
    pub submissions: Vec<Submission>,
}

impl Submissions {
    fn path(out: &Path) -> PathBuf {
        out.join(SLURM_DIR).join("jobs.toml")
    }

    /// The sweep's record (empty when it was never submitted).
    pub fn read(out: &Path) -> Result<Self, SlurmError> {
        let path = Self::path(out);
        match std::fs::read_to_string(&path) {
            Ok(text) => toml::from_str(&text).map_err(|e| SlurmError::File {
                path,
                message: e.to_string(),
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(e) => Err(SlurmError::File {
                path,
                message: e.to_string(),
            }),
        }
    }

    /// Adds `s` and rewrites the record atomically.
    pub fn push(out: &Path, s: Submission) -> Result<(), SlurmError> {
        let mut all = Self::read(out)?;
        all.submissions.push(s);
        let path = Self::path(out);
        let text = toml::to_string_pretty(&all).expect("submissions always serialise");
        write_atomic(&path, text.as_bytes()).map_err(|e| SlurmError::File {
            path,
            message: e.source.to_string(),
        })
    }

    /// Every job id recorded (arrays and reports).
    pub fn job_ids(&self) -> Vec<String> {
        self.submissions
            .iter()
            .flat_map(|s| [s.array_job.clone(), s.report_job.clone()])
            .collect()
    }
}

/// SLURM's compact form of task indices: `0-3,5,7-8`.
pub fn array_spec(tasks: &[usize]) -> String {
    let mut sorted = tasks.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut parts = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i;
        while j + 1 < sorted.len() && sorted[j + 1] == sorted[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            sorted[i].to_string()
        } else {
            format!("{}-{}", sorted[i], sorted[j])
        });
        i = j + 1;
    }
    parts.join(",")
}

/// Single-quotes `text` for bash.
fn quoted(text: &Path) -> String {
    format!("'{}'", text.display().to_string().replace('\'', r"'\''"))
}

/// The `#SBATCH` header shared by both scripts.
fn header(name: &str, output: &Path, workdir: &Path, o: &SlurmOptions) -> String {
    let mut lines = vec![
        "#!/bin/bash".to_string(),
        format!("#SBATCH --job-name={name}"),
        format!("#SBATCH --chdir={}", workdir.display()),
        format!("#SBATCH --output={}", output.display()),
        "#SBATCH --open-mode=append".into(),
        format!("#SBATCH --cpus-per-task={}", o.cpus_per_task.max(1)),
    ];
    for (key, value) in [
        ("partition", &o.partition),
        ("account", &o.account),
        ("time", &o.time),
    ] {
        if let Some(v) = value {
            lines.push(format!("#SBATCH --{key}={v}"));
        }
    }
    lines.extend(o.extra.iter().map(|l| format!("#SBATCH {l}")));
    lines.join("\n")
}

/// The array job: task `I` runs `sweep --task I` on `out` with `cpus_per_task` threads.
/// `exe` is the `sweep` binary, `out` and `workdir` absolute paths.
pub fn tasks_script(
    exe: &Path,
    out: &Path,
    workdir: &Path,
    tasks: &[usize],
    o: &SlurmOptions,
) -> String {
    format!(
        "{}\n#SBATCH --array={}\n#SBATCH --requeue\n\
         # One task per unfinished run or baseline of the sweep in {out_shown} (written by `sweep --slurm`).\n\
         # A task resumes its run from the last checkpoint; SIGTERM stops it between two env steps.\n\
         exec {} --out {} --task \"$SLURM_ARRAY_TASK_ID\" --threads-per-run {}\n",
        header(
            "foosball-sweep",
            &out.join(SLURM_DIR).join("task-%a.out"),
            workdir,
            o
        ),
        array_spec(tasks),
        quoted(exe),
        quoted(out),
        o.cpus_per_task.max(1),
        out_shown = out.display(),
    )
}

/// The report job (submitted to run after the array): `sweep --report-only` on `out`.
pub fn report_script(exe: &Path, out: &Path, workdir: &Path, o: &SlurmOptions) -> String {
    let o = SlurmOptions {
        cpus_per_task: 1,
        ..o.clone()
    };
    format!(
        "{}\n# The sweep's report, after its tasks (written by `sweep --slurm`).\n\
         exec {} --out {} --report-only\n",
        header(
            "foosball-sweep-report",
            &out.join(SLURM_DIR).join("report.out"),
            workdir,
            &o
        ),
        quoted(exe),
        quoted(out),
    )
}

fn command_error(command: &Command, message: String) -> SlurmError {
    let line = std::iter::once(command.get_program())
        .chain(command.get_args())
        .map(|a| a.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ");
    SlurmError::Command {
        command: line,
        message,
    }
}

/// Runs `command` and returns its standard output.
fn output(mut command: Command) -> Result<String, SlurmError> {
    let o = command.output().map_err(|e| {
        let why = if e.kind() == std::io::ErrorKind::NotFound {
            "not found: is this a SLURM login node (sbatch and squeue on PATH)?".to_string()
        } else {
            e.to_string()
        };
        command_error(&command, why)
    })?;
    if !o.status.success() {
        let message = String::from_utf8_lossy(&o.stderr).trim().to_string();
        return Err(command_error(&command, format!("{}: {message}", o.status)));
    }
    Ok(String::from_utf8_lossy(&o.stdout).into_owned())
}

/// Submits `script` (`sbatch --parsable`), after job `after` ends in any state when given;
/// returns the job id.
pub fn submit(script: &Path, after: Option<&str>) -> Result<String, SlurmError> {
    let mut c = Command::new("sbatch");
    c.arg("--parsable");
    if let Some(job) = after {
        c.arg(format!("--dependency=afterany:{job}"));
    }
    c.arg(script);
    let text = output(c)?;
    // `--parsable` prints `id` or `id;cluster`.
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(SlurmError::Command {
            command: format!("sbatch --parsable {}", script.display()),
            message: format!("no job id in its answer `{}`", text.trim()),
        });
    }
    Ok(id)
}

/// What the scheduler says of the tasks of the sweep in `out` (its recorded submissions)
/// that it still knows (pending, running, requeued...): task index -> (`JOB_TASK`, state,
/// reason). A task submitted twice takes the latest submission's. Jobs SLURM has
/// forgotten (`MinJobAge`) are absent; a sweep never submitted asks nothing of SLURM.
pub fn queued(out: &Path) -> Result<BTreeMap<usize, (String, String, String)>, SlurmError> {
    let submissions = Submissions::read(out)?;
    let arrays: Vec<&str> = submissions
        .submissions
        .iter()
        .map(|s| s.array_job.as_str())
        .collect();
    let mut states = BTreeMap::new();
    if arrays.is_empty() {
        return Ok(states);
    }
    let mut c = Command::new("squeue");
    c.args(["--noheader", "--array", "--format=%i|%T|%r", "--jobs"])
        .arg(arrays.join(","));
    let text = match output(c) {
        Ok(text) => text,
        // squeue refuses a list of only unknown (finished and forgotten) jobs.
        Err(SlurmError::Command { message, .. }) if message.contains("Invalid job id") => {
            String::new()
        }
        Err(e) => return Err(e),
    };
    let order = |job: &str| arrays.iter().position(|a| *a == job);
    let mut rows: Vec<(usize, usize, String, String, String)> = text
        .lines()
        .filter_map(|line| {
            let mut f = line.trim().split('|');
            let id = f.next()?.to_string();
            let (job, task) = id.split_once('_')?;
            let task = task.parse::<usize>().ok()?;
            Some((
                order(job)?,
                task,
                id.clone(),
                f.next()?.to_string(),
                f.next()?.to_string(),
            ))
        })
        .collect();
    rows.sort();
    for (_, task, id, state, reason) in rows {
        states.insert(task, (id, state, reason));
    }
    Ok(states)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task_lists_are_compacted_into_ranges() {
        assert_eq!(array_spec(&[0, 1, 2, 3, 5, 7, 8]), "0-3,5,7-8");
        assert_eq!(array_spec(&[4]), "4");
        assert_eq!(array_spec(&[9, 2, 3, 2]), "2-3,9");
    }

    #[test]
    fn the_scripts_name_the_binary_the_sweep_and_the_scheduler_options() {
        let o = SlurmOptions {
            partition: Some("gpu".into()),
            account: None,
            time: Some("12:00:00".into()),
            cpus_per_task: 2,
            extra: vec!["--qos=long".into()],
        };
        let s = tasks_script(
            Path::new("/opt/bin/sweep"),
            Path::new("/data/it's"),
            Path::new("/data"),
            &[0, 1, 4],
            &o,
        );
        for line in [
            "#SBATCH --array=0-1,4",
            "#SBATCH --requeue",
            "#SBATCH --partition=gpu",
            "#SBATCH --time=12:00:00",
            "#SBATCH --cpus-per-task=2",
            "#SBATCH --qos=long",
            "#SBATCH --output=/data/it's/slurm/task-%a.out",
            "exec '/opt/bin/sweep' --out '/data/it'\\''s' --task \"$SLURM_ARRAY_TASK_ID\" --threads-per-run 2",
        ] {
            assert!(s.lines().any(|l| l == line), "{line} not in\n{s}");
        }
        assert!(!s.contains("--account"));
        let r = report_script(Path::new("/b/sweep"), Path::new("/o"), Path::new("/"), &o);
        assert!(
            r.contains("exec '/b/sweep' --out '/o' --report-only"),
            "{r}"
        );
        assert!(
            r.contains("#SBATCH --cpus-per-task=1") && !r.contains("--array"),
            "{r}"
        );
    }
}
