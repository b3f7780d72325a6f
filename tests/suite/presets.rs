//! The rule presets: a ball in the goal earns beta on every step without ending the
//! episode (paper presets), the reference's counters end episodes at 20 ms and 30 ms,
//! end_on_goal still ends on a goal, presets load from TOML with overrides, and the
//! scripted shooter scores where the ball starts in reach.

use foosball_rl::env::{
    EndReason, Env, FoosballConfig, FoosballEnv, Preset, StepInfo, ball_in_a_goal,
};
use foosball_rl::play::scripted::ScriptedPolicy;

use crate::common;

use common::{placed, play_out};

/// A fresh episode of `preset` with the ball placed at `xy` moving at `v` (cm/s).
fn placed_in(preset: Preset, xy: [f32; 2], v: [f32; 2]) -> FoosballEnv {
    placed(FoosballConfig::preset(preset), xy, v)
}

#[test]
fn under_the_paper_rules_a_ball_in_the_goal_earns_beta_every_step() {
    for preset in [Preset::Paper, Preset::PaperV1] {
        // At rest in the pocket, 1 cm past the goal line at x = 0.
        let mut env = placed_in(preset, [0.0, 65.0], [0.0, 0.0]);
        let ts = play_out(&mut env, 100);
        // It does not end there: the stagnation rule ends it after 10 steps.
        assert_eq!(ts.len(), 10, "{preset:?}");
        assert_eq!(ts.last().unwrap().info.end, Some(EndReason::Stagnant));
        for t in &ts {
            assert!(t.info.in_goal && t.info.scored(), "{:?}", t.info);
            let expected = 300.0 - t.info.goal_distance + 1000.0;
            assert!(
                (t.reward - expected).abs() < 1e-3,
                "{} vs {expected}",
                t.reward
            );
            assert!(t.reward > 1290.0);
        }
        // It ends absorbing: the ball stays in the goal (what `absorbing_ends` values),
        // and the recorded state says so too (what demonstrations are read by).
        assert!(ts.last().unwrap().info.absorbing(), "{preset:?}");
        assert!(ball_in_a_goal(env.config(), env.state().unwrap()));
        // A ball at rest on the table ends the same way, not absorbing.
        let mut env = placed_in(preset, [0.0, 20.0], [0.0, 0.0]);
        let ts = play_out(&mut env, 100);
        let last = ts.last().unwrap();
        assert!(last.terminated && !last.info.absorbing(), "{:?}", last.info);
        assert!(!ball_in_a_goal(env.config(), env.state().unwrap()));
    }
}

#[test]
fn under_the_reference_rules_the_goal_pays_beta_alone_and_the_own_goal_is_out_of_reach() {
    // The code's goal line y > 65 is world y > 61 (its frame starts at the ball body,
    // world y = -4).
    let mut env = placed_in(Preset::Reference, [0.0, 61.5], [0.0, 0.0]);
    let ts = play_out(&mut env, 100);
    assert!(ts.iter().all(|t| t.reward == 1000.0), "{:?}", ts[0]);
    let mut env = placed_in(Preset::Reference, [0.0, 60.5], [0.0, 0.0]);
    assert!(!play_out(&mut env, 1)[0].info.in_goal);
    // Its own-goal line y < -65 is world y < -69, behind the pocket: never reached.
    let mut env = placed_in(Preset::Reference, [0.0, -66.0], [0.0, 0.0]);
    let t = play_out(&mut env, 1).remove(0);
    assert!(!t.info.in_own_goal && !t.info.conceded());
    // The first reference read the same numbers in world coordinates.
    let mut env = placed_in(Preset::ReferenceV1, [0.0, -65.5], [0.0, 0.0]);
    let t = play_out(&mut env, 1).remove(0);
    assert!(t.info.in_own_goal && t.info.conceded());
    let expected = 300.0 - t.info.goal_distance - 1000.0;
    assert!(
        (t.reward - expected).abs() < 1e-3,
        "{} vs {expected}",
        t.reward
    );
    let mut env = placed_in(Preset::ReferenceV1, [0.0, 64.5], [0.0, 0.0]);
    assert!(!play_out(&mut env, 1)[0].info.in_goal);
    let mut env = placed_in(Preset::PaperV1, [0.0, 64.5], [0.0, 0.0]);
    assert!(play_out(&mut env, 1)[0].info.in_goal);
}

#[test]
fn the_reference_counters_end_episodes_after_20_ms_and_30_ms() {
    let config = FoosballConfig::preset(Preset::Reference);
    let agent_dt = config.agent_dt();
    assert_eq!(agent_dt, 0.002);
    assert_eq!(config.max_episode_steps as f32 * agent_dt, 40.0);
    // A resting ball: 10 steps of 2 ms.
    let mut env = placed_in(Preset::Reference, [-30.0, 0.0], [0.0, 0.0]);
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 10);
    assert_eq!(ts.last().unwrap().info.end, Some(EndReason::Stagnant));
    // A ball rolling towards yellow's goal (placed behind its start, so that no step
    // gains y): 15 steps of 2 ms.
    let mut env = placed_in(Preset::Reference, [-30.0, -10.0], [0.0, -40.0]);
    let ts = play_out(&mut env, 100);
    assert_eq!(ts.len(), 15);
    assert_eq!(ts.last().unwrap().info.end, Some(EndReason::NoProgress));
    // The paper's presets count the same rules in 10 ms agent steps.
    let paper = FoosballConfig::preset(Preset::Paper);
    assert!((paper.agent_dt() - 0.01).abs() < 1e-7);
}

#[test]
fn end_on_goal_ends_the_episode_with_one_bonus() {
    let mut env = placed_in(Preset::EndOnGoal, [5.0, 42.0], [0.0, 300.0]);
    let ts = play_out(&mut env, 100);
    let last = ts.last().unwrap();
    assert_eq!(last.info.end, Some(EndReason::Scored));
    assert!(last.terminated && last.info.scored());
    assert!(last.reward > 1000.0 + 300.0 - 8.0, "reward {}", last.reward);
    assert!(ts[..ts.len() - 1].iter().all(|t| t.reward < 300.0));
    // The same shot under the paper's rules goes on after the goal.
    let mut env = placed_in(Preset::Paper, [5.0, 42.0], [0.0, 300.0]);
    let ts = play_out(&mut env, 200);
    let first_in = ts.iter().position(|t| t.info.in_goal).expect("scores");
    assert!(ts.len() > first_in + 1 && !ts[first_in].done());
}

#[test]
fn presets_load_from_toml_with_overrides() {
    let c: FoosballConfig = toml::from_str("preset = \"reference\"\nframe_skip = 2\n").unwrap();
    assert_eq!(c.preset, Preset::Reference);
    assert_eq!(c.frame_skip, 2);
    assert_eq!(c.max_episode_steps, 20_000);
    assert!(c.reward.zero_shaping_in_goal && c.ball.planar);
    let c: FoosballConfig = toml::from_str("[start]\ny_std = 0.0\n").unwrap();
    assert_eq!(c, {
        let mut d = FoosballConfig::preset(Preset::Reference);
        d.start.y_std = 0.0;
        d
    });
    // What a run saves reads back as the same configuration.
    let saved = toml::to_string(&c).unwrap();
    assert_eq!(toml::from_str::<FoosballConfig>(&saved).unwrap(), c);
    let e = toml::from_str::<FoosballConfig>("preset = \"papr\"").unwrap_err();
    assert!(e.to_string().contains("unknown preset `papr`"), "{e}");
    let e = toml::from_str::<FoosballConfig>("preset = \"paper_reachable\"").unwrap_err();
    assert!(e.to_string().contains("paper_v1"), "{e}");
    let e = toml::from_str::<FoosballConfig>("action_map = \"cubic\"").unwrap_err();
    assert!(e.to_string().contains("cubic"), "{e}");
    let e = toml::from_str::<FoosballConfig>("[ball]\nmodel = \"bouncy\"").unwrap_err();
    assert!(e.to_string().contains("bouncy"), "{e}");
    let e = toml::from_str::<FoosballConfig>("[rules]\nend_on_gol = true").unwrap_err();
    assert!(e.to_string().contains("end_on_gol"), "{e}");
}

/// Plays `episodes` episodes of `policy` on `config` (seeds 0..episodes, one env):
/// `(scored, kicked)`, the episodes whose ball entered black's goal and those whose ball
/// ever went faster than 100 cm/s.
fn outcomes(config: &FoosballConfig, policy: ScriptedPolicy, episodes: u64) -> (usize, usize) {
    let mut env = FoosballEnv::new(config.clone()).unwrap();
    let mut act = policy.batch_policy(0, config).unwrap();
    let (mut scored, mut kicked) = (0, 0);
    for seed in 0..episodes {
        let mut obs = env.reset(Some(seed));
        let mut fast = false;
        loop {
            let (next, t) = env.step(&act(&obs).unwrap()).unwrap();
            obs = next;
            fast |= t.info.ball_speed > 100.0;
            if t.done() {
                scored += usize::from(t.info.scored());
                kicked += usize::from(fast);
                break;
            }
        }
    }
    (scored, kicked)
}

#[test]
fn the_shooter_scores_where_the_ball_is_in_reach_and_standing_still_never_does() {
    for preset in [Preset::Paper, Preset::Reference] {
        let config = FoosballConfig::preset(preset);
        let (scored, kicked) = outcomes(&config, ScriptedPolicy::Shooter, 400);
        eprintln!("{preset:?}: the shooter scored {scored} and kicked {kicked} of 400");
        // Measured: every start is kicked; 4 (paper) and 2 (reference) of 400 score. The
        // shooter was tuned on the rolling ball: on the code's dead, sliding one it is weak.
        assert!(
            scored >= 1 && kicked == 400,
            "{preset:?}: {scored}, {kicked} of 400"
        );
        assert_eq!(outcomes(&config, ScriptedPolicy::Zero, 40), (0, 0));
    }
    // The text's start read in world coordinates is out of reach: the shooter never
    // touches the ball.
    let paper = FoosballConfig::preset(Preset::PaperV1);
    assert_eq!(outcomes(&paper, ScriptedPolicy::Shooter, 20), (0, 0));
}
