//! The reverse curriculum (`[curriculum]`, issue 49): training episodes begun along a
//! teacher's scoring episodes (the planner's, recorded by `evaluate`) begin where one
//! still step puts the ball in the goal at the run's start, at the configured share; a
//! run with one scores more training episodes than without, the same numbers twice, and
//! with share 0 is the plain run; a teacher file without a goal, one recorded on another
//! game or on the run's own held-out starts, bad values and a curriculum beside
//! self-play are refused by key.

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_env::{Env, ball_in_a_goal};
use foosball_rl::config::RunConfig;
use foosball_rl::plan::PlannerConfig;
use foosball_rl::play::scripted::{Baseline, ScriptedPolicy};
use foosball_rl::run::curriculum::{load_teacher, training_envs};
use foosball_rl::run::train::{Start, train};
use std::path::{Path, PathBuf};

/// The tiny SAC run, 400 env steps, on a table whose episodes last up to 120 steps (the
/// planner's goals take more than the tiny table's 30).
fn tiny_text() -> String {
    tiny_text_of(2, 200)
}

/// The tiny SAC run of `epochs` x `steps_per_epoch` env steps on that table, the fifth
/// `reference` (the thresholds below measured there; the mechanism is any game's).
fn tiny_text_of(epochs: u32, steps_per_epoch: u64) -> String {
    tiny_config_text("sac", epochs, steps_per_epoch)
        .replace("max_episode_steps = 30", "max_episode_steps = 120")
        .replace("[env]\n", "[env]\npreset = \"reference_v5\"\n")
}

/// `episodes` of `policy` (the planner on a small budget) recorded on the run's table
/// from seed `seed`'s test starts.
fn record(dir: &Path, policy: ScriptedPolicy, seed: u64, episodes: u32) -> PathBuf {
    let c = RunConfig::from_toml(&tiny_text(), Path::new("t.toml")).unwrap();
    let planner = PlannerConfig {
        population: 32,
        elites: 4,
        iterations: 8,
        ..PlannerConfig::default()
    };
    let teacher = Baseline {
        policy,
        seed,
        env: c.env,
        planner: (policy == ScriptedPolicy::Planner).then_some(planner),
    };
    let out = dir.join(format!("{}-{seed}", policy.name()));
    let m = teacher.test(episodes, &out, true).unwrap();
    if policy == ScriptedPolicy::Planner {
        assert!(m.score_rate.mean > 0.0, "the teacher scores");
    }
    out.join("trajectories.bin")
}

/// The tiny SAC run with `[curriculum]` `lines` when given.
fn config_text(curriculum: Option<&str>) -> String {
    let text = tiny_text();
    match curriculum {
        Some(lines) => format!("{text}[curriculum]\n{lines}"),
        None => text,
    }
}

fn teacher_lines(file: &Path, rest: &str) -> String {
    format!("trajectories = \"{}\"\n{rest}", file.display())
}

/// Trains `text` into `dir/name`: the test metrics and the training episodes' `scored`
/// column.
fn run(dir: &Path, name: &str, text: &str) -> Result<(Vec<u8>, Vec<bool>), String> {
    let out = dir.join(name);
    std::fs::create_dir_all(&out).unwrap();
    let c = RunConfig::from_toml(text, Path::new("t.toml")).map_err(|e| e.to_string())?;
    train(&c, &out, Start::Fresh, |_| {}).map_err(|e| e.to_string())?;
    let episodes = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let scored = episodes
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3) == Some("1"))
        .collect();
    Ok((
        std::fs::read(out.join("test/metrics.json")).unwrap(),
        scored,
    ))
}

/// Of `resets` training episodes of the run `text`'s first env at the start of a long
/// run (its curriculum not yet moved back), how many have the ball in black's goal after
/// one still step, not before.
fn in_goal_after_one_step(text: &str, resets: usize) -> usize {
    let mut c = RunConfig::from_toml(text, Path::new("t.toml")).unwrap();
    c.protocol.steps_per_epoch = 1_000_000;
    let teacher = load_teacher(&c).unwrap();
    let mut env = training_envs(&c, teacher.as_ref(), None, 1, 0)
        .unwrap()
        .remove(0);
    env.reset(Some(1));
    (0..resets)
        .filter(|_| {
            env.reset(None);
            let before = ball_in_a_goal(&c.env, env.state().unwrap());
            let (_, t) = env.step(&[0.0; 8]).unwrap();
            !before && t.info.in_goal
        })
        .count()
}

#[test]
fn episodes_begin_one_step_before_the_teachers_goals_and_the_run_reproduces() {
    let dir = scratch("curriculum");
    let teacher = record(&dir, ScriptedPolicy::Planner, 1000, 3);
    // Every episode begins on the teacher's, at first one step before its goal.
    let near = config_text(Some(&teacher_lines(
        &teacher,
        "share = 1.0\nfirst_back = 1\nwhole_at = 1.0\n",
    )));
    assert_eq!(in_goal_after_one_step(&near, 20), 20);
    let own = config_text(Some(&teacher_lines(&teacher, "share = 0.0\n")));
    assert_eq!(
        in_goal_after_one_step(&own, 20),
        0,
        "the table's own starts"
    );
    let half = config_text(Some(&teacher_lines(&teacher, "first_back = 1\n")));
    let n = in_goal_after_one_step(&half, 200);
    assert!((70..130).contains(&n), "share 0.5: {n} of 200");

    let (metrics, scored) = run(&dir, "near", &near).unwrap();
    let (plain, plain_scored) = run(&dir, "plain", &config_text(None)).unwrap();
    assert_ne!(metrics, plain, "the curriculum changed nothing");
    let goals = |s: &[bool]| s.iter().filter(|&&s| s).count();
    assert!(
        goals(&scored) >= goals(&plain_scored) + 2,
        "training episodes scoring: {} of {} begun along the teacher's, {} of {} from the own starts",
        goals(&scored),
        scored.len(),
        goals(&plain_scored),
        plain_scored.len()
    );
    assert_eq!(
        run(&dir, "near-again", &near).unwrap().0,
        metrics,
        "not reproducible"
    );
    // No share: the run is the plain one (the teacher's file is still read and checked).
    assert_eq!(run(&dir, "none", &own).unwrap().0, plain);
}

#[test]
fn a_curriculum_that_does_not_fit_the_run_is_refused_by_key() {
    let dir = scratch("curriculum-refused");
    let teacher = record(&dir, ScriptedPolicy::Planner, 1000, 2);
    let err = |text: String| run(&dir, "refused", &text).unwrap_err();

    let still = record(&dir, ScriptedPolicy::Zero, 1000, 2);
    let e = err(config_text(Some(&teacher_lines(&still, ""))));
    assert!(
        e.contains("curriculum.trajectories") && e.contains("no episode scores"),
        "{e}"
    );
    // Seed 3 is the tiny run's own: its test starts would be trained on.
    let own = record(&dir, ScriptedPolicy::Planner, 3, 1);
    let e = err(config_text(Some(&teacher_lines(&own, ""))));
    assert!(
        e.contains("curriculum.trajectories") && e.contains("evaluation or test"),
        "{e}"
    );
    // Another game: each action held for two physics steps. Refused by the record
    // `evaluate` keeps beside the file, and without it by the replay of the episodes.
    let other = |teacher: &Path| {
        config_text(Some(&teacher_lines(teacher, ""))).replace("[env]\n", "[env]\nframe_skip = 2\n")
    };
    let e = err(other(&teacher));
    assert!(
        e.contains("curriculum.trajectories")
            && e.contains("recorded on another table")
            && e.contains("frame_skip = 1"),
        "{e}"
    );
    let bare = dir.join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    std::fs::copy(&teacher, bare.join("trajectories.bin")).unwrap();
    let e = err(other(&bare.join("trajectories.bin")));
    assert!(
        e.contains("curriculum.trajectories") && e.contains("another game"),
        "{e}"
    );
    for (lines, key) in [
        ("share = 1.5\n", "curriculum.share"),
        ("first_back = 0\n", "curriculum.first_back"),
        ("whole_at = 0.0\n", "curriculum.whole_at"),
        ("success_rate = 0.0\n", "curriculum.success_rate"),
        ("window = 0\n", "curriculum.window"),
        ("advance = 0\n", "curriculum.advance"),
        ("schedule = \"sometimes\"\n", "curriculum.schedule"),
    ] {
        let e = err(config_text(Some(&teacher_lines(&teacher, lines))));
        assert!(e.contains(key), "{e}");
    }
    let e = err(config_text(Some("share = 0.5\n")));
    assert!(e.contains("curriculum.trajectories"), "{e}");
    let e = err(config_text(Some(&teacher_lines(&teacher, ""))) + "[self_play]\n");
    assert!(e.contains("curriculum") && e.contains("self_play"), "{e}");
}

/// The `train/curriculum_back` values of a run's `scalars.csv`, one per log window.
fn logged_backs(run: &Path) -> Vec<f64> {
    std::fs::read_to_string(run.join("scalars.csv"))
        .unwrap()
        .lines()
        .filter(|l| l.contains(",train/curriculum_back,"))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect()
}

/// `schedule = "success"`: begun one step before the teacher's goals, where the ball goes
/// in whatever the learner does, the starts move back as the learner keeps scoring from
/// them; the run reproduces, and one stopped and resumed ends as the uninterrupted one
/// (the distance and the window so far are in the checkpoint).
#[test]
fn starts_move_back_as_the_learner_succeeds_from_them() {
    let dir = scratch("curriculum-success");
    let teacher = record(&dir, ScriptedPolicy::Planner, 1000, 3);
    let lines = teacher_lines(
        &teacher,
        "share = 1.0\nfirst_back = 1\nschedule = \"success\"\nwindow = 2\n\
         success_rate = 0.5\nadvance = 1\n",
    );
    let text = config_text(Some(&lines));
    let (metrics, _) = run(&dir, "success", &text).unwrap();
    let backs = logged_backs(&dir.join("success"));
    assert!(!backs.is_empty(), "no train/curriculum_back rows");
    assert!(backs[0] >= 1.0, "first_back at first: {backs:?}");
    assert!(
        backs.last().unwrap() > &backs[0],
        "the starts never moved back: {backs:?}"
    );
    assert_eq!(run(&dir, "success-again", &text).unwrap().0, metrics);
    let resumable = tiny_text_of(3, 150) + "[curriculum]\n" + &lines;
    crate::resume::stopped_and_resumed("curriculum-success", &resumable, None);
}
