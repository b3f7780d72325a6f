//! The foosball environment's contract: observation layout, reward, episode rules, goal
//! bookkeeping, refused actions and determinism.

use foosball_rl::env::config::SpinRule;
use foosball_rl::env::geometry::{BALL_RADIUS, GOAL_LINE_Y};
use foosball_rl::env::layout::{
    ACTION_DIM, BALL_POS, OBS_DIM, ROD_ANGLE, ROD_SLIDE, action_turn, black_rod_inputs,
};
use foosball_rl::env::{
    EndReason, Env, EnvError, EnvRng, FoosballConfig, FoosballEnv, OpponentKind, Preset,
    ResetOptions, Serve,
};
use rand::{Rng, SeedableRng};

use crate::common;

use common::{NEUTRAL, env_with, placed, play_out};

/// The first paper preset: 10 ms agent steps, world frame, linear actions, a rolling ball
/// free in 3-D, starting near (-0.5, -0.1). (The code's table has its own tests:
/// `presets.rs` and `tests/suite/reference_parity.rs`.)
fn ten_ms() -> FoosballConfig {
    FoosballConfig::preset(Preset::PaperV1)
}

/// The first game with a goal ending the episode.
fn end_on_goal() -> FoosballConfig {
    let mut config = ten_ms();
    config.rules.end_on_goal = true;
    config
}

#[test]
fn the_first_observation_follows_the_layout() {
    let mut env = FoosballEnv::new(ten_ms()).unwrap();
    let obs = env.reset(Some(3));
    assert_eq!(obs.len(), OBS_DIM);
    assert!((obs[BALL_POS.start + 2] - BALL_RADIUS).abs() < 1e-5);
    // Ball near (-0.5, -0.1) with std 0.5.
    assert!(
        (obs[0] + 0.5).abs() < 3.0 && (obs[1] + 0.1).abs() < 3.0,
        "{:?}",
        &obs[..3]
    );
    // Everything but the ball position is zero at the start: rods at neutral, at rest.
    assert!(obs[3..].iter().all(|&v| v == 0.0), "{:?}", &obs[3..]);
}

#[test]
fn rod_commands_show_up_in_the_observation() {
    let mut env = env_with(ten_ms());
    // Yellow attack: slide +0.5 of 12 cm, turn -0.4 of 2.5 rad.
    let mut a = NEUTRAL;
    a[6] = 0.5;
    a[7] = -0.4;
    let mut obs = Vec::new();
    for _ in 0..8 {
        obs = env.step(&a).unwrap().0;
    }
    assert!(
        (obs[ROD_SLIDE.start + 3] - 6.0).abs() < 0.12,
        "{}",
        obs[ROD_SLIDE.start + 3]
    );
    assert!(
        (obs[ROD_ANGLE.start + 3] + 1.0).abs() < 0.02,
        "{}",
        obs[ROD_ANGLE.start + 3]
    );
    // Black's static rods stay at neutral.
    assert!(
        obs[ROD_SLIDE.start + 4..ROD_SLIDE.end]
            .iter()
            .all(|v| v.abs() < 1e-3)
    );
}

#[test]
fn hidden_black_rods_read_zero_and_change_nothing_else() {
    // Black moves at random, so its rods have values to hide.
    let mut seen = FoosballConfig::preset(Preset::Reference);
    seen.opponent = OpponentKind::Random;
    let mut hidden = seen.clone();
    hidden.observation.hide_black_rods = true;
    let (mut a, mut b) = (
        FoosballEnv::new(seen).unwrap(),
        FoosballEnv::new(hidden).unwrap(),
    );
    let (mut full, mut blind) = (a.reset(Some(5)), b.reset(Some(5)));
    let black: Vec<usize> = black_rod_inputs().collect();
    let mut rng = EnvRng::seed_from_u64(1);
    let mut moved = false;
    for _ in 0..40 {
        for i in 0..OBS_DIM {
            let expected = if black.contains(&i) { 0.0 } else { full[i] };
            assert_eq!(blind[i], expected, "observation value {i}");
        }
        moved |= black.iter().any(|&i| full[i] != 0.0);
        let action: Vec<f32> = (0..ACTION_DIM)
            .map(|_| rng.random_range(-1.0..1.0))
            .collect();
        let (x, y) = (a.step(&action).unwrap(), b.step(&action).unwrap());
        assert_eq!(x.1.reward, y.1.reward);
        (full, blind) = match x.1.done() {
            true => (a.reset(Some(6)), b.reset(Some(6))),
            false => (x.0, y.0),
        };
    }
    assert!(moved, "black's rods never left neutral: nothing was hidden");
}

#[test]
fn reward_is_alpha_minus_the_distance_to_the_goal() {
    for (xy, expected) in [
        ([0.0, 0.0], 300.0 - 64.0),
        ([6.0, 56.0], 300.0 - 10.0),
        ([-30.0, -30.0], 300.0 - (900.0_f32 + 94.0 * 94.0).sqrt()),
    ] {
        let mut env = placed(ten_ms(), xy, [0.0, 0.0]);
        let (_, t) = env.step(&NEUTRAL).unwrap();
        assert!(
            (t.reward - expected).abs() < 1e-2,
            "at {xy:?}: {} vs {expected}",
            t.reward
        );
        assert!((t.info.goal_distance - (300.0 - expected)).abs() < 1e-2);
    }
}

#[test]
fn the_distance_weighs_as_set_and_with_no_shaping_only_goals_pay() {
    let mut half = ten_ms();
    half.reward.distance_weight = 0.5;
    let mut env = placed(half, [6.0, 56.0], [0.0, 0.0]);
    let (_, t) = env.step(&NEUTRAL).unwrap();
    assert!((t.reward - (300.0 - 5.0)).abs() < 1e-2, "{}", t.reward);
    let mut goals_only = ten_ms();
    goals_only.reward.alpha = 0.0;
    goals_only.reward.distance_weight = 0.0;
    let mut env = placed(goals_only, [-30.0, -30.0], [0.0, 0.0]);
    let (_, t) = env.step(&NEUTRAL).unwrap();
    assert_eq!(t.reward, 0.0);
}

#[test]
fn a_resting_ball_ends_the_episode_as_stagnant_after_10_steps() {
    let mut env = env_with(ten_ms());
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 10);
    let last = ts.last().unwrap();
    assert_eq!(last.info.end, Some(EndReason::Stagnant));
    assert!(last.terminated && !last.truncated);
    assert!(ts[..9].iter().all(|t| !t.done()));
}

#[test]
fn a_ball_rolling_backwards_ends_the_episode_after_15_steps() {
    // Rolls towards yellow's goal at 40 cm/s through the gap at x = -30.
    let mut env = placed(ten_ms(), [-30.0, 0.0], [0.0, -40.0]);
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 15);
    assert_eq!(ts.last().unwrap().info.end, Some(EndReason::NoProgress));
    assert!(ts.last().unwrap().terminated);
}

#[test]
fn the_time_limit_truncates() {
    let config = FoosballConfig {
        max_episode_steps: 5,
        ..ten_ms()
    };
    let mut env = placed(config, [-30.0, -30.0], [0.0, 60.0]);
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 5);
    let last = ts.last().unwrap();
    assert_eq!(last.info.end, Some(EndReason::TimeLimit));
    assert!(last.truncated && !last.terminated);
    assert_eq!(env.step(&NEUTRAL).unwrap_err(), EnvError::NeedsReset);
}

#[test]
fn with_the_end_rules_off_only_the_time_limit_ends_an_episode() {
    // A goal under end_on_goal, then a stagnant ball in the goal: neither ends it.
    let mut config = end_on_goal();
    config.rules.end_episodes = false;
    config.max_episode_steps = 60;
    let mut env = placed(config, [0.0, 58.0], [0.0, 80.0]);
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 60);
    assert!(ts.iter().any(|t| t.info.in_goal));
    assert!(ts[..59].iter().all(|t| !t.done()));
    assert_eq!(ts[59].info.end, Some(EndReason::TimeLimit));
}

#[test]
fn a_reset_places_the_ball_where_asked_and_refuses_a_place_off_the_table() {
    let mut env = FoosballEnv::new(FoosballConfig::preset(Preset::Reference)).unwrap();
    let mut obs = [0.0; OBS_DIM];
    let at = |x, y| ResetOptions { ball: Some([x, y]) };
    env.reset_with(Some(1), &at(-20.0, 30.0), &mut obs).unwrap();
    // The reference's joint frame: x, y, y again.
    assert_eq!(&obs[BALL_POS], &[-20.0, 30.0, 30.0]);
    let placed_obs = obs;
    // The same seed with a drawn start draws the same episode otherwise.
    let mut drawn = [0.0; OBS_DIM];
    env.reset_with(Some(1), &ResetOptions::default(), &mut drawn)
        .unwrap();
    assert_eq!(drawn[BALL_POS.end..], placed_obs[BALL_POS.end..]);
    for bad in [[0.0, 70.0], [40.0, 0.0], [f32::NAN, 0.0]] {
        let err = env
            .reset_with(Some(1), &at(bad[0], bad[1]), &mut obs)
            .unwrap_err();
        assert!(
            matches!(err, EnvError::ResetOption { key: "ball", .. }),
            "{err}"
        );
        assert!(err.to_string().contains("playfield"), "{err}");
    }
    // A refused reset writes nothing and leaves the episode in progress as it was.
    assert_eq!(obs, placed_obs);
    let (after, _) = env.step(&NEUTRAL).unwrap();
    assert!(
        (after[0] - drawn[0]).abs() < 1.0,
        "{} against {}",
        after[0],
        drawn[0]
    );
}

#[test]
fn a_goal_terminates_with_the_bonus_under_end_on_goal() {
    let mut env = placed(end_on_goal(), [5.0, 42.0], [0.0, 300.0]);
    let ts = play_out(&mut env, 100);
    let last = ts.last().unwrap();
    assert!(last.info.scored() && last.terminated, "{:?}", last.info);
    // The step's reward is alpha - distance + beta, the ball within a few cm of (0, 64).
    assert!(last.reward > 1000.0 + 300.0 - 8.0, "reward {}", last.reward);
    assert!(ts[..ts.len() - 1].iter().all(|t| t.reward < 300.0));
}

#[test]
fn an_own_goal_is_conceded_with_the_penalty_under_end_on_goal() {
    let mut config = end_on_goal();
    config.reward.conceded_penalty = 500.0;
    config.rules.no_progress_steps = 1000;
    let mut env = placed(config, [5.0, -42.0], [0.0, -300.0]);
    let ts = play_out(&mut env, 100);
    let last = ts.last().unwrap();
    assert!(last.info.conceded() && last.terminated, "{:?}", last.info);
    let distance = last.info.goal_distance;
    assert!(distance > 2.0 * GOAL_LINE_Y - 8.0);
    assert!((last.reward - (300.0 - distance - 500.0)).abs() < 1e-2);
}

/// `config` with `rules.serve_again` and a time limit of `steps`.
fn serving(mut config: FoosballConfig, steps: u32) -> FoosballConfig {
    config.rules.serve_again = true;
    config.max_episode_steps = steps;
    config
}

#[test]
fn under_serve_again_a_dead_ball_is_served_again_on_a_neutral_table_until_the_time_limit() {
    let mut env = env_with(serving(ten_ms(), 35));
    // Yellow slides its rods out while the ball lies still: stagnant after 10 steps.
    let out = [1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0];
    let mut seen = Vec::new();
    loop {
        let (obs, t) = env.step(&out).unwrap();
        let done = t.done();
        seen.push((obs, t));
        if done {
            break;
        }
    }
    assert_eq!(seen.len(), 35, "the episode runs to its time limit");
    let serves: Vec<u32> = seen.iter().map(|(_, t)| t.info.serves).collect();
    for (i, &n) in serves.iter().enumerate() {
        assert_eq!(n, (i as u32 + 1) / 10, "serves after step {}", i + 1);
    }
    let (last_obs, last) = seen.last().unwrap();
    assert_eq!(last.info.end, Some(EndReason::TimeLimit));
    assert!(last.truncated && !last.terminated);
    assert!(last_obs.iter().all(|v| v.is_finite()));
    // The serve step: the point's reward, not an end, and a table with the rods at
    // neutral and the ball at rest on the start.
    let (before, _) = &seen[8];
    let (served, t) = &seen[9];
    assert!(t.info.end.is_none() && !t.done(), "{:?}", t.info);
    assert!(t.reward > 0.0 && t.reward < 300.0);
    assert!(before[ROD_SLIDE].iter().take(4).all(|s| s.abs() > 0.5));
    assert!(
        served[ROD_SLIDE].iter().all(|s| s.abs() < 1e-3),
        "{served:?}"
    );
    let ball = &served[BALL_POS];
    assert!(ball[0].abs() < 5.0 && ball[1].abs() < 5.0, "{ball:?}");
    assert_eq!(t.info.goals, [0, 0]);
    assert_eq!(env.step(&NEUTRAL).unwrap_err(), EnvError::NeedsReset);
}

#[test]
fn under_serve_again_goals_are_counted_and_served_again() {
    let mut env = placed(serving(end_on_goal(), 60), [5.0, 42.0], [0.0, 300.0]);
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 60);
    let goal = ts.iter().position(|t| t.info.in_goal).expect("a goal");
    let t = &ts[goal];
    assert!(t.reward > 1000.0 + 300.0 - 8.0 && !t.done(), "{:?}", t.info);
    assert_eq!((t.info.goals, t.info.serves), ([1, 0], 1));
    let last = ts.last().unwrap();
    assert_eq!(last.info.goals, [1, 0], "one goal, then still balls");
    assert!(last.info.scored() && !last.info.conceded() && last.truncated);

    let mut config = serving(end_on_goal(), 60);
    config.rules.no_progress_steps = 1000;
    let mut env = placed(config, [5.0, -42.0], [0.0, -300.0]);
    let ts = play_out(&mut env, 100);
    let last = ts.last().unwrap();
    assert_eq!(
        (last.info.goals, last.info.end),
        ([0, 1], Some(EndReason::TimeLimit))
    );
}

/// Under `start.serve = "conceded"` the side scored upon serves the next ball, a dead
/// ball is served again by the side that served it, a seeded reset serves yellow's; the
/// serves far up or down the table (start y ~ -20 cm, black's mirrored to +20) say whose.
#[test]
fn under_the_conceded_serve_rule_the_side_scored_upon_serves_next() {
    let mut config = end_on_goal();
    config.rules.no_progress_steps = 1000;
    config.start.serve = Serve::Conceded;
    (config.start.y_mean, config.start.y_std) = (-20.0, 0.1);
    let served_by_black = |obs: &[f32]| {
        let y = obs[BALL_POS.start + 1];
        assert!(y.abs() > 15.0, "a serve near the centre: {y}");
        y > 0.0
    };
    let shoot = |env: &mut FoosballEnv, into_blacks: bool| {
        let (y, v) = if into_blacks {
            (42.0, 300.0)
        } else {
            (-42.0, -300.0)
        };
        env.table_mut()
            .unwrap()
            .set_ball([5.0, y, BALL_RADIUS], [0.0, v, 0.0]);
        play_out(env, 100).last().unwrap().info.end
    };
    let mut env = FoosballEnv::new(config.clone()).unwrap();
    assert!(!served_by_black(&env.reset(Some(1))), "the first serve");
    assert_eq!(shoot(&mut env, true), Some(EndReason::Scored));
    assert!(
        served_by_black(&env.reset(None)),
        "yellow scored: black serves"
    );
    let dead = play_out(&mut env, 100).last().unwrap().info.end;
    assert_eq!(dead, Some(EndReason::Stagnant));
    assert!(
        served_by_black(&env.reset(None)),
        "a dead ball: black again"
    );
    assert_eq!(shoot(&mut env, false), Some(EndReason::Conceded));
    assert!(
        !served_by_black(&env.reset(None)),
        "black scored: yellow serves"
    );
    assert_eq!(shoot(&mut env, true), Some(EndReason::Scored));
    assert!(
        !served_by_black(&env.reset(Some(2))),
        "a seeded reset: yellow"
    );
    // Within a `serve_again` episode too.
    let mut env = FoosballEnv::new(serving(config.clone(), 200)).unwrap();
    env.reset(Some(1));
    env.table_mut()
        .unwrap()
        .set_ball([5.0, 42.0, BALL_RADIUS], [0.0, 300.0, 0.0]);
    let mut obs = Vec::new();
    while obs.is_empty() {
        let (o, t) = env.step(&NEUTRAL).unwrap();
        if t.info.serves == 1 {
            obs = o;
        }
    }
    assert!(
        served_by_black(&obs),
        "the point's goal: black serves the next ball"
    );
    // Drawing the side beside the rule is refused.
    config.start.black_share = 0.5;
    let e = FoosballEnv::new(config).err().unwrap().to_string();
    assert!(e.contains("start.black_share"), "{e}");
}

/// Under `rules.possession` a still ball within a rod's reach is that rod's, not dead: the
/// point ends when the rod has held it for its limit (a five-man rod's is shorter), and
/// the other side serves next under `start.serve = "conceded"`; out of every rod's reach
/// a still ball is dead as before, and without the rule it is dead anywhere.
#[test]
fn under_the_possession_rule_a_rod_that_holds_the_ball_too_long_loses_it() {
    let mut config = ten_ms();
    config.rules.no_progress_steps = 1000;
    config.rules.possession = true;
    config.rules.possession_limit_s = [0.2, 0.3]; // 20 and 30 agent steps of 10 ms
    config.start.serve = Serve::Conceded;
    (config.start.y_mean, config.start.y_std) = (-20.0, 0.1);
    let ends = |config: &FoosballConfig, at: [f32; 2]| {
        let mut env = placed(config.clone(), at, [0.0, 0.0]);
        let ts = play_out(&mut env, 100);
        let last = ts.last().unwrap();
        assert!(last.terminated, "{:?}", last.info);
        let served = env.reset(None)[BALL_POS.start + 1];
        (ts.len(), last.info.end, served > 0.0)
    };
    // Between the men of yellow's midfield (world y -7.5), 4.5 cm in front of its axis.
    assert_eq!(
        ends(&config, [6.0, -3.0]),
        (20, Some(EndReason::YellowHeld), true),
        "yellow's five-man rod held it 0.2 s: black serves"
    );
    // Between the men of black's attack (world y -22.5).
    assert_eq!(
        ends(&config, [9.0, -19.0]),
        (30, Some(EndReason::BlackHeld), false),
        "black's three-man rod held it 0.3 s: yellow serves"
    );
    // Between yellow's midfield and black's attack: nobody's, dead after 10 still steps.
    assert_eq!(ends(&config, [6.0, -15.0]).0, 10);
    let mut off = config.clone();
    off.rules.possession = false;
    assert_eq!(
        ends(&off, [6.0, -3.0]).1,
        Some(EndReason::Stagnant),
        "without the rule a still ball is dead anywhere"
    );
    config.rules.possession_limit_s = [0.0, 15.0];
    let e = FoosballEnv::new(config).err().unwrap().to_string();
    assert!(e.contains("rules.possession_limit_s"), "{e}");
}

/// Under `rules.end_on_lost_ball` the side whose half the ball was served on attacks,
/// and the point ends once the ball passes out of its midfield rod's reach (6.71 cm from
/// the axis, world y -7.5 for yellow, 7.5 for black) towards its own goal; a ball going
/// forward plays on, and without the rule a ball going back is played as before. Under
/// `start.serve = "conceded"` the other side serves next.
#[test]
fn under_the_lost_ball_rule_a_ball_lost_behind_the_servers_midfield_ends_the_point() {
    let mut config = ten_ms();
    config.rules.no_progress_steps = 1000;
    config.rules.end_on_lost_ball = true;
    config.start.serve = Serve::Conceded;
    (config.start.y_mean, config.start.y_std) = (-20.0, 0.1);
    let ends = |config: &FoosballConfig, at: [f32; 2], v: [f32; 2], steps: usize| {
        let mut env = placed(config.clone(), at, v);
        let ts = play_out(&mut env, steps);
        let last = ts.last().unwrap();
        let served = env.reset(None)[BALL_POS.start + 1];
        (ts.len(), last.info.end, last.terminated, served > 0.0)
    };
    // Yellow served (y = -20); the ball rolls back from y = -10 at 100 cm/s: out of the
    // midfield's reach (y < -14.21) after about 4.2 cm, 5 steps of 10 ms.
    let (steps, end, terminated, black_next) = ends(&config, [6.0, -10.0], [0.0, -100.0], 40);
    assert_eq!(end, Some(EndReason::LostBall));
    assert!(terminated && (4..=6).contains(&steps), "{steps}");
    assert!(black_next, "yellow lost the ball: black serves");
    // Rolling forward instead, it is not lost.
    let (_, end, ..) = ends(&config, [6.0, -10.0], [0.0, 100.0], 40);
    assert_ne!(end, Some(EndReason::LostBall));
    // Without the rule the ball rolling back plays on.
    let mut off = config.clone();
    off.rules.end_on_lost_ball = false;
    let (_, end, ..) = ends(&off, [6.0, -10.0], [0.0, -100.0], 40);
    assert_ne!(end, Some(EndReason::LostBall));
    // Black served: its midfield's reach ends at world y = 14.21 on black's side.
    config.start.black_share = 1.0;
    config.start.serve = Serve::Drawn;
    let (steps, end, terminated, ..) = ends(&config, [6.0, 10.0], [0.0, 100.0], 40);
    assert_eq!(end, Some(EndReason::LostBall));
    assert!(terminated && (4..=6).contains(&steps), "{steps}");
}

#[test]
fn a_non_finite_action_is_refused_and_changes_nothing() {
    let mut a = env_with(ten_ms());
    let mut b = env_with(ten_ms());
    let mut bad = [0.3; ACTION_DIM];
    bad[5] = f32::NAN;
    assert!(
        matches!(a.step(&bad), Err(EnvError::NonFiniteAction { index: 5, value }) if value.is_nan())
    );
    assert!(matches!(
        a.step(&[f32::INFINITY; ACTION_DIM]),
        Err(EnvError::NonFiniteAction { index: 0, .. })
    ));
    assert!(matches!(
        a.step(&[0.0; 3]),
        Err(EnvError::ActionDim {
            expected: 8,
            got: 3
        })
    ));
    for _ in 0..5 {
        assert_eq!(
            a.step(&[0.3; ACTION_DIM]).unwrap(),
            b.step(&[0.3; ACTION_DIM]).unwrap()
        );
    }
}

/// Plays `steps` agent steps of seeded random actions, resetting whenever an episode ends;
/// returns every observation and reward in order.
pub fn rollout(config: &FoosballConfig, seed: u64, steps: usize) -> Vec<f32> {
    let mut env = FoosballEnv::new(config.clone()).unwrap();
    let mut rng = EnvRng::seed_from_u64(seed ^ 0xACE);
    let mut trace = env.reset(Some(seed));
    for _ in 0..steps {
        let a: Vec<f32> = (0..ACTION_DIM)
            .map(|_| rng.random_range(-1.0..=1.0))
            .collect();
        let (obs, t) = env.step(&a).unwrap();
        trace.extend_from_slice(&obs);
        trace.push(t.reward);
        if t.done() {
            trace.extend(env.reset(None));
        }
    }
    trace
}

#[test]
fn same_seed_and_actions_give_identical_trajectories() {
    let config = FoosballConfig {
        opponent: foosball_rl::env::OpponentKind::Random,
        ..ten_ms()
    };
    let a = rollout(&config, 42, 5000);
    let b = rollout(&config, 42, 5000);
    assert!(
        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
        "trajectories differ"
    );
    assert_eq!(a.len(), b.len());
    let c = rollout(&config, 43, 200);
    assert_ne!(
        a[..c.len()],
        c[..],
        "another seed should give another trajectory"
    );
}

#[test]
fn the_scripted_opponent_blocks_a_shot_the_static_one_lets_in() {
    for (opponent, scores) in [
        (OpponentKind::Static, true),
        (OpponentKind::Scripted, false),
    ] {
        let config = FoosballConfig {
            opponent,
            ..ten_ms()
        };
        // The scripted goalie gets a few steps to slide over before the ball arrives.
        let mut env = placed(config, [5.0, 30.0], [0.0, 150.0]);
        let ts = play_out(&mut env, 200);
        assert_eq!(
            ts.last().unwrap().info.scored(),
            scores,
            "{opponent:?}: {:?}",
            ts.last().unwrap().info
        );
    }
}

#[test]
fn domain_randomisation_draws_within_its_ranges_per_episode() {
    let mut config = ten_ms();
    let r = &mut config.randomization;
    r.ball_mass_scale = [0.5, 1.5];
    r.ball_friction_scale = [0.8, 1.2];
    r.ball_restitution_scale = [0.9, 1.1];
    r.servo_gain_scale = [0.7, 1.3];
    r.men_friction_scale = [0.8, 1.2];
    r.position_noise_std = [0.1, 0.2];
    r.action_latency_steps = [1, 3];
    let mut env = FoosballEnv::new(config).unwrap();
    let mut masses = Vec::new();
    for seed in 0..20 {
        env.reset(Some(seed));
        let d = *env.episode_draw().unwrap();
        assert!((0.05..=0.15).contains(&d.physics.ball_mass));
        assert!((0.24..=0.36).contains(&d.physics.ball_friction));
        assert!((0.54..=0.66).contains(&d.physics.ball_restitution));
        assert!((0.7..=1.3).contains(&d.physics.servo_gain_scale));
        assert!((0.8..=1.2).contains(&d.physics.men_friction_scale));
        assert!((0.1..=0.2).contains(&d.position_noise_std));
        assert!((1..=3).contains(&d.action_latency));
        masses.push(d.physics.ball_mass);
    }
    masses.sort_by(f32::total_cmp);
    masses.dedup();
    assert_eq!(masses.len(), 20, "each episode draws anew");
}

/// The start of an episode of the ball-Fourier PPO on the MuJoCo model (its seed 3,
/// episode 1), on the fifth `reference`: the midfield's foot sweeps sideways into the ball
/// on the second step (on the model and the sixth game it passes the ball by then).
fn sideways_sweep(men_friction: f32) -> ([f32; OBS_DIM], [f32; OBS_DIM]) {
    let mut config = FoosballConfig::preset(Preset::ReferenceV5);
    config.rules.end_episodes = false;
    config.randomization.men_friction_scale = [men_friction, men_friction];
    let mut env = FoosballEnv::new(config).unwrap();
    let mut obs = [0.0; OBS_DIM];
    let ball = Some([0.312_172_7, -0.305_878_2]);
    env.reset_with(Some(3), &ResetOptions { ball }, &mut obs)
        .unwrap();
    let start = obs;
    let actions = [
        [0.5, 0.0569, 0.3906, 0.125, -0.35, 0.125, 0.6, -0.0004],
        [0.1997, 0.0795, 0.4189, 0.0846, -0.35, -0.0875, 0.6, 0.0125],
        [0.3961, 0.0241, 0.3145, -0.0161, -0.35, 0.1009, 0.6, -0.0045],
    ];
    for a in &actions {
        env.step_into(a, &mut obs).unwrap();
    }
    (start, obs)
}

#[test]
fn the_mens_friction_moves_the_ball_they_sweep_and_a_fixed_value_draws_nothing() {
    let (start, nominal) = sideways_sweep(1.0);
    let (start_low, low) = sideways_sweep(0.7);
    // No draw: the same start, and the rods that never touch the ball move alike (the
    // midfield's slide, held back by the ball it carries, does not).
    assert_eq!(start, start_low);
    for rod in [0, 1, 3] {
        assert_eq!(nominal[ROD_SLIDE.start + rod], low[ROD_SLIDE.start + rod]);
    }
    // The foot set the ball going in both; with less friction it left another way
    // (measured: (-120, 476) cm/s at nominal friction, (432, 313) at 0.7).
    let v = |o: &[f32; OBS_DIM]| [o[BALL_POS.start + 3], o[BALL_POS.start + 4]];
    let (a, b) = (v(&nominal), v(&low));
    let speed = |v: [f32; 2]| v[0].hypot(v[1]);
    assert!(speed(a) > 100.0 && speed(b) > 100.0, "{a:?} {b:?}");
    assert!(
        speed([a[0] - b[0], a[1] - b[1]]) > 100.0,
        "the men's friction changed little: {a:?} {b:?}"
    );
}

#[test]
fn position_noise_touches_positions_only() {
    let mut config = ten_ms();
    config.randomization.position_noise_std = [0.5, 0.5];
    let mut env = FoosballEnv::new(config).unwrap();
    let obs = env.reset(Some(4));
    assert!(
        (obs[2] - BALL_RADIUS).abs() > 1e-6,
        "ball z should be noisy"
    );
    assert!(obs[ROD_SLIDE].iter().all(|v| *v != 0.0));
    assert!(obs[ROD_ANGLE].iter().all(|v| *v != 0.0));
    // Velocities (ball 3..6, rods 14..22 and 30..38) are exact: all zero at rest.
    assert!(
        obs[3..6]
            .iter()
            .chain(&obs[14..22])
            .chain(&obs[30..38])
            .all(|v| *v == 0.0)
    );
}

#[test]
fn action_latency_delays_the_rods() {
    let mut config = ten_ms();
    config.randomization.action_latency_steps = [2, 2];
    let mut env = env_with(config);
    let mut a = NEUTRAL;
    a[0] = 1.0; // yellow goalie slide
    let slide = |obs: &[f32]| obs[ROD_SLIDE.start];
    let first = env.step(&a).unwrap().0;
    let second = env.step(&a).unwrap().0;
    let third = env.step(&a).unwrap().0;
    assert_eq!(slide(&first), 0.0);
    assert_eq!(slide(&second), 0.0);
    assert!(
        slide(&third) > 0.5,
        "the command arrives on the third step: {}",
        slide(&third)
    );
}

#[test]
fn a_physics_fault_truncates_with_a_finite_observation() {
    // A ball knocked off the table.
    let mut env = env_with(ten_ms());
    env.table_mut()
        .unwrap()
        .set_ball([0.0, 0.0, 60.0], [0.0, 0.0, 500.0]);
    let (obs, t) = env.step(&NEUTRAL).unwrap();
    assert!(
        t.info.physics_fault() && t.truncated && !t.terminated,
        "{:?}",
        t.info
    );
    assert!(obs.iter().all(|v| v.is_finite()));

    // A non-finite state: the last good observation comes back, and the reward is finite.
    let mut env = env_with(ten_ms());
    let (good, _) = env.step(&NEUTRAL).unwrap();
    env.table_mut()
        .unwrap()
        .set_ball([f32::NAN, 0.0, BALL_RADIUS], [0.0, 0.0, 0.0]);
    let (obs, t) = env.step(&NEUTRAL).unwrap();
    assert!(t.info.physics_fault() && t.truncated, "{:?}", t.info);
    assert_eq!(obs, good);
    assert!(
        t.reward.is_finite() && t.info.goal_distance.is_finite() && t.info.ball_speed.is_finite()
    );
    assert_eq!(env.step(&NEUTRAL).unwrap_err(), EnvError::NeedsReset);
    assert!(env.reset(None).iter().all(|v| v.is_finite()));
}

/// The reference table with the stagnation and no-progress ends off, `spin` under a
/// 90-degree limit (its position servos hold a rod within +-2.5 rad, so a full swing,
/// about 286 degrees, never makes ITSF's 360).
fn swinging_table(spin: SpinRule) -> FoosballConfig {
    let mut c = FoosballConfig::preset(Preset::Reference);
    c.rules.stagnant_steps = u32::MAX;
    c.rules.no_progress_steps = u32::MAX;
    c.rules.spin = spin;
    c.rules.spin_limit_deg = 90.0;
    c
}

/// Yellow's goalie swung from one end of its range to the other every 100 steps.
fn swing(step: usize) -> [f32; ACTION_DIM] {
    let mut a = NEUTRAL;
    a[action_turn(0)] = if (step / 100).is_multiple_of(2) {
        1.0
    } else {
        -1.0
    };
    a
}

#[test]
fn spins_are_counted_and_cost_the_penalty_or_end_the_episode_by_rule() {
    let (mut off, mut penalty) = (
        env_with(swinging_table(SpinRule::Off)),
        env_with(swinging_table(SpinRule::Penalty)),
    );
    let mut spins = 0;
    for step in 0..600 {
        let a = swing(step);
        let (_, t_off) = off.step(&a).unwrap();
        let (_, t_pen) = penalty.step(&a).unwrap();
        assert_eq!(
            t_off.info.spins, t_pen.info.spins,
            "the rule changes no physics"
        );
        let new = t_off.info.spins[0] - spins;
        spins = t_off.info.spins[0];
        assert!(
            (t_off.reward - t_pen.reward - 1000.0 * new as f32).abs() < 1e-3,
            "step {step}: {} vs {} with {new} new spins",
            t_off.reward,
            t_pen.reward
        );
        assert_eq!(t_off.info.spins[1], 0, "the static black never turns");
        assert!(t_off.info.end.is_none());
    }
    // From neutral to one end (143 degrees: one spin), then five swings end to end of
    // about 286 degrees (three spins each, the remainder dropped at each turn back).
    assert_eq!(spins, 16);

    let mut foul = env_with(swinging_table(SpinRule::Foul));
    let ended = (0..600).find_map(|step| {
        let (_, t) = foul.step(&swing(step)).unwrap();
        t.done().then_some((step, t))
    });
    let (step, t) = ended.expect("the foul ends the episode");
    assert_eq!(t.info.end, Some(EndReason::SpinFoul));
    assert!(t.terminated && !t.truncated);
    assert_eq!(t.info.spins[0], 1);
    assert!(step < 100, "the first swing fouls, ended at step {step}");
}

/// A snapshot taken in the middle of an episode (the ball in play, contacts under way)
/// steps on as the original does, to the bit, under MuJoCo's soft contacts and rapier's,
/// with a scripted black and a random one.
#[test]
fn a_snapshot_steps_on_as_the_table_it_was_taken_from() {
    for (preset, opponent) in [
        (Preset::Reference, OpponentKind::Static),
        (Preset::ReferenceV3, OpponentKind::Random),
        (Preset::Reference, OpponentKind::Shooter),
    ] {
        let mut config = FoosballConfig::preset(preset);
        config.opponent = opponent;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut actions = (0..400)
            .map(|_| -> [f32; ACTION_DIM] { std::array::from_fn(|_| rng.random_range(-1.0..1.0)) });
        let mut original = FoosballEnv::new(config).unwrap();
        let mut checked = 0;
        for seed in 0..6 {
            original.reset(Some(seed));
            for _ in 0..7 {
                original.step(&actions.next().unwrap()).unwrap();
            }
            let mut copy = original.snapshot().expect("a scripted black copies");
            assert_eq!(copy.state(), original.state());
            for a in actions.by_ref().take(40) {
                let (a_obs, a_t) = original.step(&a).unwrap();
                let (b_obs, b_t) = copy.step(&a).unwrap();
                assert_eq!(
                    a_obs, b_obs,
                    "{preset:?}: step {checked} after the snapshot"
                );
                assert_eq!((a_t.reward, a_t.info.end), (b_t.reward, b_t.info.end));
                checked += 1;
                if a_t.done() {
                    break;
                }
            }
        }
        assert!(checked > 60, "{preset:?}: {checked} steps compared");
    }
}

/// `obs` reflected in the table's long axis (x -> -x): the ball's x and x velocity and
/// every rod's slide and slide velocity change sign; y, angles and angular velocities stay.
fn reflected(obs: &[f32]) -> Vec<f32> {
    use foosball_rl::env::layout::{BALL_VEL, ROD_SLIDE_VEL};
    let mut out = obs.to_vec();
    let flipped = [BALL_POS.start, BALL_VEL.start]
        .into_iter()
        .chain(ROD_SLIDE)
        .chain(ROD_SLIDE_VEL);
    for i in flipped {
        out[i] = -obs[i];
    }
    out
}

/// The ball at (±x, -4) cm, yellow's commands mirrored (slides negated): the largest gap
/// between the two observations (one reflected) over each of the first `steps` steps, and
/// how far apart the balls are at the end (cm).
fn mirrored_play(x: f32, steps: usize) -> (Vec<f32>, f32) {
    let new = || FoosballEnv::new(FoosballConfig::preset(Preset::Reference)).unwrap();
    let (mut left, mut right) = (new(), new());
    let (mut a, mut b) = ([0.0; OBS_DIM], [0.0; OBS_DIM]);
    let at = |x| ResetOptions {
        ball: Some([x, -4.0]),
    };
    left.reset_with(Some(1), &at(-x), &mut a).unwrap();
    right.reset_with(Some(1), &at(x), &mut b).unwrap();
    // The planner's first kick (docs/journal/study.md): midfield slide -0.66, turn +0.86.
    let mut action = NEUTRAL;
    action[4] = -0.66;
    action[5] = 0.86;
    let mut mirrored = action;
    mirrored[4] = 0.66;
    let mut gaps = Vec::new();
    let mut apart = 0.0;
    for _ in 0..steps {
        let (oa, ta) = left.step(&action).unwrap();
        let (ob, tb) = right.step(&mirrored).unwrap();
        let ra = reflected(&oa);
        gaps.push(
            ra.iter()
                .zip(&ob)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f32::max),
        );
        apart = (ra[0] - ob[0]).hypot(ra[1] - ob[1]);
        if ta.done() || tb.done() {
            break;
        }
    }
    (gaps, apart)
}

/// The table mirrors itself in its long axis until a man touches the ball: out of the
/// men's reach the two episodes stay exact mirror images, rods and ball; once the midfield
/// man strikes the ball they part (the men's contact is not symmetric), which is why no
/// learner is trained on reflected transitions (docs/journal/study.md, "More options on the
/// normalised learners").
#[test]
fn the_table_mirrors_itself_until_a_man_touches_the_ball() {
    let (gaps, apart) = mirrored_play(0.3, 40);
    assert!(gaps.iter().all(|&g| g < 1e-4), "{gaps:?}");
    assert!(apart < 1e-4, "{apart}");
    let (gaps, apart) = mirrored_play(1.5, 11);
    assert_eq!(gaps.len(), 11);
    assert!(
        apart > 2.0,
        "the struck balls {apart} cm apart after 11 steps"
    );
}
