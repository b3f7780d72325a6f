//! Practice spots for the training serves (`[[drills]]`): a run's training episodes start
//! on the drill's spot in its share of the serves while its evaluations serve from
//! `env.start`; the section survives the saved config, and bad values are refused by key
//! and line.

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_rl::config::RunConfig;
use foosball_rl::run::train::{Start, train};
use std::path::Path;

/// Every serve of the training envs 10 cm before black's goal (joint frame), at rest.
const BY_BLACKS_GOAL: &str = "[[drills]]\nshare = 1.0\nx_mean = 0.0\ny_mean = 55.0\n";

/// Trains the tiny PPO run with `extra` appended into `dir/name`: each training episode's
/// return per step, and the evaluations' mean distance of the ball to black's goal (cm).
fn run(dir: &Path, name: &str, extra: &str) -> (Vec<f64>, Vec<f64>) {
    let text = format!("{}{extra}", tiny_config_text("ppo", 2, 200));
    let c = RunConfig::from_toml(&text, Path::new("t.toml")).unwrap();
    let out = dir.join(name);
    std::fs::create_dir_all(&out).unwrap();
    train(&c, &out, Start::Fresh, |_| {}).unwrap();
    let rows = |file: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(out.join(file))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| {
                l.split(',')
                    .map(|v| v.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect()
    };
    let per_step = rows("episodes.csv").iter().map(|r| r[1] / r[2]).collect();
    let distances = rows("evaluations.csv").iter().map(|r| r[3]).collect();
    (per_step, distances)
}

#[test]
fn training_serves_go_to_the_drill_and_evaluations_serve_from_the_start() {
    let dir = scratch("drills-run");
    let (drilled, drilled_eval) = run(&dir, "drilled", BY_BLACKS_GOAL);
    let (plain, plain_eval) = run(&dir, "plain", "");
    assert!(drilled.len() > 5 && plain.len() > 5);
    // A step pays 300 minus the ball's distance to black's goal (65 cm from the centre
    // serve, 10 from the drill's spot), more in the goal.
    assert!(
        drilled.iter().all(|&r| r > 270.0),
        "every training episode served by black's goal: {drilled:?}"
    );
    assert!(
        plain.iter().all(|&r| r < 270.0),
        "every plain one from the centre: {plain:?}"
    );
    assert!(!drilled_eval.is_empty());
    assert!(
        drilled_eval.iter().chain(&plain_eval).all(|&d| d > 40.0),
        "evaluations serve from the centre in both runs: {drilled_eval:?} {plain_eval:?}"
    );
}

#[test]
fn drills_are_saved_with_the_run_and_bad_ones_refused_by_key_and_line() {
    let text = format!("{}{BY_BLACKS_GOAL}", tiny_config_text("ppo", 1, 100));
    let c = RunConfig::from_toml(&text, Path::new("t.toml")).unwrap();
    assert_eq!(c.drills.len(), 1);
    assert_eq!(c.drills[0].y_mean, 55.0);
    let again = RunConfig::from_toml(&c.to_toml(), Path::new("saved.toml")).unwrap();
    assert_eq!(again, c);
    let bad = format!(
        "{}{BY_BLACKS_GOAL}[[drills]]\nshare = 0.5\nx_mean = 0.0\ny_mean = 0.0\nx_std = -2.0\n",
        tiny_config_text("ppo", 1, 100)
    );
    let lines = bad.lines().count();
    let e = RunConfig::from_toml(&bad, Path::new("bad.toml"))
        .unwrap_err()
        .to_string();
    // The second drill's `x_std`, the file's last line.
    assert!(
        e.starts_with(&format!("bad.toml:{lines}: drills[1].x_std: ")),
        "{e}"
    );
    let over = bad.replace("x_std = -2.0", "x_std = 2.0");
    let e = RunConfig::from_toml(&over, Path::new("bad.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("drills: the shares sum to 1.5, past 1"), "{e}");
}
