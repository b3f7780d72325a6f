//! Two-sided play: a policy plays black through the mirrored view exactly as it plays
//! yellow, matches replay from their seed, bad contestants are refused by name.

use foosball_rl::env::layout::mirror_observation;
use foosball_rl::env::{Env, FoosballConfig, FoosballEnv, OpponentKind, Preset};
use foosball_rl::play::contestant::Contestant;
use foosball_rl::play::matches::{MatchRules, PolicyOpponent, match_table, play_match};
use foosball_rl::play::scripted::ScriptedPolicy;

/// The match table of `preset` with the ball served at rest at world (x, y).
fn served_at(preset: Preset, x: f32, y: f32) -> FoosballConfig {
    let mut t = match_table(&FoosballConfig::preset(preset), &MatchRules::default());
    let [ox, oy, _] = t.ball_frame.origin();
    t.start.x_mean = x - ox;
    t.start.y_mean = y - oy;
    t.start.x_std = 0.0;
    t.start.y_std = 0.0;
    t
}

/// The world states of `steps` steps on `preset`'s match table: `yellow` against `black`
/// from a serve at (x, y).
fn states(
    preset: Preset,
    yellow: ScriptedPolicy,
    black: ScriptedPolicy,
    x: f32,
    y: f32,
    steps: usize,
) -> Vec<[f32; 38]> {
    let table = served_at(preset, x, y);
    let black = PolicyOpponent::new(
        Contestant::Scripted(black).policy(&table, 1).unwrap(),
        table.ball_frame,
    );
    let env = FoosballEnv::with_opponent(table.clone(), Box::new(black)).unwrap();
    trace(env, &table, yellow, steps)
}

/// The world states of `steps` steps of `env` (reset with seed 3), yellow played by
/// `yellow` on `table`.
fn trace(
    mut env: FoosballEnv,
    table: &FoosballConfig,
    yellow: ScriptedPolicy,
    steps: usize,
) -> Vec<[f32; 38]> {
    let mut act = Contestant::Scripted(yellow).policy(table, 1).unwrap();
    let mut obs = env.reset(Some(3));
    let mut out = vec![*env.state().unwrap()];
    for _ in 0..steps {
        let (next, t) = env.step(&act(&obs).unwrap()).unwrap();
        out.push(*env.state().unwrap());
        obs = next;
        if t.done() {
            break;
        }
    }
    out
}

#[test]
fn a_policy_plays_black_as_the_mirror_image_of_yellow() {
    // The shooter as yellow against a static black, served at (2, 26): the same
    // shooter as black against a static yellow, served at (-2, -26), plays the mirror
    // image, kick included: 400 steps (0.8 s), the ball kicked at 470 cm/s, every value
    // within 1 % (measured: at most 0.019 apart; rapier's sums run in another order on
    // the mirrored side, so not bit for bit). On `reference_v4`'s contacts: `reference`'s
    // SDF search starts from the same points in world axes on either side, as MuJoCo's
    // does, so its contacts on black's men are not the mirror image of yellow's (at the
    // kick, 2 % apart).
    let (x, y) = (2.0, 26.0);
    let v4 = Preset::ReferenceV4;
    let as_yellow = states(v4, ScriptedPolicy::Shooter, ScriptedPolicy::Zero, x, y, 400);
    let as_black = states(
        v4,
        ScriptedPolicy::Zero,
        ScriptedPolicy::Shooter,
        -x,
        -y,
        400,
    );
    assert!(
        as_yellow.len() > 50,
        "the shooter played {} steps",
        as_yellow.len()
    );
    let top_speed = as_yellow
        .iter()
        .map(|s| s[3].hypot(s[4]))
        .fold(0.0, f32::max);
    assert!(
        top_speed > 200.0,
        "the shooter never kicked: {top_speed} cm/s"
    );
    assert_eq!(as_yellow.len(), as_black.len());
    for (k, (a, b)) in as_yellow.iter().zip(&as_black).enumerate() {
        let mirrored = mirror_observation(a);
        for (i, (m, b)) in mirrored.iter().zip(b).enumerate() {
            assert!(
                (m - b).abs() <= 1e-2 * (1.0 + m.abs()),
                "step {k}, value {i}: {m} vs {b}"
            );
        }
    }
}

#[test]
fn the_blocker_contestant_is_the_tables_scripted_black() {
    // `blocker` on black, through the mirrored view and the ball frame, plays what the
    // table's own `opponent = "scripted"` plays: the shooter against either, served at
    // (2, 26), gives the same states (within float rounding of the frame changes), and
    // black's rods do move to follow the ball.
    let (x, y) = (2.0, 26.0);
    let contestant = states(
        Preset::Reference,
        ScriptedPolicy::Shooter,
        ScriptedPolicy::Blocker,
        x,
        y,
        400,
    );
    let mut table = served_at(Preset::Reference, x, y);
    table.opponent = OpponentKind::Scripted;
    let env = FoosballEnv::new(table.clone()).unwrap();
    let built_in = trace(env, &table, ScriptedPolicy::Shooter, 400);
    assert_eq!(contestant.len(), built_in.len());
    for (k, (a, b)) in contestant.iter().zip(&built_in).enumerate() {
        for (i, (a, b)) in a.iter().zip(b).enumerate() {
            assert!(
                (a - b).abs() <= 1e-3 * (1.0 + a.abs()),
                "step {k}, value {i}: {a} vs {b}"
            );
        }
    }
    // Black's slides (state 10..14, cm) leave neutral to track the ball.
    let slid = contestant
        .iter()
        .flat_map(|s| s[10..14].iter())
        .fold(0.0_f32, |m, v| m.max(v.abs()));
    assert!(slid > 1.0, "black's rods never slid: {slid} cm");
}

#[test]
fn a_match_replays_from_its_seed() {
    let table = match_table(&FoosballConfig::default(), &MatchRules::default());
    let rules = MatchRules {
        time_limit_s: 10.0,
        ..MatchRules::default()
    };
    let shooter = Contestant::Scripted(ScriptedPolicy::Shooter);
    let random = Contestant::Scripted(ScriptedPolicy::Random);
    let a = play_match(&table, &rules, &shooter, &random, 7).unwrap();
    let b = play_match(&table, &rules, &shooter, &random, 7).unwrap();
    assert_eq!(a, b);
    assert!(a.serves >= 1 && a.steps > 0 && a.steps <= 5000);
    let c = play_match(&table, &rules, &random, &shooter, 7).unwrap();
    assert_ne!(a, c, "sides swapped, the same serves give another match");
}

#[test]
fn bad_contestants_are_refused_by_name() {
    let e = "shoter".parse::<Contestant>().unwrap_err();
    assert!(e.contains("shoter") && e.contains("scripted policy"), "{e}");
    assert_eq!(
        "blocker".parse::<Contestant>(),
        Ok(Contestant::Scripted(ScriptedPolicy::Blocker))
    );
    let e = "results/figure2/sac-seed0@middle"
        .parse::<Contestant>()
        .unwrap_err();
    assert!(e.contains("@middle"), "{e}");
    // A run of the first game (world frame, linear actions) cannot play the code's table.
    let old: Contestant = "results/figure2-v1/sac-seed0".parse().unwrap();
    let table = match_table(&FoosballConfig::default(), &MatchRules::default());
    let e = old.policy(&table, 0).err().unwrap();
    assert!(
        e.contains("figure2-v1/sac-seed0") && e.contains("ball_frame"),
        "{e}"
    );
    let rules = MatchRules {
        goals_to_win: 0,
        ..MatchRules::default()
    };
    assert!(
        rules
            .validate()
            .unwrap_err()
            .starts_with("match.goals_to_win")
    );
}

#[test]
fn a_run_plays_a_table_of_the_other_action_map_with_its_own_servo_targets() {
    use foosball_rl::env::config::{ActionMap, control_range};
    use foosball_rl::env::layout::ACTION_DIM;
    // A self-play run trained under the linear map (ball frame joint) on the code's
    // saturating table: its actions are translated so that they set the servo targets
    // they set on a linear table.
    let run: Contestant = "results/league/self-play-ppo-kickstart-shooter-seed0"
        .parse()
        .unwrap();
    let saturating = match_table(&FoosballConfig::default(), &MatchRules::default());
    let mut linear = saturating.clone();
    linear.action_map = ActionMap::Linear;
    let mut on_saturating = run.policy(&saturating, 0).unwrap();
    let mut on_linear = run.policy(&linear, 0).unwrap();
    let mut env = FoosballEnv::new(saturating.clone()).unwrap();
    let (mut translated, mut saturated_untranslated) = (0, 0);
    for seed in 0..20 {
        let mut obs = env.reset(Some(seed));
        for _ in 0..25 {
            let (a, b) = (on_saturating(&obs).unwrap(), on_linear(&obs).unwrap());
            for i in 0..ACTION_DIM {
                let range = control_range(i);
                let (want, got) = (
                    ActionMap::Linear.target(b[i], range),
                    ActionMap::Saturating.target(a[i], range),
                );
                assert!((want - got).abs() <= 1e-5 * range, "[{i}] {want} {got}");
                translated += usize::from(a[i] != b[i]);
                saturated_untranslated +=
                    usize::from((ActionMap::Saturating.target(b[i], range) - want).abs() > 0.01);
            }
            obs = env.step(&a).unwrap().0;
        }
    }
    // The translation did something: untranslated, most of these actions would have set
    // other targets.
    assert!(
        translated > 3000 && saturated_untranslated > 1000,
        "{translated} {saturated_untranslated}"
    );
}

#[test]
fn a_head_to_head_swaps_sides_on_the_same_serves() {
    use foosball_rl::play::matches::{head_to_head, round_seed};
    let table = match_table(&FoosballConfig::default(), &MatchRules::default());
    let rules = MatchRules {
        time_limit_s: 3.0,
        ..MatchRules::default()
    };
    let shooter = Contestant::Scripted(ScriptedPolicy::Shooter);
    let random = Contestant::Scripted(ScriptedPolicy::Random);
    let played = head_to_head(&table, &rules, &shooter, &random, 2, 9).unwrap();
    let sides: Vec<bool> = played.iter().map(|p| p.a_on_yellow).collect();
    assert_eq!(sides, [true, false, true, false]);
    // Match 1 of round 1 is the shooter on black against random, served from round 1's seed.
    let again = play_match(&table, &rules, &random, &shooter, round_seed(9, 1)).unwrap();
    assert_eq!(played[3].result, again);
    // Its ball flow tells the same goals and lasts as long as the match.
    for p in &played {
        let (me, flow) = (p.a_side(), p.flow.side(p.a_on_yellow));
        assert_eq!((flow.scored, flow.let_in), (me.scored, me.let_in));
        let steps = flow.own_reach.iter().chain(&flow.their_reach).sum::<u64>() + flow.no_reach;
        assert_eq!(steps, p.result.steps);
        assert_eq!(
            flow.time_limits,
            u32::from(me.scored.max(me.let_in) < rules.goals_to_win)
        );
        assert_eq!(p.flow.side(!p.a_on_yellow).attacks_past, flow.let_past);
        assert_eq!(flow.own_serves + flow.their_serves, p.result.serves);
        assert!(flow.scored_on_own_serve + flow.scored_on_their_serve <= me.scored + me.let_in);
    }
}

#[test]
fn the_side_scored_upon_serves_next() {
    use foosball_rl::env::geometry::Team;
    use foosball_rl::env::layout::BALL_POS;
    use foosball_rl::play::matches::{Kickoff, round_seed};
    // Black's serve is yellow's turned 180 degrees about the centre. On the fifth
    // `reference`, where the matches' goals below were counted (the rule is any game's).
    let table = match_table(
        &FoosballConfig::preset(Preset::ReferenceV5),
        &MatchRules::default(),
    );
    let ball = |side| {
        let mut env = FoosballEnv::new(table.clone()).unwrap();
        env.serve_on(side);
        env.reset(Some(5));
        let s = env.state().unwrap();
        [s[BALL_POS.start], s[BALL_POS.start + 1]]
    };
    let [yellow, black] = [ball(Team::Yellow), ball(Team::Black)];
    assert!(
        yellow[1] < 0.0,
        "yellow's serve lies on its side: {yellow:?}"
    );
    assert_eq!(black, [-yellow[0], -yellow[1]]);

    let rules = |kickoff| MatchRules {
        kickoff,
        ..MatchRules::default()
    };
    let [itsf, yellow_serves] = [Kickoff::Conceded, Kickoff::Yellow].map(rules);
    let random = Contestant::Scripted(ScriptedPolicy::Random);
    let shooter = Contestant::Scripted(ScriptedPolicy::Shooter);
    let zero = Contestant::Scripted(ScriptedPolicy::Zero);
    let play = |r: &MatchRules, y: &Contestant, b: &Contestant, seed| {
        play_match(&table, r, y, b, seed).unwrap()
    };
    // Yellow serves under both rules until it scores: a match it never scores in is the
    // same match (random on yellow, the shooter scoring 5 from its serves).
    let seed = round_seed(0, 0);
    let m = play(&yellow_serves, &random, &shooter, seed);
    assert_eq!((m.yellow_goals, m.black_goals), (0, 5));
    assert_eq!(play(&itsf, &random, &shooter, seed), m);
    // Random scores past the static black from its own serves (4:2 on the corrected
    // `reference`, the 2 own goals of its flailing; 2:0 on `reference_v2`); under ITSF's
    // rule every goal hands black the serve, and the match goes otherwise.
    let seed = round_seed(2, 0);
    let m = play(&yellow_serves, &random, &zero, seed);
    assert!(m.yellow_goals > 0, "{m:?}");
    assert_ne!(play(&itsf, &random, &zero, seed), m);
}

/// Under ITSF's possession limits a served ball that nobody plays is the serving side's
/// midfield's, not a dead ball: after 10 s it goes to the other side, instead of being
/// served again by the same side every second.
#[test]
fn a_ball_nobody_plays_changes_sides_under_the_possession_limits() {
    use foosball_rl::env::EndReason;
    use foosball_rl::env::geometry::Team;
    use foosball_rl::env::layout::BALL_POS;
    let zero = Contestant::Scripted(ScriptedPolicy::Zero);
    let rules = |possession| MatchRules {
        time_limit_s: 30.0,
        possession,
        ..MatchRules::default()
    };
    let play = |r: &MatchRules| {
        let table = match_table(&FoosballConfig::default(), r);
        play_match(&table, r, &zero, &zero, 3).unwrap()
    };
    let dead = play(&rules(false));
    assert_eq!((dead.yellow_goals, dead.black_goals), (0, 0));
    assert!(dead.serves >= 25, "a dead ball every second: {dead:?}");
    let held = play(&rules(true));
    assert_eq!((held.yellow_goals, held.black_goals), (0, 0));
    assert_eq!(
        held.serves, 3,
        "held 10 s each, then the other side: {held:?}"
    );
    // Each serve lies by the serving side's midfield, which holds it until its limit.
    let table = match_table(&FoosballConfig::default(), &rules(true));
    for (side, held) in [
        (Team::Yellow, EndReason::YellowHeld),
        (Team::Black, EndReason::BlackHeld),
    ] {
        let mut env = FoosballEnv::new(table.clone()).unwrap();
        env.serve_on(side);
        let served = env.reset(Some(1))[BALL_POS.start + 1];
        assert_eq!(served > 0.0, side == Team::Black, "{served}");
        let (mut end, mut steps) = (None, 0);
        while end.is_none() {
            end = env.step(&[0.0; 8]).unwrap().1.info.end;
            steps += 1;
        }
        assert_eq!((end, steps), (Some(held), 5000), "10 s of 2 ms steps");
    }
}
