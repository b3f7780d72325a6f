//! Helpers shared by the modules of the integration tests.

use foosball_rl::env::geometry::BALL_RADIUS;
use foosball_rl::env::layout::ACTION_DIM;
use foosball_rl::env::{Env, FoosballConfig, FoosballEnv, FoosballInfo, Transition};
use std::path::{Path, PathBuf};

/// The reference data folder `../shared/reference/<name>` beside the checkout, or `None`
/// (with a note) where it is absent outside CI. Under `CI=true` it must exist.
pub fn reference_file(name: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference")
        .join(name);
    if path.exists() {
        return Some(path);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "reference file {} is missing",
        path.display()
    );
    eprintln!("skipping: reference file {} is not here", path.display());
    None
}

/// A run configuration for `algo` small enough to train in about a second: 16-wide
/// networks, `epochs` epochs of `steps_per_epoch` env steps on two envs, evaluations every
/// 100 steps on 2 episodes, a 3-episode test.
pub fn tiny_config_text(algo: &str, epochs: u32, steps_per_epoch: u64) -> String {
    let section = match algo {
        "ppo" => "[ppo]\nn_steps = 64\nbatch_size = 32\nn_epochs = 2\n[ppo.net]\nhidden = [16]\n",
        _ => "[ALGO.net]\nhidden = [16]\n[ALGO.off_policy]\nbuffer_size = 1000\nlearning_starts = 50\nbatch_size = 32\n",
    }
    .replace("ALGO", algo);
    format!(
        "algo = \"{algo}\"\n[protocol]\nseed = 3\nepochs = {epochs}\nsteps_per_epoch = {steps_per_epoch}\n\
         eval_every = 100\neval_episodes = 2\ntest_episodes = 3\nenvs = 2\n[env]\nmax_episode_steps = 30\n{section}"
    )
}

/// An empty scratch directory for test `name`, removed with everything in it when the
/// guard drops (a failing test leaves it: a panic skips the removal, so it can be read).
pub fn scratch(name: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("foosball-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    Scratch(dir)
}

/// A scratch directory (see [`scratch`]); derefs to its path.
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Neutral commands: every rod held at its centre, feet down.
pub const NEUTRAL: [f32; ACTION_DIM] = [0.0; ACTION_DIM];

/// An environment of `config` after `reset(Some(1))`.
pub fn env_with(config: FoosballConfig) -> FoosballEnv {
    let mut env = FoosballEnv::new(config).unwrap();
    env.reset(Some(1));
    env
}

/// A fresh episode with the ball placed at `xy` moving at `v` (cm/s).
pub fn placed(config: FoosballConfig, xy: [f32; 2], v: [f32; 2]) -> FoosballEnv {
    let mut env = env_with(config);
    env.table_mut()
        .unwrap()
        .set_ball([xy[0], xy[1], BALL_RADIUS], [v[0], v[1], 0.0]);
    env
}

/// Steps with neutral actions until the episode ends (at most `limit` steps).
pub fn play_out(env: &mut FoosballEnv, limit: usize) -> Vec<Transition<FoosballInfo>> {
    let mut out = Vec::new();
    for _ in 0..limit {
        let (_, t) = env.step(&NEUTRAL).unwrap();
        let done = t.done();
        out.push(t);
        if done {
            break;
        }
    }
    out
}

/// The tiny sweep's arguments: PPO and SAC, seeds 0 and 1, two baselines.
pub const TINY_SWEEP: [&str; 6] = [
    "--algos",
    "ppo,sac",
    "--seeds",
    "0..2",
    "--baselines",
    "shooter,zero",
];

/// The files that define the results of the tiny sweep of PPO and SAC x seeds 0, 1 with
/// the shooter and zero baselines (logs without timings, metrics, trajectories), by name.
pub fn sweep_results(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    for run in ["ppo-seed0", "ppo-seed1", "sac-seed0", "sac-seed1"] {
        for f in [
            "episodes.csv",
            "evaluations.csv",
            "test/metrics.json",
            "test/trajectories.bin",
        ] {
            files.push(format!("{run}/{f}"));
        }
    }
    files.push("shooter-reference/metrics.json".into());
    files.push("zero-reference/metrics.json".into());
    files
        .into_iter()
        .map(|f| {
            let path = out.join(&f);
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            (f, bytes)
        })
        .collect()
}

/// Every file under `dir` (recursively, sorted) whose name ends in `.{ext}`, skipping the
/// folders named in `skip`.
pub fn files_under(dir: &Path, ext: &str, skip: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                if !skip
                    .iter()
                    .any(|s| path.file_name().is_some_and(|n| n == *s))
                {
                    stack.push(path);
                }
            } else if path.extension().is_some_and(|e| e == ext) {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}
