//! Self-play training: the pool fills with snapshots on schedule, every training episode
//! is recorded against the opponent it was drawn, snapshots play as contestants, a trained
//! run plays black as a rival, a run is the same on one thread or two, and bad settings
//! are refused by key; a run starts from saved networks (`protocol.init_from`, the way to
//! fine-tune a trained agent by self-play).

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_rl::config::RunConfig;
use foosball_rl::play::contestant::Contestant;
use foosball_rl::play::matches::{MatchRules, match_table, play_match};
use foosball_rl::run::train::{Start, train};
use std::path::Path;

const SELF_PLAY: &str = "[self_play]\nsnapshot_every = 100\npool_size = 2\nlatest_share = 0.4\n\
                         anchor_share = 0.3\nanchors = [\"static\", \"random\", \"shooter\"]\n\
                         rivals = [\"blocker\"]\n";

fn config(threads: usize) -> RunConfig {
    let text = tiny_config_text("sac", 2, 200)
        .replace("envs = 2", &format!("envs = 2\nthreads = {threads}"))
        + SELF_PLAY;
    RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap()
}

fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

#[test]
fn the_pool_takes_snapshots_and_records_every_training_episode() {
    let dir = scratch("self-play-pool");
    let c = config(1);
    train(&c, &dir, Start::Fresh, |_| {}).unwrap();
    let pool = dir.join("pool");
    for step in [0, 100, 200, 300, 400] {
        let snap = pool.join(format!("step-{step:09}"));
        assert!(snap.join("config.toml").is_file(), "{}", snap.display());
        assert!(snap.join("last").is_dir(), "{}", snap.display());
    }
    let records = json(&pool.join("pool.json"));
    assert_eq!(records["env_steps"], 400);
    let rows = records["opponents"].as_array().unwrap();
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["opponent"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "static",
            "random",
            "shooter",
            "blocker",
            "step-000000000",
            "step-000000100",
            "step-000000200",
            "step-000000300",
            "step-000000400"
        ]
    );
    // pool_size = 2: the two newest snapshots are in play.
    let in_play: Vec<bool> = rows
        .iter()
        .map(|r| r["in_play"].as_bool().unwrap())
        .collect();
    assert_eq!(
        in_play,
        [true, true, true, true, false, false, false, true, true]
    );
    // Every training episode was played against one of them.
    let episodes = std::fs::read_to_string(dir.join("episodes.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    let games: u64 = rows.iter().map(|r| r["games"].as_u64().unwrap()).sum();
    assert_eq!(games, episodes as u64);
    let played = rows
        .iter()
        .filter(|r| r["games"].as_u64().unwrap() > 0)
        .count();
    assert!(played >= 4, "opponents met: {played} of {}", rows.len());
    for r in rows {
        let (g, w, d) = (
            r["games"].as_u64().unwrap(),
            r["wins"].as_u64().unwrap(),
            r["draws"].as_u64().unwrap(),
        );
        assert!(w + d <= g);
        let share = r["points_share"].as_f64().unwrap();
        assert!((share - (w as f64 + 0.5 * d as f64 + 0.5) / (g as f64 + 1.0)).abs() < 1e-12);
    }
    assert!(pool.join("pool.md").is_file());
    assert!(dir.join("test/metrics.json").is_file());

    // A snapshot is a contestant like any run: it plays a match against the shooter.
    let snap: Contestant = pool
        .join("step-000000300")
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    let rules = MatchRules {
        time_limit_s: 2.0,
        ..MatchRules::default()
    };
    let table = match_table(&c.env, &rules);
    let shooter: Contestant = "shooter".parse().unwrap();
    let result = play_match(&table, &rules, &snap, &shooter, 5).unwrap();
    assert!(result.steps > 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A rival from a run directory (here the first run's snapshot, a run like any other)
/// plays black in the anchor episodes and gets its own record; a rival that names no
/// contestant stops the run before it starts, naming `self_play.rivals` and the name.
#[test]
fn a_trained_run_plays_black_as_a_rival_and_a_bad_rival_is_refused() {
    let dir = scratch("self-play-rival");
    let (first, second) = (dir.join("first"), dir.join("second"));
    std::fs::create_dir_all(&first).unwrap();
    train(&config(1), &first, Start::Fresh, |_| {}).unwrap();
    let rival = first.join("pool/step-000000300");
    let with_rival = |name: &str| {
        let text = tiny_config_text("sac", 2, 200)
            + &format!(
                "[self_play]\nlatest_share = 0\nanchor_share = 1\nanchors = [\"static\"]\n\
                 rivals = [\"{name}\"]\n"
            );
        RunConfig::from_toml(&text, Path::new("rival.toml")).unwrap()
    };
    std::fs::create_dir_all(&second).unwrap();
    train(
        &with_rival(&format!("{}@last", rival.display())),
        &second,
        Start::Fresh,
        |_| {},
    )
    .unwrap();
    let records = json(&second.join("pool/pool.json"));
    let rows = records["opponents"].as_array().unwrap();
    assert_eq!(rows[0]["opponent"], "static");
    assert_eq!(rows[1]["opponent"], format!("{}@last", rival.display()));
    let games = |i: usize| rows[i]["games"].as_u64().unwrap();
    assert!(games(0) > 0 && games(1) > 0, "{rows:?}");
    let snapshot_games: u64 = (2..rows.len()).map(games).sum();
    assert_eq!(snapshot_games, 0, "anchor_share = 1 draws no snapshot");

    let refused = dir.join("refused");
    std::fs::create_dir_all(&refused).unwrap();
    let err = train(&with_rival("no/such/run"), &refused, Start::Fresh, |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("self_play.rivals") && err.contains("no/such/run"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_self_play_run_is_the_same_on_one_thread_or_two() {
    let dir = scratch("self-play-threads");
    let (one, two) = (dir.join("one"), dir.join("two"));
    for (run, threads) in [(&one, 1), (&two, 2)] {
        std::fs::create_dir_all(run).unwrap();
        train(&config(threads), run, Start::Fresh, |_| {}).unwrap();
    }
    for file in [
        "episodes.csv",
        "evaluations.csv",
        "pool/pool.json",
        "test/metrics.json",
    ] {
        assert!(
            std::fs::read(one.join(file)).unwrap() == std::fs::read(two.join(file)).unwrap(),
            "{file} differs between 1 and 2 threads"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_self_play_settings_are_refused_by_key() {
    let base = tiny_config_text("sac", 1, 100);
    for (section, key) in [
        ("[self_play]\nanchors = []\n", "self_play.anchors"),
        (
            "[self_play]\nsnapshot_every = 0\n",
            "self_play.snapshot_every",
        ),
        (
            "[self_play]\nlatest_share = 0.9\nanchor_share = 0.2\n",
            "self_play.anchor_share",
        ),
        ("[self_play]\npfsp_power = -1\n", "self_play.pfsp_power"),
        (
            "[self_play]\nepisode_steps = 0\n",
            "self_play.episode_steps",
        ),
        (
            "[self_play]\nblack_serve_share = 1.5\n",
            "self_play.black_serve_share",
        ),
        (
            "[self_play]\nanchors = [\"goalie\"]\n",
            "tiny.toml:19: self_play.anchors: unknown variant `goalie`",
        ),
        ("[self_play]\nsnapshots = 3\n", "snapshots"),
        (
            "[self_play]\nserve = \"conceded\"\nblack_serve_share = 0.5\n",
            "self_play.black_serve_share",
        ),
        (
            "[self_play]\nserve = \"winner\"\n",
            "unknown variant `winner`",
        ),
    ] {
        let err = RunConfig::from_toml(&(base.clone() + section), Path::new("tiny.toml"))
            .unwrap_err()
            .to_string();
        assert!(err.contains(key), "{section}: {err}");
    }
}

/// `protocol.init_from` starts a run from another run's saved networks: with no update
/// (learning starts after the run's end) its test is the saved run's, byte for byte; an
/// algorithm or network shape that differs is refused by key.
#[test]
fn a_run_starts_from_saved_networks_and_refuses_ones_that_do_not_fit() {
    let dir = scratch("init-from");
    let (saved, tuned) = (dir.join("saved"), dir.join("tuned"));
    for d in [&saved, &tuned] {
        std::fs::create_dir_all(d).unwrap();
    }
    let text = tiny_config_text("sac", 1, 200);
    let c = RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap();
    train(&c, &saved, Start::Fresh, |_| {}).unwrap();
    let text = text
        .replace("learning_starts = 50", "learning_starts = 100000")
        .replace(
            "[protocol]\n",
            &format!("[protocol]\ninit_from = \"{}@last\"\n", saved.display()),
        );
    let c = RunConfig::from_toml(&text, Path::new("tuned.toml")).unwrap();
    train(&c, &tuned, Start::Fresh, |_| {}).unwrap();
    let metrics = |run: &Path| std::fs::read(run.join("test/metrics.json")).unwrap();
    assert!(
        metrics(&saved) == metrics(&tuned),
        "the test differs from the saved run's"
    );
    // Without init_from the same frozen run tests other (fresh) networks.
    let fresh = dir.join("fresh");
    std::fs::create_dir_all(&fresh).unwrap();
    let mut c2 = c.clone();
    c2.protocol.init_from = None;
    train(&c2, &fresh, Start::Fresh, |_| {}).unwrap();
    assert!(metrics(&saved) != metrics(&fresh));

    for (algo, hidden, why) in [
        ("td3", "[16]", "it trained sac, this run trains td3"),
        ("sac", "[8]", "[16] wide, this run's [8]"),
    ] {
        let mut c = RunConfig::from_toml(
            &tiny_config_text(algo, 1, 200).replace("hidden = [16]", &format!("hidden = {hidden}")),
            Path::new("other.toml"),
        )
        .unwrap();
        c.protocol.init_from = Some(format!("{}@best", saved.display()));
        let run = dir.join(format!("refused-{algo}"));
        std::fs::create_dir_all(&run).unwrap();
        let err = train(&c, &run, Start::Fresh, |_| {})
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("protocol.init_from") && err.contains(why),
            "{err}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The learner's table: black's goals count (the own-goal line mirrored), the conceded
/// penalty as configured, the "no progress" end off unless kept, black's serves and the
/// serve rule as set.
#[test]
fn the_self_play_table_counts_black_s_goals_and_drops_no_progress_unless_kept() {
    use foosball_rl::config::SelfPlayConfig;
    use foosball_rl::env::Serve;
    use foosball_rl::self_play::self_play_table;
    let c = config(1);
    let sp = SelfPlayConfig {
        conceded_penalty: 250.0,
        ..SelfPlayConfig::default()
    };
    let t = self_play_table(&c.env, &sp);
    assert_eq!(t.own_goal_line_world(), -t.goal_line_world());
    assert_eq!(t.reward.conceded_penalty, 250.0);
    assert_eq!(t.rules.no_progress_steps, u32::MAX);
    let kept = self_play_table(
        &c.env,
        &SelfPlayConfig {
            no_progress_end: true,
            ..sp
        },
    );
    assert_eq!(kept.rules.no_progress_steps, c.env.rules.no_progress_steps);
    assert_eq!(t.start.black_share, 0.0);
    let served = self_play_table(
        &c.env,
        &SelfPlayConfig {
            black_serve_share: 0.25,
            ..SelfPlayConfig::default()
        },
    );
    assert_eq!(served.start.black_share, 0.25);
    assert!(!served.rules.serve_again);
    assert_eq!(served.max_episode_steps, c.env.max_episode_steps);
    let match_like = self_play_table(
        &c.env,
        &SelfPlayConfig {
            serve_again: true,
            episode_steps: Some(2500),
            ..SelfPlayConfig::default()
        },
    );
    assert!(match_like.rules.serve_again);
    assert_eq!(match_like.max_episode_steps, 2500);
    assert_eq!(match_like.start.serve, Serve::Drawn);
    let as_a_match = self_play_table(
        &c.env,
        &SelfPlayConfig {
            serve: Serve::Conceded,
            ..SelfPlayConfig::default()
        },
    );
    assert_eq!(as_a_match.start.serve, Serve::Conceded);
}

/// `start.black_share`: a served episode's ball lies at the mirror image (world (x, y) ->
/// (-x, -y)) of the same seed's serve without it; a share of 0.3 serves about 30 % of 400
/// episodes on black's side; a share outside [0, 1] is refused by key.
#[test]
fn black_s_serve_mirrors_the_table_s_start_in_its_share_of_episodes() {
    use foosball_rl::env::{Env, FoosballConfig, FoosballEnv, Preset};
    let start = |share: f32, seed: u64| {
        let mut c = FoosballConfig::preset(Preset::Reference);
        c.start.black_share = share;
        let mut env = FoosballEnv::new(c).unwrap();
        let mut obs = vec![0.0; env.obs_dim()];
        env.reset_into(Some(seed), &mut obs);
        env.table().unwrap().ball_position()
    };
    for seed in 0..5 {
        let [x, y, z] = start(0.0, seed);
        assert!(
            y < 0.0,
            "the paper's serve is on yellow's side, got y = {y}"
        );
        assert_eq!(start(1.0, seed), [-x, -y, z]);
    }
    let black = (0..400).filter(|&s| start(0.3, s)[1] > 0.0).count();
    assert!(
        (95..=145).contains(&black),
        "{black} of 400 served on black's side"
    );
    let mut c = FoosballConfig::preset(Preset::Reference);
    c.start.black_share = -0.1;
    let err = FoosballEnv::new(c).err().expect("refused").to_string();
    assert!(err.contains("start.black_share"), "{err}");
}

/// `protocol.init_blind_to_black`: the loaded networks ignore black's rods, act as the
/// saved ones where black's rods are at rest, and the key is refused without `init_from`.
#[test]
fn networks_loaded_blind_to_black_ignore_black_s_rods() {
    use foosball_env::layout::{OBS_DIM, black_rod_inputs};
    use foosball_rl::agents::{build_agent, device, load_agent};
    use foosball_rl::run::init::init_networks;
    let dir = scratch("init-blind");
    let saved = dir.join("saved");
    std::fs::create_dir_all(&saved).unwrap();
    let text = tiny_config_text("sac", 1, 200);
    let c = RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap();
    train(&c, &saved, Start::Fresh, |_| {}).unwrap();

    let at_rest: Vec<f32> = (0..OBS_DIM).map(|i| 0.1 * i as f32 - 1.0).collect();
    let mut at_rest = at_rest;
    black_rod_inputs().for_each(|i| at_rest[i] = 0.0);
    let mut moving = at_rest.clone();
    black_rod_inputs().for_each(|i| moving[i] = 40.0 - 3.0 * i as f32);
    let act = |agent: &mut dyn foosball_algos::Agent, obs: &[f32]| {
        agent.act(obs, foosball_algos::ActMode::Deterministic)
    };

    let mut as_saved = load_agent(&c, &saved.join("last")).unwrap();
    let mut tuned = c.clone();
    tuned.protocol.init_from = Some(format!("{}@last", saved.display()));
    tuned.protocol.init_blind_to_black = true;
    let mut blind = build_agent(&tuned, &device(&tuned).unwrap());
    init_networks(&tuned, blind.as_mut()).unwrap();
    assert_ne!(
        act(as_saved.as_mut(), &at_rest),
        act(as_saved.as_mut(), &moving)
    );
    let rest = act(blind.as_mut(), &at_rest);
    assert_eq!(rest, act(as_saved.as_mut(), &at_rest));
    assert_eq!(rest, act(blind.as_mut(), &moving));

    let mut unset = tuned.clone();
    unset.protocol.init_from = None;
    let run = dir.join("refused");
    std::fs::create_dir_all(&run).unwrap();
    let err = train(&unset, &run, Start::Fresh, |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("protocol.init_blind_to_black"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
