//! The `reference` game against the paper code's MuJoCo model one step at a time, from the
//! model's own states: `tests/data/model_episodes.json` holds twelve episodes of two
//! trained policies played on the model (`tools/transfer.py RUN --seeds ... --record`,
//! MuJoCo 3.3.2): yellow's action at every step and the 38-value observation after it.
//! That observation is the model's whole state (MuJoCo steps from it, set as its `qpos`
//! and `qvel`, to the recorded next one within 4e-10). Each step is taken on our table
//! from the recorded state (the ball and all eight rods placed: `Table::set_ball`,
//! `Table::set_rod`) with the recorded action, and its result compared with the model's
//! next state. Unlike a replay, an error made at one step is not carried into the next:
//! this is the per-step parity of the physics, the kicks included.
//!
//! Asserted, on `reference` (the search on the model's own octree of the man):
//! - every rod's velocities after every step within 5 % of the model's (floors 1 cm/s
//!   and 1 rad/s), but for a rod whose bumper presses a wall (the step-response test's
//!   known gap);
//! - the ball's change of velocity in a step where it is struck (the model's or ours
//!   changes by more than 1 cm/s) away from the walls: within 1 % of the model's at the
//!   median and within 10 % at nine steps in ten, and at most one step that misses by
//!   more than a quarter (measured: 0.06 %, 1.76 %, one step of 20 cm/s);
//! - `reference_v5` (the man's field sampled every 0.1 cm) misses the nine-in-ten bound
//!   (measured 89 %; median 7.3 %, 33 steps missing by more than a quarter): the test tells
//!   the two apart.
//!
//! Not asserted, a known gap: where the ball starts a step within 0.5 cm of a wall or past
//! a goal line, the model's walls meet it up to 0.3 cm sooner than ours and stop it dead
//! (seven steps of the fixture miss by more than a quarter there).
//!
//! Run with `--nocapture` for the figures and the worst steps.

use crate::step_response::Fixture;
use foosball_rl::env::config::BallFrame;
use foosball_rl::env::geometry::{BALL_RADIUS, FIELD_HALF_LENGTH, FIELD_HALF_WIDTH, RODS};
use foosball_rl::env::layout::{
    BALL_POS, BALL_VEL, OBS_DIM, ROD_ANGLE, ROD_ANGLE_VEL, ROD_SLIDE, ROD_SLIDE_VEL,
};
use foosball_rl::env::table::RodState;
use foosball_rl::env::{Env, FoosballConfig, FoosballEnv, Preset, ResetOptions};

const FIXTURE: &str = "tests/data/model_episodes.json";

/// What one step of the fixture came to on our table.
struct Step {
    /// Case name and step index.
    at: String,
    /// The ball's change of velocity in the step, the model's and ours, cm/s.
    theirs: [f64; 2],
    ours: [f64; 2],
    /// The rods' worst velocity error over its allowance, and which.
    rods: (f64, String),
    /// Whether the ball starts the step within 0.5 cm of a wall or past the goal line.
    by_wall: bool,
}

impl Step {
    /// |ours - theirs| over |theirs| (at least 10 cm/s).
    fn ball_error(&self) -> f64 {
        let d = (self.ours[0] - self.theirs[0]).hypot(self.ours[1] - self.theirs[1]);
        d / self.theirs[0].hypot(self.theirs[1]).max(10.0)
    }

    fn struck(&self) -> bool {
        self.theirs[0].hypot(self.theirs[1]) > 1.0 || self.ours[0].hypot(self.ours[1]) > 1.0
    }
}

/// Puts the table of `env` in the recorded state `seen` (joint frame).
fn place(env: &mut FoosballEnv, seen: &[f64]) {
    let [ox, oy, _] = BallFrame::JOINT_ORIGIN;
    let table = env.table_mut().unwrap();
    let z = table.ball_position()[2];
    let v = |i: usize| seen[i] as f32;
    table.set_ball(
        [v(BALL_POS.start) + ox, v(BALL_POS.start + 1) + oy, z],
        [v(BALL_VEL.start), v(BALL_VEL.start + 1), 0.0],
    );
    for rod in 0..8 {
        table.set_rod(
            rod,
            RodState {
                slide: v(ROD_SLIDE.start + rod),
                slide_vel: v(ROD_SLIDE_VEL.start + rod),
                angle: v(ROD_ANGLE.start + rod),
                angle_vel: v(ROD_ANGLE_VEL.start + rod),
            },
        );
    }
}

/// Every step of the fixture taken on `preset` from the model's state before it.
fn steps(preset: Preset) -> Vec<Step> {
    let text = std::fs::read_to_string(FIXTURE).expect("the fixture is in the repository");
    let fixture: Fixture = serde_json::from_str(&text).expect("the fixture parses");
    let mut config = FoosballConfig::preset(preset);
    config.rules.end_episodes = false;
    let mut env = FoosballEnv::new(config).unwrap();
    let mut obs = [0.0; OBS_DIM];
    let mut out = Vec::new();
    for case in &fixture.cases {
        assert_eq!(case.obs.len(), case.actions.len() + 1, "{}", case.name);
        let options = ResetOptions {
            ball: Some(case.ball),
        };
        env.reset_with(Some(0), &options, &mut obs).unwrap();
        for (t, action) in case.actions.iter().enumerate() {
            let (before, after) = (&case.obs[t], &case.obs[t + 1]);
            place(&mut env, before);
            env.step_into(action, &mut obs).unwrap();
            let change = |o: f64, i: usize| o - before[BALL_VEL.start + i];
            let mut rods = (0.0, String::new());
            for rod in 0..8 {
                // The pressed bumper's known gap (the step-response test's module docs).
                let pressed = |o: &[f64]| {
                    o[ROD_SLIDE.start + rod].abs() > f64::from(RODS[rod % 4].bumper_contact)
                };
                if pressed(before) || pressed(after) {
                    continue;
                }
                for (what, i, floor) in [
                    ("slide velocity", ROD_SLIDE_VEL.start + rod, 1.0),
                    ("angular velocity", ROD_ANGLE_VEL.start + rod, 1.0),
                ] {
                    let (a, b) = (f64::from(obs[i]), after[i]);
                    let ratio = (a - b).abs() / (0.05 * b.abs()).max(floor);
                    if ratio > rods.0 {
                        rods = (
                            ratio,
                            format!(
                                "rod {rod} {what}: ours {a:.3}, theirs {b:.3} (slide {:.3})",
                                before[ROD_SLIDE.start + rod]
                            ),
                        );
                    }
                }
            }
            let [ox, oy, _] = BallFrame::JOINT_ORIGIN;
            let (x, y) = (
                before[BALL_POS.start] + f64::from(ox),
                before[BALL_POS.start + 1] + f64::from(oy),
            );
            let reach = f64::from(BALL_RADIUS) + 0.5;
            let by_wall = x.abs() > f64::from(FIELD_HALF_WIDTH) - reach
                || y.abs() > f64::from(FIELD_HALF_LENGTH) - reach;
            out.push(Step {
                at: format!(
                    "{} step {} (ball at ({:.2}, {:.2}))",
                    case.name,
                    t + 1,
                    before[BALL_POS.start],
                    before[BALL_POS.start + 1]
                ),
                theirs: [0, 1].map(|i| change(after[BALL_VEL.start + i], i)),
                ours: [0, 1].map(|i| change(f64::from(obs[BALL_VEL.start + i]), i)),
                rods,
                by_wall,
            });
        }
    }
    out
}

fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The struck steps' ball errors: median, 90th percentile, the steps missing by more
/// than a quarter; printed with the worst.
fn ball_figures(preset: Preset, steps: &[Step], by_wall: bool) -> (f64, f64, Vec<&Step>) {
    let struck: Vec<&Step> = steps
        .iter()
        .filter(|s| s.struck() && s.by_wall == by_wall)
        .collect();
    let errors: Vec<f64> = struck.iter().map(|s| s.ball_error()).collect();
    let (median, ninety) = (quantile(errors.clone(), 0.5), quantile(errors, 0.9));
    let missed: Vec<&Step> = struck
        .iter()
        .copied()
        .filter(|s| s.ball_error() > 0.25)
        .collect();
    println!(
        "{}: {} steps, {} struck {}: the ball's change off the model's by {:.2} % (median), \
         {:.2} % (90th percentile); {} miss by more than a quarter",
        preset.name(),
        steps.len(),
        struck.len(),
        if by_wall { "by a wall" } else { "in the field" },
        100.0 * median,
        100.0 * ninety,
        missed.len()
    );
    for s in &missed {
        println!(
            "  {}: theirs ({:.1}, {:.1}), ours ({:.1}, {:.1}) cm/s",
            s.at, s.theirs[0], s.theirs[1], s.ours[0], s.ours[1]
        );
    }
    (median, ninety, missed)
}

#[test]
fn every_step_of_the_models_episodes_matches_from_the_models_state() {
    let steps = steps(Preset::Reference);
    assert!(steps.len() > 500, "{} steps", steps.len());
    let worst_rod = steps
        .iter()
        .max_by(|a, b| a.rods.0.total_cmp(&b.rods.0))
        .unwrap();
    println!(
        "rods: worst {:.2} of the bound, {}: {}",
        worst_rod.rods.0, worst_rod.at, worst_rod.rods.1
    );
    assert!(
        worst_rod.rods.0 <= 1.0,
        "{}: {}",
        worst_rod.at,
        worst_rod.rods.1
    );
    let (median, ninety, missed) = ball_figures(Preset::Reference, &steps, false);
    assert!(median < 0.01, "median {median}");
    assert!(ninety < 0.10, "90th percentile {ninety}");
    assert!(missed.len() <= 1, "{} steps missed", missed.len());
    // The walls' known gap, printed, not asserted.
    ball_figures(Preset::Reference, &steps, true);
}

#[test]
fn the_sampled_field_of_the_fifth_reference_misses_the_bound() {
    let steps = steps(Preset::ReferenceV5);
    let (_, ninety, _) = ball_figures(Preset::ReferenceV5, &steps, false);
    assert!(ninety > 0.10, "90th percentile {ninety}");
}
