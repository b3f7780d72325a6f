//! The `sweep` binary: runs algorithms x seeds into one directory with baselines and a
//! report; a sweep killed and run again ends with the same files as an uninterrupted one;
//! a directory of another sweep and a bad seed list are refused by name.

use crate::common;

use common::{TINY_SWEEP, scratch, sweep_results, tiny_config_text};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A folder of tiny configs for PPO and SAC (3 epochs of 150 env steps each).
fn configs(dir: &Path) -> PathBuf {
    let configs = dir.join("configs");
    std::fs::create_dir_all(&configs).unwrap();
    for algo in ["ppo", "sac"] {
        let text = tiny_config_text(algo, 3, 150).replace("test_episodes = 3", "test_episodes = 4");
        std::fs::write(configs.join(format!("{algo}.toml")), text).unwrap();
    }
    configs
}

fn sweep_command(configs: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_sweep"));
    c.args(["--jobs", "2"])
        .arg("--configs")
        .arg(configs)
        .arg("--out")
        .arg(out)
        .args(extra);
    c
}

fn run(mut c: Command) -> Output {
    let o = c.output().unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

#[test]
fn a_killed_sweep_run_again_ends_as_an_uninterrupted_one() {
    let dir = scratch("sweep");
    let configs = configs(&dir);
    let whole = dir.join("whole");
    let o = run(sweep_command(&configs, &whole, &TINY_SWEEP));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("4 runs (0 finished, 4 to train or resume)"),
        "{text}"
    );
    let md = std::fs::read_to_string(whole.join("report/report.md")).unwrap();
    for label in [
        "ppo reference* 16 (2 runs)",
        "sac reference* 16 (2 runs)",
        "shooter reference* (1 run)",
    ] {
        assert!(md.contains(label), "{label} missing from\n{md}");
    }
    assert!(md.contains("# The paper's claims"));

    // Kill a second sweep once its first checkpoint is written, then run it again.
    let killed = dir.join("killed");
    let mut child = sweep_command(&configs, &killed, &TINY_SWEEP)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !killed.join("ppo-seed0/checkpoint/state.bin").exists()
        && !killed.join("sac-seed0/checkpoint/state.bin").exists()
    {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no checkpoint written"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let o = run(sweep_command(&configs, &killed, &TINY_SWEEP));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("to train or resume"), "{text}");
    assert_eq!(sweep_results(&whole), sweep_results(&killed));

    // Once finished, the same command trains nothing.
    let o = run(sweep_command(&configs, &killed, &TINY_SWEEP));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("4 runs (4 finished, 0 to train or resume)")
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// SIGTERM stops the run in flight and starts no other: with one job, the runs after the
/// first are not started, and the sweep exits with the message
/// that says how to resume.
#[test]
fn a_sweep_stopped_by_sigterm_starts_no_further_run() {
    let dir = scratch("sweep-term");
    let configs = configs(&dir);
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(["--jobs", "1", "--configs"])
        .arg(&configs)
        .arg("--out")
        .arg(&out)
        .args(TINY_SWEEP)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !out.join("ppo-seed0/checkpoint/state.bin").exists() {
        assert!(
            start.elapsed() < Duration::from_secs(120) && child.try_wait().unwrap().is_none(),
            "no checkpoint written"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("ppo-seed0") && err.contains("stopped by a signal"),
        "{err}"
    );
    assert!(err.contains("1 run(s) failed"), "{err}");
    for run in ["sac-seed0", "ppo-seed1", "sac-seed1"] {
        assert!(
            !err.contains(run),
            "{run} was started after the signal\n{err}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn another_sweep_in_the_same_directory_and_bad_seeds_are_refused() {
    let dir = scratch("sweep-refused");
    let configs = configs(&dir);
    let out = dir.join("out");
    let one = |epochs: &'static str| {
        sweep_command(
            &configs,
            &out,
            &[
                "--epochs",
                epochs,
                "--algos",
                "ppo",
                "--seeds",
                "0",
                "--no-baselines",
            ],
        )
    };
    run(one("1"));
    let entries: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| !n.ends_with(".toml") && n != "report")
        .collect();
    assert_eq!(entries, ["ppo-seed0"], "--no-baselines tests no baseline");
    let o = one("2").output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("holds a sweep of another configuration") && err.contains("--force"),
        "{err}"
    );
    let o = sweep_command(&configs, &out, &["--seeds", "3..1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--seeds `3..1`"));
    let o = sweep_command(&configs, &out, &["--baselines", "zero", "--no-baselines"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--no-baselines"));
}
