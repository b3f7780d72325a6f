//! Kill and resume: a run that stops in the middle of an epoch and goes on from its last
//! checkpoint ends exactly as the uninterrupted run does (metrics, logs, networks and
//! the whole training state).

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_rl::config::RunConfig;
use foosball_rl::nets::Backend;
use foosball_rl::nets::Snapshot;
use foosball_rl::run::train::{Event, Start, train};
use std::path::Path;
use std::process::{Child, Command, Stdio};

fn config(algo: &str, epochs: u32, steps_per_epoch: u64) -> RunConfig {
    let text = tiny_config_text(algo, epochs, steps_per_epoch);
    RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap()
}

/// Image observations (12 x 20 grey, 2 frames) and a one-layer CNN for `algo`.
fn on_pixels(algo: &str) -> String {
    format!(
        "[env.observation]\nkind = \"image\"\nwidth = 12\nheight = 20\nframe_stack = 2\n\
         [{algo}.net.cnn]\nconvs = [{{ channels = 4, kernel = 3, stride = 2 }}]\nfeatures = 16\n"
    )
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `scalars.csv` without the wall-clock rows (`time/...`).
fn scalars(run: &Path) -> String {
    String::from_utf8(read(&run.join("scalars.csv")))
        .unwrap()
        .lines()
        .filter(|l| !l.contains(",time/"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The training state of a run's checkpoint, less the log files' lengths (the
/// wall-clock rows of `scalars.csv` differ in length from run to run).
fn training_state(run: &Path) -> Snapshot<'static> {
    let mut state = Snapshot::read(&run.join("checkpoint/state.bin")).unwrap();
    assert!(state.contains("loop.log_bytes"));
    state.put_u64s("loop.log_bytes", vec![]);
    state
}

/// The two runs end the same: test results, logs, and the whole training state
/// (parameters follow from it: the optimisers' moments record every gradient, and the
/// test trajectories every action). Network files are not compared byte for byte: Burn
/// gives parameters a fresh random id in each process and writes it in the record.
fn assert_same_run(a: &Path, b: &Path, label: &str) {
    for file in [
        "test/metrics.json",
        "test/trajectories.bin",
        "episodes.csv",
        "evaluations.csv",
    ] {
        assert!(
            read(&a.join(file)) == read(&b.join(file)),
            "{label}: {file} differs"
        );
    }
    if a.join("pool").exists() {
        assert!(
            read(&a.join("pool/pool.json")) == read(&b.join("pool/pool.json")),
            "{label}: the self-play records differ"
        );
    }
    assert_eq!(scalars(a), scalars(b), "{label}: scalars.csv differs");
    assert!(
        training_state(a) == training_state(b),
        "{label}: the training state differs"
    );
}

/// Trains `algo` (its config text followed by `extra`) straight through, and again
/// stopped at its evaluation at env step 200 (in epoch 2 of 3, after the epoch-1
/// checkpoint, with epoch-2 logs and best networks already written) and resumed; the two
/// must end the same. `extra` is appended to the config text; `backend` set when given.
fn stopped_mid_epoch_and_resumed(algo: &str, extra: &str, backend: Option<Backend>) {
    let name = backend.map_or(String::new(), |b| b.to_string());
    let text = tiny_config_text(algo, 3, 150) + extra;
    stopped_and_resumed(&format!("{algo}{}{name}", extra.len()), &text, backend);
}

/// The run `text` (3 epochs of 150 env steps, evaluated at step 200), stopped at that
/// evaluation and resumed, ends as it does uninterrupted; scratch directory `resume-{name}`.
pub fn stopped_and_resumed(name: &str, text: &str, backend: Option<Backend>) {
    let dir = scratch(&format!("resume-{name}"));
    let mut c = RunConfig::from_toml(text, Path::new("tiny.toml")).unwrap();
    c.protocol.backend = backend;
    let straight = dir.join("straight");
    let broken = dir.join("broken");
    for run in [&straight, &broken] {
        std::fs::create_dir_all(run).unwrap();
    }
    train(&c, &straight, Start::Fresh, |_| {}).unwrap();
    let stopped = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        train(&c, &broken, Start::Fresh, |p| {
            if matches!(p.event, Event::Evaluation { .. }) && p.env_steps == 200 {
                panic!("stopped at env step 200");
            }
        })
    }));
    assert!(stopped.is_err(), "{name}: the run was not stopped");
    assert!(!broken.join("test").exists());
    let evals = std::fs::read_to_string(broken.join("evaluations.csv")).unwrap();
    assert_eq!(
        evals.lines().count(),
        1 + 2,
        "{name}: logged past the checkpoint"
    );
    train(&c, &broken, Start::Resume, |_| {}).unwrap();
    assert_same_run(&straight, &broken, name);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_ppo_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("ppo", "", None);
}

#[test]
fn a_ppo_run_on_the_host_path_stopped_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("ppo", "", Some(Backend::Host));
}

/// The running moments of `[normalize]` (observations, returns, each env's return so far)
/// are part of the checkpoint.
#[test]
fn a_normalised_ppo_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("ppo", "[normalize]\n", Some(Backend::Host));
}

/// PPO's self-imitation (its kept rows, the episodes being played, its draws) is part of
/// the checkpoint.
#[test]
fn a_self_imitating_ppo_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    let sil = "[ppo.self_imitation]\ncoef = 1.0\nbatch_size = 16\ncapacity = 64\nupdates = 2\n";
    stopped_mid_epoch_and_resumed("ppo", sil, Some(Backend::Host));
}

/// A kickstarted PPO's teacher labels (the rollout's column) and DAgger's aggregate of
/// them (`keep`, full and overwriting its oldest rows by the stop) are part of the
/// checkpoint.
#[test]
fn a_kickstarted_ppo_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    let kickstart = "[ppo.kickstart]\nteacher = \"shooter\"\ncoef_start = 2.0\n";
    stopped_mid_epoch_and_resumed("ppo", kickstart, Some(Backend::Host));
    let aggregate = format!("{kickstart}keep = 100\nupdates = 3\n");
    stopped_mid_epoch_and_resumed("ppo", &aggregate, Some(Backend::Host));
}

#[test]
fn a_sac_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("sac", "", None);
}

#[test]
fn a_sac_run_on_the_host_path_stopped_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("sac", "", Some(Backend::Host));
}

/// The replay buffer's image planes (stored once each, shared between rows) are saved
/// and restored with the rest of the training state.
#[test]
fn a_sac_run_on_pixels_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("sac", &on_pixels("sac"), None);
}

/// The interactive teacher's rounds and labels are part of the checkpoint (`demo_share`
/// lands in `[sac.off_policy]`, the tiny text's last table).
#[test]
fn a_sac_run_with_the_interactive_teacher_stopped_and_resumed_ends_as_the_uninterrupted_one() {
    let teacher = "demo_share = 0.5\n[sac]\nbc_weight = 0.4\n[dagger]\nevery = 75\nepisodes = 2\n\
                   [dagger.planner]\npopulation = 16\nelites = 4\niterations = 4\n\
                   max_rollout_steps = 30\n";
    stopped_mid_epoch_and_resumed("sac", teacher, None);
}

/// PPO cloning the teacher's labels in self-play with normalised observations: the
/// labels handed again after the resume are normalised with the checkpoint's moments and
/// not merged into them twice (`Normalized`'s count of the episodes merged).
#[test]
fn a_ppo_self_play_run_with_the_teacher_and_normalisation_stopped_and_resumed_ends_as_the_uninterrupted_one()
 {
    let teacher = "[ppo.demonstrations]\nbatch_size = 16\nupdates = 2\n[normalize]\n\
                   [self_play]\nsnapshot_every = 60\npool_size = 3\n\
                   [dagger]\nevery = 75\nepisodes = 2\n[dagger.planner]\npopulation = 16\n\
                   elites = 4\niterations = 4\nmax_rollout_steps = 30\n";
    stopped_mid_epoch_and_resumed("ppo", teacher, None);
}

#[test]
fn a_td3_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("td3", "", None);
}

#[test]
fn a_td3_run_on_the_host_path_stopped_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed("td3", "", Some(Backend::Host));
}

/// Self-play: the pool (snapshots at steps 0, 60, ..., records) is part of the checkpoint;
/// the environments' opponents are drawn again as the uninterrupted run drew them.
#[test]
fn a_self_play_run_stopped_mid_epoch_and_resumed_ends_as_the_uninterrupted_one() {
    stopped_mid_epoch_and_resumed(
        "sac",
        "[self_play]\nsnapshot_every = 60\npool_size = 3\n",
        None,
    );
}

#[test]
fn resuming_without_a_checkpoint_is_refused() {
    let dir = scratch("resume-none");
    let c = config("sac", 1, 150);
    let err = train(&c, &dir, Start::Resume, |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("no checkpoint"), "{err}");
    assert!(err.contains(dir.to_str().unwrap()), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Trains a tiny SAC run with the `train` binary straight through, and again stopped by
/// `stop` once its first checkpoint is written, then resumed with `train --resume`: the
/// two end the same. Returns what the stopped process wrote on stderr.
fn train_stopped_then_resumed(name: &str, stop: impl FnOnce(&mut Child, &Path)) -> String {
    let dir = scratch(name);
    let config_path = dir.join("sac.toml");
    std::fs::write(&config_path, tiny_config_text("sac", 3, 1500)).unwrap();
    let train_bin = env!("CARGO_BIN_EXE_train");
    let (straight, stopped) = (dir.join("straight"), dir.join("stopped"));
    let args = |out: &Path| {
        let mut cmd = Command::new(train_bin);
        cmd.args(["--config", config_path.to_str().unwrap()])
            .args(["--out", out.to_str().unwrap()])
            .stdout(Stdio::null());
        cmd
    };
    assert!(args(&straight).status().unwrap().success());

    let mut child = args(&stopped).stderr(Stdio::piped()).spawn().unwrap();
    let state = stopped.join("checkpoint/state.bin");
    while !state.exists() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "ended before a checkpoint"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    stop(&mut child, &stopped);
    let o = child.wait_with_output().unwrap();
    assert!(!stopped.join("test").exists(), "stopped after the end");
    let o2 = Command::new(train_bin)
        .args(["--resume", stopped.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        o2.status.success(),
        "{}",
        String::from_utf8_lossy(&o2.stderr)
    );
    assert_same_run(&straight, &stopped, name);

    let o2 = Command::new(train_bin)
        .args(["--resume", stopped.to_str().unwrap(), "--seed", "4"])
        .output()
        .unwrap();
    assert!(
        !o2.status.success(),
        "--resume takes its run's own settings"
    );
    std::fs::remove_dir_all(&dir).unwrap();
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn train_killed_by_a_signal_resumes_from_its_checkpoint() {
    train_stopped_then_resumed("resume-kill", |child, _| child.kill().unwrap());
}

/// SIGTERM (what SLURM sends before a kill) stops the run between two env steps with a
/// message that says where it resumes; while it runs, a second process is refused the
/// run directory by name.
#[test]
fn train_stopped_by_sigterm_says_so_and_resumes_from_its_checkpoint() {
    let stderr = train_stopped_then_resumed("resume-term", |child, run| {
        let o = Command::new(env!("CARGO_BIN_EXE_train"))
            .args(["--resume", run.to_str().unwrap()])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("another process is training this run")
                && err.contains(&format!("pid {}", child.id())),
            "{err}"
        );
        let kill = Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(2));
    });
    assert!(
        stderr.contains("stopped by a signal at env step")
            && stderr.contains("resumes from the checkpoint of epoch"),
        "{stderr}"
    );
}
