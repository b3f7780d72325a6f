//! `sweep --slurm` on a real SLURM cluster (`tools/slurm/cluster.sh up`; `.ci/run` starts
//! one): a tiny sweep submitted as a job array, one task cancelled mid-run (SIGTERM) and
//! requeued, must end with the same runs, baselines and report as the same sweep trained
//! locally; `--status` and a second submission see what is left. Without a cluster the
//! test says so and passes, except under `CI=true`, where the cluster must be up.

use crate::common;

use common::{TINY_SWEEP, scratch, sweep_results, tiny_config_text};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// Whether a SLURM cluster answers here (`sinfo` lists a usable node).
fn cluster_up() -> bool {
    let up = Command::new("sinfo")
        .args(["--noheader", "--format=%T"])
        .output()
        .is_ok_and(|o| {
            o.status.success()
                && String::from_utf8_lossy(&o.stdout)
                    .lines()
                    .any(|s| ["idle", "mixed", "allocated"].contains(&s.trim()))
        });
    assert!(
        up || std::env::var("CI").as_deref() != Ok("true"),
        "no SLURM cluster answers (`sinfo`): start one with `tools/slurm/cluster.sh up`"
    );
    if !up {
        eprintln!("skipping: no SLURM cluster here (tools/slurm/cluster.sh up starts one)");
    }
    up
}

/// Tiny PPO and SAC configurations; SAC's 6 epochs of 1,500 env steps leave time to
/// cancel it after its first checkpoint.
fn configs(dir: &Path) -> PathBuf {
    let configs = dir.join("configs");
    std::fs::create_dir_all(&configs).unwrap();
    for (algo, epochs, steps) in [("ppo", 3, 300), ("sac", 6, 1500)] {
        let text =
            tiny_config_text(algo, epochs, steps).replace("test_episodes = 3", "test_episodes = 4");
        std::fs::write(configs.join(format!("{algo}.toml")), text).unwrap();
    }
    configs
}

fn sweep(configs: &Path, out: &Path, extra: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(TINY_SWEEP)
        .arg("--configs")
        .arg(configs)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "sweep {extra:?}: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// The word after `label` in `text`.
fn word_after(text: &str, label: &str) -> String {
    text.split(label)
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .unwrap_or_else(|| panic!("nothing after `{label}` in\n{text}"))
        .to_string()
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn slurm(args: &[&str]) -> String {
    let o = Command::new(args[0]).args(&args[1..]).output().unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// What SLURM still lists of `jobs` (`JOBID_TASK STATE` lines); jobs it has forgotten
/// (`MinJobAge`) are gone.
fn listed(jobs: &[&str]) -> Vec<String> {
    let o = Command::new("squeue")
        .args([
            "--noheader",
            "--array",
            "--format=%i %T",
            "--jobs",
            &jobs.join(","),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() || err.contains("Invalid job id"),
        "squeue: {err}"
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| l.trim().to_string())
        .collect()
}

fn wait_for(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < limit, "waited {limit:?} for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_slurm_sweep_with_a_task_cancelled_and_requeued_ends_as_a_local_one() {
    if !cluster_up() {
        return;
    }
    let dir = scratch("slurm");
    let configs = configs(&dir);
    let local = dir.join("local");
    sweep(&configs, &local, &["--jobs", "2"]);

    // The dry run prints the scripts and submits nothing.
    let cluster = dir.join("cluster");
    let dry = text(&sweep(
        &configs,
        &cluster,
        &["--slurm", "--dry-run", "--sbatch=--comment=tiny"],
    ));
    assert!(
        dry.contains("#SBATCH --array=0-5") && dry.contains("#SBATCH --comment=tiny"),
        "{dry}"
    );
    assert!(!cluster.exists(), "a dry run wrote {}", cluster.display());

    let o = text(&sweep(&configs, &cluster, &["--slurm"]));
    let job = word_after(&o, "submitted array job ");
    let report_job = word_after(&o, "report job ");

    // Task 3 is sac-seed1 (runs seed-major: ppo-seed0, sac-seed0, ppo-seed1, sac-seed1,
    // then the baselines); cancel it once its first epoch is checkpointed.
    let run = cluster.join("sac-seed1");
    wait_for(
        "sac-seed1's first checkpoint",
        Duration::from_secs(240),
        || run.join("checkpoint/epochs.txt").is_file(),
    );
    assert!(
        !run.join("test").exists(),
        "sac-seed1 ended before it was cancelled"
    );
    let task = format!("{job}_3");
    slurm(&["scancel", &task]);
    wait_for("the cancelled task to end", Duration::from_secs(60), || {
        !listed(&[&job])
            .iter()
            .any(|l| l.starts_with(&format!("{task} ")))
    });
    let stopped = std::fs::read_to_string(run.join("stopped.txt")).unwrap();
    assert!(stopped.contains("stopped by a signal"), "{stopped}");
    assert!(!run.join("test").exists());

    let status = text(&sweep(&configs, &cluster, &["--status"]));
    let line = status.lines().find(|l| l.contains("sac-seed1")).unwrap();
    assert!(line.contains("stopped (resumes after epoch"), "{status}");
    // A second submission would send exactly the cancelled task.
    let dry = text(&sweep(&configs, &cluster, &["--slurm", "--dry-run"]));
    assert!(
        dry.contains("1 to submit") && dry.contains("#SBATCH --array=3\n"),
        "{dry}"
    );

    // Requeued, it resumes from its checkpoint.
    slurm(&["scontrol", "requeue", &task]);
    // A requeued task waits for its BeginTime; start it now.
    slurm(&[
        "scontrol",
        "update",
        &format!("JobId={task}"),
        "StartTime=now",
    ]);
    // Wait for the requeued task's own word first: squeue answers nothing at all for a
    // list that holds a job it has already forgotten (the report job may be), so an
    // empty listing alone does not mean that the requeued task has run.
    let log_path = cluster.join("slurm/task-3.out");
    wait_for(
        "the requeued task to finish",
        Duration::from_secs(600),
        || std::fs::read_to_string(&log_path).is_ok_and(|l| l.contains("sac-seed1: finished")),
    );
    wait_for(
        "every task and the report",
        Duration::from_secs(600),
        || listed(&[&job, &report_job]).is_empty(),
    );
    let log = std::fs::read_to_string(&log_path).unwrap();
    assert!(
        log.contains("stopped by a signal") && log.contains("sac-seed1: finished"),
        "{log}"
    );
    let resumed_at = log.lines().filter(|l| l.ends_with("] started")).nth(1);
    assert!(
        resumed_at.is_some_and(|l| !l.starts_with("[0/")),
        "the requeued task did not resume from its checkpoint:\n{log}"
    );

    let (want, got) = (sweep_results(&local), sweep_results(&cluster));
    for ((name, a), (_, b)) in want.iter().zip(&got) {
        assert!(
            a == b,
            "{name} differs between the local and the SLURM sweep"
        );
    }
    let report = |out: &Path| std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert_eq!(report(&local), report(&cluster), "the reports differ");
    let status = text(&sweep(&configs, &cluster, &["--status"]));
    assert_eq!(
        status.lines().filter(|l| l.contains(" done: ")).count(),
        6,
        "{status}"
    );
    let again = text(&sweep(&configs, &cluster, &["--slurm"]));
    assert!(
        again.contains("6 finished, 0 queued or running, 0 to submit"),
        "{again}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
