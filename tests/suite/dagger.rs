//! The planner as an interactive teacher (`[dagger]`, issue 49): a round plays the
//! learner's own episodes and labels, where the planner finds a goal, a state the learner
//! reached with the planner's actions from there on; the labels join the run's
//! demonstrations, change what it learns, the same way twice, and are logged; a teacher
//! that does not fit the run is refused by key.

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::seeding::{DAGGER, derive_seed};
use foosball_rl::agents::{build_agent, device};
use foosball_rl::config::{RunConfig, TestActions};
use foosball_rl::play::evaluation::{Episodes, play_agent};
use foosball_rl::run::dagger::Dagger;
use foosball_rl::run::demonstrations::as_observed;
use foosball_rl::run::train::{Start, train};
use std::path::Path;

/// A search small enough for a test, on the tiny table.
const TEACHER: &str = "[dagger]\nevery = 100\nepisodes = 3\n[dagger.planner]\npopulation = 32\n\
                       elites = 4\niterations = 8\nsegments = 24\nsegment_steps = 5\n\
                       initial_std = 1.0\nmax_rollout_steps = 120\n";

/// The tiny SAC run (2 epochs of 200 env steps) on a table whose episodes last up to 120
/// steps, cloning its demonstrations (`demo_share` lands in `[sac.off_policy]`, the
/// text's last table), with `teacher` appended.
fn config_text(teacher: &str) -> String {
    tiny_config_text("sac", 2, 200).replace("max_episode_steps = 30", "max_episode_steps = 120")
        + "demo_share = 0.5\n[sac]\nbc_weight = 0.4\n"
        + teacher
}

fn config(text: &str) -> Result<RunConfig, String> {
    RunConfig::from_toml(text, Path::new("t.toml")).map_err(|e| e.to_string())
}

#[test]
fn the_planner_labels_states_the_learner_reached_with_goals() {
    let c = config(&config_text(TEACHER)).unwrap();
    let device = device(&c).unwrap();
    let mut agent = build_agent(&c, &device);
    let mut teacher = Dagger::start(&c, None).unwrap().unwrap();
    assert_eq!(teacher.next_round_at(), 100);
    // What the learner plays in round 0, as it observes it.
    let episodes = Episodes {
        env: &c.env,
        seed: derive_seed(c.protocol.seed, DAGGER, 0),
        stream: DAGGER,
        n: 3,
        record: true,
    };
    let reached: Vec<Vec<f32>> = play_agent(agent.as_mut(), TestActions::Deterministic, &episodes)
        .unwrap()
        .iter()
        .flat_map(|e| {
            let states = &e.trajectory.as_ref().unwrap().obs;
            as_observed(&c, states)
                .chunks_exact(OBS_DIM)
                .map(<[f32]>::to_vec)
                .collect::<Vec<_>>()
        })
        .collect();
    let first = teacher.round(agent.as_mut()).unwrap();
    assert_eq!(first.queries, 3);
    assert!(first.learner_steps > 0 && first.simulated_steps > 0);
    assert_eq!(teacher.next_round_at(), 200);
    let labels = &teacher.state().labels;
    assert_eq!(labels.len(), first.labelled as usize);
    for label in labels {
        assert!(
            reached.contains(&label.obs[..OBS_DIM].to_vec()),
            "a label begins where the learner was"
        );
        let steps = label.rewards.len();
        assert_eq!(label.obs.len(), steps * OBS_DIM);
        assert_eq!(label.actions.len(), steps * ACTION_DIM);
        assert!(label.actions.iter().all(|a| (-1.0..=1.0).contains(a)));
    }
    let mut labelled = first.labelled;
    for _ in 0..4 {
        labelled += teacher.round(agent.as_mut()).unwrap().labelled;
    }
    assert!(
        labelled > 0,
        "the planner found no goal from 15 of the learner's states"
    );
    assert_eq!(teacher.state().labels.len(), labelled as usize);
    assert_eq!(teacher.state().rounds, 5);
    let rows: usize = teacher.state().labels.iter().map(|l| l.rewards.len()).sum();
    assert_eq!(teacher.label_rows(), rows);
    // A label cut at the rollout cap loses its last row (its next state is unknown).
    let cut = teacher
        .state()
        .labels
        .iter()
        .filter(|l| !l.terminated)
        .count();
    assert_eq!(teacher.hand(agent.as_mut()), Ok(rows - cut));
}

/// The searches of a round run side by side: one thread or three, the same labels.
#[test]
fn a_round_labels_the_same_whatever_the_thread_count() {
    let c = config(&config_text(TEACHER)).unwrap();
    let rounds_on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut agent = build_agent(&c, &device(&c).unwrap());
            let mut teacher = Dagger::start(&c, None).unwrap().unwrap();
            let rounds: Vec<_> = (0..3)
                .map(|_| teacher.round(agent.as_mut()).unwrap())
                .collect();
            (rounds, teacher.state().clone())
        })
    };
    let one = rounds_on(1);
    assert!(!one.1.labels.is_empty(), "no label to compare");
    assert_eq!(rounds_on(3), one);
}

/// Trains `text` into `dir/name`: the test metrics and the scalars file.
fn run(dir: &Path, name: &str, text: &str) -> Result<(Vec<u8>, String), String> {
    let out = dir.join(name);
    std::fs::create_dir_all(&out).unwrap();
    train(&config(text)?, &out, Start::Fresh, |_| {}).map_err(|e| e.to_string())?;
    Ok((
        std::fs::read(out.join("test/metrics.json")).unwrap(),
        std::fs::read_to_string(out.join("scalars.csv")).unwrap(),
    ))
}

#[test]
fn a_run_learns_from_the_labels_the_same_way_twice_and_logs_the_rounds() {
    let dir = scratch("dagger");
    let (taught, scalars) = run(&dir, "taught", &config_text(TEACHER)).unwrap();
    // Without a round before its end the teacher labels nothing: the run clones nothing.
    let idle = TEACHER.replace("every = 100", "every = 100000");
    let (alone, _) = run(&dir, "alone", &config_text(&idle)).unwrap();
    assert_ne!(taught, alone, "the labels changed nothing");
    assert_eq!(
        run(&dir, "again", &config_text(TEACHER)).unwrap().0,
        taught,
        "not reproducible"
    );
    let aggregate: Vec<f64> = scalars
        .lines()
        .filter(|l| l.contains("train/dagger_aggregate_rows"))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    // Two rounds in each epoch's window (the scalars average them).
    assert_eq!(
        aggregate.len(),
        2,
        "a row per window with rounds: {scalars}"
    );
    assert!(
        aggregate[0] <= aggregate[1] && aggregate[1] > 0.0,
        "{aggregate:?}"
    );
}

/// PPO in self-play with normalised observations: the labels (of episodes against
/// `env.opponent`) are cloned after each update (`train/demo_cloning_*`), and change
/// the networks the run ends with.
#[test]
fn a_ppo_self_play_run_clones_the_labels_after_its_updates() {
    let dir = scratch("dagger-ppo");
    let text = |teacher: &str| {
        tiny_config_text("ppo", 2, 200).replace("max_episode_steps = 30", "max_episode_steps = 120")
            + "[ppo.demonstrations]\nbatch_size = 16\nupdates = 2\n[normalize]\n\
               [self_play]\nsnapshot_every = 100\npool_size = 2\n"
            + teacher
    };
    let (_, scalars) = run(&dir, "taught", &text(TEACHER)).unwrap();
    let idle = TEACHER.replace("every = 100", "every = 100000");
    let (_, idle_scalars) = run(&dir, "alone", &text(&idle)).unwrap();
    // The tiny runs' test episodes never reach the ball: their networks tell them apart.
    let networks =
        |name: &str| std::fs::read(dir.join(name).join("last/actor_critic.bpk")).unwrap();
    assert_ne!(
        networks("taught"),
        networks("alone"),
        "the labels changed nothing"
    );
    let last = |scalars: &str, tag: &str| -> Option<f64> {
        (scalars.lines())
            .filter(|l| l.contains(tag))
            .rev()
            .find_map(|l| l.rsplit(',').next()?.parse().ok())
    };
    assert!(
        last(&scalars, "train/dagger_aggregate_rows").unwrap() > 0.0,
        "no label: {scalars}"
    );
    assert!(
        last(&scalars, "train/demo_cloning_loss").is_some(),
        "{scalars}"
    );
    assert_eq!(last(&idle_scalars, "train/demo_cloning_loss"), None);
}

#[test]
fn a_teacher_that_does_not_fit_the_run_is_refused_by_key() {
    let refused = |text: String, keys: &[&str]| {
        let e = config(&text).unwrap_err();
        assert!(keys.iter().all(|k| e.contains(k)), "{keys:?}: {e}");
    };
    refused(
        tiny_config_text("sac", 1, 100) + TEACHER,
        &["dagger", "demo_share"],
    );
    refused(
        tiny_config_text("ppo", 1, 100) + TEACHER,
        &["dagger", "ppo.demonstrations"],
    );
    for (from, to, key) in [
        ("every = 100", "every = 0", "dagger.every"),
        ("episodes = 3", "episodes = 0", "dagger.episodes"),
        ("population = 32", "population = 0", "planner.population"),
        (
            "population = 32",
            "shared_starts = 4\npopulation = 32",
            "dagger.planner.shared_starts",
        ),
        ("episodes = 3", "episodes = 3\nsteps = 4", "steps"),
    ] {
        refused(config_text(&TEACHER.replace(from, to)), &[key]);
    }
    // `demo_share` without files: allowed only beside a teacher.
    refused(
        config_text(""),
        &["off_policy.demo_share", "protocol.demonstrations"],
    );
}
