//! End-to-end training speed: `cargo bench --bench train_speed -- [--hidden 64,64]
//! [--steps N] [--algos sac,td3,ppo]`.
//!
//! Trains each algorithm from `configs/<algo>.toml` (the paper's protocol: one env,
//! evaluation every 3,000 env steps on 10 deterministic episodes; SAC and TD3 one update
//! per env step) with the given hidden widths, on one thread, for `--steps` env steps
//! (default 9,000) in a scratch directory, and reports env steps/s from the first 1,000
//! steps (past `learning_starts` and the first allocations) to the end of training, the
//! evaluations included and the final test left out. The figures also go to
//! `target/bench/train_speed.json` (`sac_train_env_steps_per_s_64x64`, ...). Wall-clock
//! figures: run on an idle machine.

use foosball_rl::config::RunConfig;
use foosball_rl::run::train::{Event, Start, train};
use std::path::Path;
use std::time::Instant;

#[path = "args.rs"]
mod args;
#[path = "figures.rs"]
mod figures;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Env steps after which the clock starts.
const WARM_UP: u64 = 1_000;

/// Env steps/s of `algo` trained for `steps` env steps with `hidden` networks.
fn train_speed(algo: &str, hidden: &[usize], steps: u64) -> f64 {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("configs/{algo}.toml"));
    let mut config = RunConfig::load(&path).unwrap_or_else(|e| panic!("{e}"));
    config.algorithm.net_mut().hidden = hidden.to_vec();
    config.protocol.epochs = 1;
    config.protocol.steps_per_epoch = steps;
    config.protocol.test_episodes = 1;
    config.protocol.threads = 1;
    let dir = std::env::temp_dir().join(format!("foosball-train-speed-{algo}"));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let mut clock: Option<(Instant, u64)> = None;
    let mut end: Option<(Instant, u64)> = None;
    train(&config, &dir, Start::Fresh, |p| match p.event {
        Event::Window(_) if clock.is_none() && p.env_steps >= WARM_UP => {
            clock = Some((Instant::now(), p.env_steps));
        }
        Event::Test => end = Some((Instant::now(), p.env_steps)),
        _ => {}
    })
    .unwrap_or_else(|e| panic!("{algo}: {e}"));
    std::fs::remove_dir_all(&dir).ok();
    let ((t0, s0), (t1, s1)) = (clock.expect("a window"), end.expect("a test"));
    (s1 - s0) as f64 / (t1 - t0).as_secs_f64()
}

fn main() {
    let hidden: Vec<usize> = args::flag("--hidden")
        .unwrap_or_else(|| "64,64".into())
        .split(',')
        .map(|w| w.parse().expect("--hidden W,W,..."))
        .collect();
    let steps: u64 = args::flag("--steps").map_or(9_000, |s| s.parse().expect("--steps N"));
    assert!(steps > 2 * WARM_UP, "--steps must exceed {}", 2 * WARM_UP);
    let algos = args::flag("--algos").unwrap_or_else(|| "sac,td3,ppo".into());
    let key = hidden
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("x");
    let mut out = Vec::new();
    for algo in algos.split(',') {
        let per_s = train_speed(algo, &hidden, steps);
        println!("{algo} {key}: {per_s:>8.0} env steps/s (one thread, evaluations included)");
        out.push((format!("{algo}_train_env_steps_per_s_{key}"), per_s));
    }
    println!(
        "figures in {}",
        figures::write_figures("train_speed", &out).display()
    );
}
