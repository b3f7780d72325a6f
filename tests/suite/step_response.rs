//! The `reference` preset against the paper code's MuJoCo model, step by step: every case of
//! `shared/reference/foosball_cu/step_response.json` (its README says how it was made; the
//! file may be replaced by another of the same schema) replayed through our table, the
//! ball placed at the case's start (`reset_with`) and the episode's end rules off
//! (`rules.end_episodes = false`), black's rods held at neutral as in the fixture.
//!
//! Asserted, per step:
//! - every rod's slide and angle within 5 % of the reference's (floor 0.05 cm, 0.01 rad),
//!   their velocities within 10 % (floor 5 cm/s, 1 rad/s), on every step before the ball's
//!   first contact with a man (the whole case where the ball is never touched: 33 of the
//!   38). One allowance, a known gap: while a rod's bumper presses a wall, MuJoCo's SDF
//!   collision puts the pad's one contact point anywhere on its face, and off the axis its
//!   sliding friction (0.1) brakes the turn by up to 1.75 rad/s in a step; ours is
//!   frictionless, so the turn's velocity gets 2 rad/s more there;
//! - the ball within 0.5 cm of the reference's until the first contact (of either game);
//! - the first contact's step within 1 step of the reference's (the bar; the mesh's
//!   leg prism meets the ball when the model's mesh man does).
//!
//! Each case runs twice: with the preset's contacts (`mujoco_octree`: the model's own contact
//! search on its man's own octree) and with `reference_v4`'s (`mujoco_soft`: one exact
//! contact per man collider).
//!
//! After the first contact the rods and the ball are not asserted: the men's shape and
//! MuJoCo's soft contacts decide them, and they differ (the worst figures are printed).
//! Run with `--nocapture` for the worst case and step of each.

use foosball_rl::env::config::ManContacts;
use foosball_rl::env::geometry::RODS;
use foosball_rl::env::layout::{
    BALL_POS, BALL_VEL, OBS_DIM, ROD_ANGLE, ROD_ANGLE_VEL, ROD_SLIDE, ROD_SLIDE_VEL,
};
use foosball_rl::env::{Env, FoosballConfig, FoosballEnv, Preset, ResetOptions};
use serde::Deserialize;

use crate::common;

/// Episodes played on the model, yellow's actions and the observations (the schema of
/// `tools/transfer.py --record` too).
#[derive(Deserialize)]
pub(crate) struct Fixture {
    /// Physics step, s.
    pub(crate) dt: f64,
    pub(crate) cases: Vec<Case>,
}

#[derive(Deserialize)]
pub(crate) struct Case {
    pub(crate) name: String,
    /// The ball's start, joint frame, cm.
    pub(crate) ball: [f32; 2],
    /// Yellow's action per step (project units).
    pub(crate) actions: Vec<[f32; 8]>,
    /// The observation at the start and after every step (38 values, joint frame).
    pub(crate) obs: Vec<Vec<f64>>,
}

/// One asserted quantity: where it sits in the observation, its relative bound and floor.
struct Quantity {
    name: &'static str,
    first: usize,
    relative: f64,
    floor: f64,
}

const QUANTITIES: [Quantity; 4] = [
    Quantity {
        name: "slide",
        first: ROD_SLIDE.start,
        relative: 0.05,
        floor: 0.05,
    },
    Quantity {
        name: "slide velocity",
        first: ROD_SLIDE_VEL.start,
        relative: 0.10,
        floor: 5.0,
    },
    Quantity {
        name: "angle",
        first: ROD_ANGLE.start,
        relative: 0.05,
        floor: 0.01,
    },
    Quantity {
        name: "angular velocity",
        first: ROD_ANGLE_VEL.start,
        relative: 0.10,
        floor: 1.0,
    },
];

/// Extra angular velocity allowed while a rod's bumper presses a wall, rad/s (see the
/// module docs).
const BUMPER_FRICTION_ALLOWANCE: f64 = 2.0;

/// Our observations after each of the case's steps.
fn replay(case: &Case, man_contacts: ManContacts) -> Vec<[f32; OBS_DIM]> {
    let mut config = FoosballConfig::preset(Preset::Reference);
    config.rules.end_episodes = false;
    config.man_contacts = man_contacts;
    let mut env = FoosballEnv::new(config).unwrap();
    let mut obs = [0.0; OBS_DIM];
    env.reset_with(
        Some(0),
        &ResetOptions {
            ball: Some(case.ball),
        },
        &mut obs,
    )
    .unwrap();
    let start = &case.obs[0];
    for (i, v) in obs[BALL_POS].iter().enumerate() {
        assert!(
            (f64::from(*v) - start[i]).abs() < 1e-4,
            "{}: start",
            case.name
        );
    }
    case.actions
        .iter()
        .map(|a| {
            let t = env.step_into(a, &mut obs).unwrap();
            assert!(
                !t.done(),
                "{}: ended after {} steps",
                case.name,
                t.info.steps
            );
            obs
        })
        .collect()
}

/// The first step (1-based) after which the ball's velocity changed by more than the
/// floor's dry friction can (0.4 cm/s per axis per 2 ms step, and stopping).
fn first_contact(velocities: impl Iterator<Item = [f64; 2]>, dt: f64) -> Option<usize> {
    let friction = 200.0 * dt + 0.01;
    let mut before = [0.0, 0.0];
    for (k, v) in velocities.enumerate() {
        let touched = (0..2).any(|i| {
            let change = (v[i] - before[i]).abs();
            change > friction && !(v[i] == 0.0 && before[i].abs() <= friction)
        });
        if touched {
            return Some(k + 1);
        }
        before = v;
    }
    None
}

#[derive(Default)]
struct Worst {
    /// Error over the allowed, case, step, what.
    ratio: f64,
    case: String,
    step: usize,
    what: String,
}

impl Worst {
    fn note(&mut self, ratio: f64, case: &str, step: usize, what: impl FnOnce() -> String) {
        if ratio > self.ratio {
            *self = Worst {
                ratio,
                case: case.into(),
                step,
                what: what(),
            };
        }
    }
}

#[test]
fn every_case_of_the_step_response_matches_the_reference_model_until_the_ball_is_touched() {
    every_case_matches(ManContacts::MujocoOctree);
}

#[test]
fn with_one_soft_contact_per_man_every_case_matches_too() {
    every_case_matches(ManContacts::MujocoSoft);
}

/// Replays every case with the men's contacts `man_contacts`, asserting the module's
/// bounds.
fn every_case_matches(man_contacts: ManContacts) {
    let Some(path) = common::reference_file("foosball_cu/step_response.json") else {
        return;
    };
    let fixture: Fixture = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    assert!(!fixture.cases.is_empty());
    let (mut rods, mut ball, mut after) = (Worst::default(), Worst::default(), Worst::default());
    let mut failures = Vec::new();
    for case in &fixture.cases {
        assert_eq!(case.obs.len(), case.actions.len() + 1, "{}", case.name);
        let ours = replay(case, man_contacts);
        let theirs_contact = first_contact(
            case.obs[1..]
                .iter()
                .map(|o| [o[BALL_VEL.start], o[BALL_VEL.start + 1]]),
            fixture.dt,
        );
        let ours_contact = first_contact(
            ours.iter()
                .map(|o| [o[BALL_VEL.start], o[BALL_VEL.start + 1]].map(f64::from)),
            fixture.dt,
        );
        let contact = match (theirs_contact, ours_contact) {
            (Some(a), Some(b)) => {
                if a.abs_diff(b) > 1 {
                    failures.push(format!(
                        "{}: the ball is first touched after step {b}, the reference's after {a}",
                        case.name
                    ));
                }
                Some(a.min(b))
            }
            (None, None) => None,
            (a, b) => {
                failures.push(format!(
                    "{}: first contact after step {b:?} here, {a:?} in the reference",
                    case.name
                ));
                a.or(b)
            }
        };
        for (k, (o, t)) in ours.iter().zip(&case.obs[1..]).enumerate() {
            let step = k + 1;
            let untouched = contact.is_none_or(|c| step < c);
            for rod in 0..8 {
                let pressed =
                    t[ROD_SLIDE.start + rod].abs() > f64::from(RODS[rod % 4].bumper_contact);
                for q in &QUANTITIES {
                    let (a, b) = (f64::from(o[q.first + rod]), t[q.first + rod]);
                    let mut allowed = (q.relative * b.abs()).max(q.floor);
                    if pressed && q.first == ROD_ANGLE_VEL.start {
                        allowed += BUMPER_FRICTION_ALLOWANCE;
                    }
                    let ratio = (a - b).abs() / allowed;
                    let what = || format!("rod {rod} {}: ours {a:.4}, theirs {b:.4}", q.name);
                    if untouched {
                        rods.note(ratio, &case.name, step, what);
                        if ratio > 1.0 {
                            failures.push(format!("{} step {step}: {}", case.name, what()));
                        }
                    } else {
                        after.note(ratio, &case.name, step, what);
                    }
                }
            }
            if untouched {
                let d = (0..2)
                    .map(|i| (f64::from(o[BALL_POS.start + i]) - t[BALL_POS.start + i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                ball.note(d / 0.5, &case.name, step, || format!("ball {d:.3} cm away"));
                if d > 0.5 {
                    failures.push(format!(
                        "{} step {step}: the ball is {d:.3} cm away",
                        case.name
                    ));
                }
            }
        }
    }
    for (label, w) in [
        ("rods before contact", &rods),
        ("ball before contact", &ball),
        ("rods after contact (not asserted)", &after),
    ] {
        println!(
            "{man_contacts:?}, {label}: worst {:.2} of its bound, {} step {}: {}",
            w.ratio, w.case, w.step, w.what
        );
    }
    assert!(
        failures.is_empty(),
        "{} of the fixture's {} cases' checks failed:\n{}",
        failures.len(),
        fixture.cases.len(),
        failures.join("\n")
    );
}
