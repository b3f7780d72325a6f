//! Runs committed under `results/` still replay: `evaluate` on a run's saved networks
//! reproduces its `test/metrics.json` byte for byte with this build (its `config.toml`
//! pins every rule and physics value; the first game is kept as the `reference_v1`
//! preset).

use std::path::Path;
use std::process::Command;

use crate::common;

fn replays(run: &str) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run_dir = root.join(run);
    let out = common::scratch(&format!("replay-{}", run.replace('/', "-")));
    let status = Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .args([
            "--run",
            run_dir.to_str().unwrap(),
            "--checkpoint",
            "last",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let ours = std::fs::read(out.join("metrics.json")).unwrap();
    let theirs = std::fs::read(run_dir.join("test/metrics.json")).unwrap();
    assert!(
        ours == theirs,
        "{run}: metrics.json differs from the committed one"
    );
}

#[test]
fn a_run_of_the_first_game_replays_byte_for_byte() {
    replays("results/figure2-v1/sac-seed0");
}

#[test]
fn a_run_of_the_codes_game_replays_byte_for_byte() {
    replays("results/figure2/ppo-seed0");
}

/// Its networks read normalised observations: the moments saved beside them replay too.
#[test]
fn a_run_on_normalised_observations_replays_byte_for_byte() {
    replays("results/ppo-normalize/ppo-seed4");
}

/// Today's game (the sixth `reference`): the headline row's first seed (the README's
/// reproduce command) replays, Fourier features and normalisation included.
#[test]
fn the_headline_run_replays_byte_for_byte() {
    replays(
        "results/ppo-study-v6/goal-bonus-10x-linear-actions-target-kl-fourier-ball-128/ppo-seed0",
    );
}
