//! The `reference` preset (the model's own contact search between the ball and the men,
//! MuJoCo's soft law), `reference_v4` (one soft contact per man collider) and
//! `reference_v3` (rapier's contacts) against the paper code's MuJoCo model, as measured in
//! `shared/reference/foosball_cu/behaviour.json` (mujoco 3.3.2; rows in the ball joint's
//! frame, world y = joint y - 4). No MuJoCo here: the fixture is data.
//!
//! - glides: the ball at the start spot sent along x at 50, 150, 300 cm/s, rods at
//!   neutral: position within 3 % of the distance travelled (+ 0.3 cm), speed within 3 %
//!   of the launch speed, and the stop at the side wall (within 1 cm, at rest);
//! - the same glide with the dry friction off keeps its speed, and bounces off the wall
//!   as slowly as the reference's (within 30 % of its rebound speed);
//! - kicks: yellow's midfield turned to +2.5 rad from rest sends the ball off within 15 %
//!   of the reference's exit speed and it comes back off black's midfield within 30 % of
//!   the reference's rebound speed; turned to -2.5 rad it misses the ball;
//! - episodes of the gym under three scripted policies: the score rate and the share of
//!   each end reason differ from the reference's by less than the 95 % bound of the
//!   difference of two independent samples (1.96 times the combined standard error), over
//!   400 of our episodes against the fixture's 60 (10 for the zero policy); the mean
//!   length within 30 %. `reference` has no allowance, the kick within 5 %;
//!   `reference_v4` one known gap, pinned: its kick leaves 36 % faster than the
//!   reference's (its prism foot overlaps the ball 1.6 cm where the model's SDF finds
//!   0.4), bound 40 %.
//! - the same kick and episodes on `reference_v3` (rapier's contacts): the kick within
//!   15 %; known gaps, pinned in [`KNOWN_GAPS`] at their measured size: the kick policy's
//!   episodes are 45 % shorter and 15 % of them stagnant (the reference's 3 %: off-centre
//!   starts that its sticky contacts push along, ours miss), and the random policy's are
//!   stagnant 13 points more often (docs/reference-game.md, "Which contacts").
//! - the zero policy from seven serves at a man's foot (the 7 of our first 400 serves
//!   whose episodes outlast the stagnation rule's 10 steps, a man at rest pushing the
//!   ball): on `reference` each lasts within 12 % of the model's own episode from the same
//!   start, the ball's velocity after its first step within 2 cm/s of the model's
//!   (`tests/data/zero_policy_model.json`, `tools/zero_policy_starts.py`; measured: 90-103 %
//!   of the model's lengths, velocities within 0.4 cm/s). The model itself outlasts 10 steps in 5 of its first 400
//!   serves, so the fixture's 10 zero-policy episodes, all of 10 steps, drew no such start.
//!
//! Run with `--nocapture` for the figures (the README's calibration table).

use foosball_rl::env::config::{BallFrame, ManContacts};
use foosball_rl::env::layout::{ACTION_DIM, action_turn};
use foosball_rl::env::table::{PhysicsParams, Table};
use foosball_rl::env::{EndReason, Env, EnvRng, FoosballConfig, FoosballEnv, Preset, ResetOptions};
use rand::{Rng, SeedableRng};
use serde::Deserialize;
use std::collections::BTreeMap;

use crate::common;

/// A row: physics step, ball joint x, joint y, velocity x, velocity y.
type Row = [f64; 5];

#[derive(Deserialize)]
struct Fixture {
    glide_x: BTreeMap<String, Vec<Row>>,
    glide_x_no_frictionloss: BTreeMap<String, Vec<Row>>,
    kicks: BTreeMap<String, Vec<Row>>,
    episodes: BTreeMap<String, Vec<Episode>>,
}

#[derive(Deserialize)]
struct Episode {
    steps: u32,
    scored: bool,
    end: String,
}

fn fixture() -> Option<Fixture> {
    let path = common::reference_file("foosball_cu/behaviour.json")?;
    Some(serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap())
}

fn reference() -> FoosballConfig {
    let config = FoosballConfig::preset(Preset::Reference);
    assert_eq!(config.man_contacts, ManContacts::MujocoOctree);
    config
}

/// The fourth `reference`: one soft contact per man collider.
fn soft_contacts() -> FoosballConfig {
    let config = FoosballConfig::preset(Preset::ReferenceV4);
    assert_eq!(config.man_contacts, ManContacts::MujocoSoft);
    config
}

/// The third `reference`: rapier's ball-man contacts.
fn rigid_contacts() -> FoosballConfig {
    let config = FoosballConfig::preset(Preset::ReferenceV3);
    assert_eq!(config.man_contacts, ManContacts::Rapier);
    config
}

/// The table of `config` with the ball at joint `(x, y)` moving at `v`, every rod held at
/// neutral, and its rows every `every` physics steps (as the fixture's) up to `last`.
fn trace(
    config: &FoosballConfig,
    joint_xy: [f64; 2],
    v: [f32; 2],
    targets: &[(usize, f32, f32)],
    every: usize,
    last: usize,
) -> Vec<Row> {
    let [ox, oy, _] = BallFrame::JOINT_ORIGIN;
    let xy = [joint_xy[0] as f32 + ox, joint_xy[1] as f32 + oy];
    let mut table = Table::new(&PhysicsParams::nominal(config), xy);
    table.set_ball(
        [xy[0], xy[1], foosball_rl::env::geometry::BALL_RADIUS],
        [v[0], v[1], 0.0],
    );
    for &(rod, slide, angle) in targets {
        table.set_target(rod, slide, angle);
    }
    let mut rows = Vec::new();
    for k in 0..=last {
        if k % every == 0 {
            let p = table.ball_position();
            let u = table.ball_velocity();
            rows.push([
                k as f64,
                (p[0] - ox) as f64,
                (p[1] - oy) as f64,
                u[0] as f64,
                u[1] as f64,
            ]);
        }
        table.step();
    }
    rows
}

fn glide(config: &FoosballConfig, reference: &[Row]) -> Vec<Row> {
    let r0 = reference[0];
    let every = reference[1][0] as usize;
    let last = reference.last().unwrap()[0] as usize;
    trace(
        config,
        [r0[1], r0[2]],
        [r0[3] as f32, r0[4] as f32],
        &[],
        every,
        last,
    )
}

/// The largest gaps, over matching rows, of position (cm) and speed (cm/s).
fn largest_gaps(ours: &[Row], theirs: &[Row]) -> (f64, f64) {
    assert_eq!(ours.len(), theirs.len());
    let mut gaps = (0.0_f64, 0.0_f64);
    for (a, b) in ours.iter().zip(theirs) {
        assert_eq!(a[0], b[0]);
        gaps.0 = gaps.0.max((a[1] - b[1]).hypot(a[2] - b[2]));
        gaps.1 = gaps.1.max((a[3] - b[3]).hypot(a[4] - b[4]));
    }
    gaps
}

#[test]
fn glides_slow_down_and_stop_at_the_wall_as_the_reference() {
    let Some(fx) = fixture() else { return };
    for (speed, theirs) in &fx.glide_x {
        let ours = glide(&reference(), theirs);
        let launch: f64 = speed.parse().unwrap();
        let travel = theirs.last().unwrap()[1] - theirs[0][1];
        let (dp, dv) = largest_gaps(&ours, theirs);
        let (a, b) = (ours.last().unwrap(), theirs.last().unwrap());
        println!(
            "glide {launch} cm/s: largest gap {dp:.3} cm, {dv:.2} cm/s; at rest at x = {:.2} (reference {:.2}), speed {:.3}",
            a[1], b[1], a[3]
        );
        assert!(
            dp <= 0.03 * travel + 0.3,
            "glide {launch}: position gap {dp}"
        );
        assert!(dv <= 0.03 * launch, "glide {launch}: speed gap {dv}");
        assert!(
            (a[1] - b[1]).abs() < 1.0,
            "glide {launch}: stops at {}",
            a[1]
        );
        assert!(a[3].hypot(a[4]) < 0.5, "glide {launch}: still moving");
    }
}

#[test]
fn without_dry_friction_the_glide_keeps_its_speed_and_the_wall_kills_it() {
    let Some(fx) = fixture() else { return };
    let theirs = &fx.glide_x_no_frictionloss["150.0"];
    let mut config = reference();
    config.ball.axis_deceleration = 0.0;
    let ours = glide(&config, theirs);
    // Before the wall: the same uniform motion.
    let before = theirs.iter().take_while(|r| r[3] > 149.0).count();
    let (dp, dv) = largest_gaps(&ours[..before], &theirs[..before]);
    assert!(dp < 0.05 && dv < 0.5, "free glide: {dp} cm, {dv} cm/s");
    // After it: the rebound.
    let rebound = |rows: &[Row]| -rows.last().unwrap()[3];
    let (a, b) = (rebound(&ours), rebound(theirs));
    println!("wall rebound from 150 cm/s without dry friction: {a:.2} cm/s (reference {b:.2})");
    assert!((a - b).abs() <= 0.3 * b, "rebound {a} against {b}");
}

/// The rows of a kick: yellow's midfield (rod 2) turned to `angle` from rest.
fn kick(config: &FoosballConfig, theirs: &[Row], angle: f32) -> Vec<Row> {
    let every = theirs[1][0] as usize;
    let last = theirs.last().unwrap()[0] as usize;
    let r0 = theirs[0];
    trace(
        config,
        [r0[1], r0[2]],
        [0.0, 0.0],
        &[(2, 0.0, angle)],
        every,
        last,
    )
}

#[test]
fn the_midfield_kick_leaves_and_comes_back_at_the_reference_speeds() {
    let Some(fx) = fixture() else { return };
    let theirs = &fx.kicks["mid+2.5"];
    // (contacts, the exit speed's bound): `reference_v4`'s one soft contact per man 36 %
    // over, a known gap (module docs), pinned at 40 %; `reference`'s, the model's own
    // search (2 % under), within 5 %; rapier's within 15 %.
    for (config, exit_bound) in [
        (soft_contacts(), 0.4),
        (reference(), 0.05),
        (rigid_contacts(), 0.15),
    ] {
        let ours = kick(&config, theirs, 2.5);
        let exit = |rows: &[Row]| rows.iter().map(|r| r[4]).fold(f64::MIN, f64::max);
        let back = |rows: &[Row]| -rows.iter().map(|r| r[4]).fold(f64::MAX, f64::min);
        let (ea, eb) = (exit(&ours), exit(theirs));
        let (ba, bb) = (back(&ours), back(theirs));
        let contacts = config.man_contacts;
        println!(
            "midfield kick, {contacts:?} contacts: exit {ea:.0} cm/s (reference {eb:.0}), back off black's midfield {ba:.0} cm/s (reference {bb:.0})"
        );
        assert!(
            (ea - eb).abs() <= exit_bound * eb,
            "{contacts:?}: exit {ea} against {eb}"
        );
        // Within 30 % since the contacts' friction is the model's (rapier: 101 against 111
        // cm/s; with the ball's own 0.01 it came back at 59).
        assert!(
            (ba - bb).abs() <= 0.3 * bb,
            "{contacts:?}: rebound {ba} against {bb}"
        );

        let missed = kick(&config, &fx.kicks["mid-2.5"], -2.5);
        let moved = missed
            .iter()
            .map(|r| (r[1] - missed[0][1]).hypot(r[2] - missed[0][2]))
            .fold(0.0, f64::max);
        assert!(
            moved < 0.1,
            "{contacts:?}: the backswing moved the ball {moved} cm"
        );
    }
}

/// What a set of episodes gives: score rate, mean length, share of each end reason.
#[derive(Debug, Default)]
struct Tally {
    n: usize,
    scored: usize,
    lengths: Vec<f64>,
    ends: BTreeMap<String, usize>,
}

impl Tally {
    fn add(&mut self, steps: u32, scored: bool, end: &str) {
        self.n += 1;
        self.scored += usize::from(scored);
        self.lengths.push(steps as f64);
        *self.ends.entry(end.to_string()).or_default() += 1;
    }

    /// Each statistic with its standard error: (name, value, se).
    fn stats(&self) -> Vec<(String, f64, f64)> {
        let n = self.n as f64;
        let share = |k: usize| {
            let p = k as f64 / n;
            (p, (p * (1.0 - p) / n).sqrt())
        };
        let mean = self.lengths.iter().sum::<f64>() / n;
        let var = self.lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let (p, se) = share(self.scored);
        let mut out = vec![
            ("score rate".to_string(), p, se),
            ("mean length".to_string(), mean, (var / n).sqrt()),
        ];
        for end in ["stagnant", "no_progress", "other"] {
            let (p, se) = share(self.ends.get(end).copied().unwrap_or(0));
            out.push((format!("share {end}"), p, se));
        }
        out
    }
}

/// A scripted policy: the next action from the policy's own random stream.
type Policy = dyn FnMut(&mut EnvRng) -> [f32; ACTION_DIM];

/// `n` episodes of the env of `config` under `policy`, seeds 0..n.
fn our_episodes(
    config: &FoosballConfig,
    n: u64,
    mut policy: impl FnMut(&mut EnvRng) -> [f32; ACTION_DIM],
) -> Tally {
    let mut env = FoosballEnv::new(config.clone()).unwrap();
    let mut rng = EnvRng::seed_from_u64(7);
    let mut tally = Tally::default();
    for seed in 0..n {
        env.reset(Some(seed));
        loop {
            let (_, t) = env.step(&policy(&mut rng)).unwrap();
            if let Some(end) = t.info.end {
                let name = match end {
                    EndReason::Stagnant | EndReason::NoProgress => end.name(),
                    _ => "other",
                };
                tally.add(t.info.steps, t.info.scored(), name);
                break;
            }
        }
    }
    tally
}

/// Where `reference_v3` (rapier's contacts) misses the bound, and by how much more it may:
/// (policy, statistic, allowance added to the bound; for the mean length, to its 30 %).
/// `reference` and `reference_v4` (MuJoCo's soft contacts) have none.
const KNOWN_GAPS: [(&str, &str, f64); 5] = [
    ("mid_kick", "mean length", 0.2),
    ("mid_kick", "share stagnant", 0.07),
    ("mid_kick", "share no_progress", 0.07),
    ("random", "share stagnant", 0.03),
    ("random", "share no_progress", 0.03),
];

#[test]
fn scripted_episodes_end_as_the_references() {
    let Some(fx) = fixture() else { return };
    // The gym's +20 on the midfield turn, saturating like it.
    let mut kick = [0.0; ACTION_DIM];
    kick[action_turn(2)] = 1.0;
    let mut misses = Vec::new();
    // MuJoCo's soft contacts (either search) with no allowance; rapier's with their known
    // gaps.
    for (config, gaps) in [
        (reference(), &[][..]),
        (soft_contacts(), &[][..]),
        (rigid_contacts(), &KNOWN_GAPS[..]),
    ] {
        let contacts = config.man_contacts;
        for (name, theirs) in &fx.episodes {
            let policy: Box<Policy> = match name.as_str() {
                "zero" => Box::new(|_| [0.0; ACTION_DIM]),
                "random" => Box::new(|rng| std::array::from_fn(|_| rng.random_range(-1.0..=1.0))),
                "mid_kick" => Box::new(move |_| kick),
                other => panic!("unknown policy {other} in the fixture"),
            };
            let ours = our_episodes(&config, 400, policy);
            let mut reference = Tally::default();
            for e in theirs {
                reference.add(e.steps, e.scored, &e.end);
            }
            for ((stat, a, sa), (_, b, sb)) in ours.stats().into_iter().zip(reference.stats()) {
                let bound = 1.96 * (sa * sa + sb * sb).sqrt();
                println!(
                    "{contacts:?} {name:>8} {stat:<18} ours {a:8.3} ± {sa:.3}   reference {b:8.3} ± {sb:.3}   bound {bound:.3}"
                );
                // Both zero-variance (e.g. every zero-policy episode stagnates in 10
                // steps): the values must be equal.
                let gap = gaps
                    .iter()
                    .find(|(policy, s, _)| policy == name && *s == stat)
                    .map_or(0.0, |g| g.2);
                let ok = if stat == "mean length" {
                    (a - b).abs() <= (0.3 + gap) * b
                } else {
                    (a - b).abs() <= bound.max(1e-9) + gap
                };
                if !ok {
                    misses.push(format!(
                        "{contacts:?} {name}: {stat} {a} against the reference's {b} (bound {bound})"
                    ));
                }
            }
        }
    }
    assert!(misses.is_empty(), "{misses:#?}");
}

/// The model's zero-policy episodes from given starts (`tools/zero_policy_starts.py`).
#[derive(Deserialize)]
struct ZeroPolicy {
    episodes: Vec<ZeroEpisode>,
}

#[derive(Deserialize)]
struct ZeroEpisode {
    /// The ball's start, joint frame (cm).
    start: [f32; 2],
    steps: u32,
    /// The ball's x, y, vx, vy after each of the first steps (joint frame).
    ball: Vec<[f64; 4]>,
}

#[test]
fn the_zero_policy_at_a_mans_foot_lasts_as_the_models() {
    let fixture: ZeroPolicy = serde_json::from_str(
        &std::fs::read_to_string("tests/data/zero_policy_model.json").unwrap(),
    )
    .unwrap();
    assert_eq!(fixture.episodes.len(), 7);
    let mut env = FoosballEnv::new(reference()).unwrap();
    let mut obs = vec![0.0; env.obs_dim()];
    for e in &fixture.episodes {
        let options = ResetOptions {
            ball: Some(e.start),
        };
        env.reset_with(Some(0), &options, &mut obs).unwrap();
        let (mut steps, mut first) = (0, None);
        loop {
            let (o, t) = env.step(&[0.0; ACTION_DIM]).unwrap();
            steps += 1;
            first.get_or_insert([f64::from(o[3]), f64::from(o[4])]);
            if t.done() {
                break;
            }
        }
        let [vx, vy] = first.unwrap();
        let theirs = e.ball[0];
        let dv = (vx - theirs[2]).hypot(vy - theirs[3]);
        println!(
            "start {:?}: {steps} steps, the model's {}; first velocity off by {dv:.1} cm/s",
            e.start, e.steps
        );
        assert!(
            e.steps > 10,
            "the model's episode from {:?} outlasts 10 steps",
            e.start
        );
        let ratio = f64::from(steps) / f64::from(e.steps);
        assert!(
            (0.88..=1.12).contains(&ratio),
            "{:?}: {steps} against {}",
            e.start,
            e.steps
        );
        assert!(
            dv < 8.0,
            "{:?}: first velocity ({vx}, {vy}) against {theirs:?}",
            e.start
        );
    }
}
