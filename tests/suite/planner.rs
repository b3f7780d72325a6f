//! The planner ([`foosball_rl::plan`]): it finds scoring plans where doing nothing never
//! scores, its plans replay exactly (the table is deterministic), the same seeds give the
//! same episodes whatever the thread count, one shared plan plays every episode alike,
//! earns on its search starts what the search says and can be refined per episode, a
//! search from a state along an episode is the same on snapshots as by replaying the
//! episode's first steps, and bad budgets are refused by name.

use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use foosball_rl::env::seeding::{TEST_ENVS, derive_seed};
use foosball_rl::env::{EnvRng, FoosballConfig, FoosballEnv, Opponent, OpponentKind, Preset};
use foosball_rl::plan::{Outcome, PlanStart, PlannerConfig, follow, search, search_shared};
use foosball_rl::play::evaluation::PlayedEpisode;
use foosball_rl::play::planned::{PlanCost, play_planned};
use foosball_rl::play::scripted::{Baseline, ScriptedPolicy};
use std::process::Command;

use crate::common;

/// A small budget: 32 candidates x 4 iterations of 24 pieces of 5 steps.
fn small() -> PlannerConfig {
    PlannerConfig {
        population: 32,
        elites: 6,
        iterations: 4,
        ..PlannerConfig::default()
    }
}

fn seeds(n: u64) -> Vec<u64> {
    (0..n).map(|k| derive_seed(0, TEST_ENVS, k)).collect()
}

fn planned(threads: usize) -> (Vec<PlayedEpisode>, PlanCost) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let env = FoosballConfig::default();
    pool.install(|| play_planned(&env, &small(), (0, &seeds(12)), false).unwrap())
}

#[test]
fn a_shared_plan_plays_every_episode_alike_and_scores_on_its_starts_as_searched() {
    // The fifth `reference`, where the small budget's figures below were measured.
    let env = FoosballConfig::preset(Preset::ReferenceV5);
    let shared = PlannerConfig {
        shared_starts: 4,
        ..small()
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| play_planned(&env, &shared, (0, &seeds(6)), true).unwrap())
    };
    let (one, cost) = run(1);
    assert_eq!(one, run(2).0, "the same episodes on 1 and 2 threads");
    let plan = cost.shared.expect("a shared plan").plan;
    assert_eq!(plan.len(), shared.segments);
    // Every episode plays the plan's actions, step by step, until it ends.
    for e in &one {
        let actions = &e.trajectory.as_ref().unwrap().actions;
        for (t, a) in actions.chunks_exact(8).enumerate() {
            let k = (t / shared.segment_steps).min(plan.len() - 1);
            assert_eq!(a, &plan[k][..], "episode {} step {t}", e.seed);
        }
    }
    // Refined per episode from the shared plan, each plan replays as searched. (At the
    // search's whole initial spread: the small budget's shared plan is too far from each
    // start's best on `reference`'s SDF contacts for a narrow refinement, 0 of 4 at 0.2.)
    let refined = PlannerConfig {
        refine_std: Some(1.0),
        ..shared.clone()
    };
    let (episodes, cost) = play_planned(&env, &refined, (0, &seeds(4)), false).unwrap();
    assert_eq!(cost.shared.map(|s| s.plan), Some(plan));
    assert_eq!(cost.replayed_exactly, cost.within_rollout_cap);
    assert_eq!(cost.within_rollout_cap, 4);
    let scored = episodes.iter().filter(|e| e.summary.scored).count();
    assert!(scored >= 2, "{scored} of 4 refined plans score");
    let starts: Vec<u64> = (0..8).map(|k| derive_seed(5, TEST_ENVS, k)).collect();
    let found = search_shared(&env, &starts, 9, &small()).unwrap();
    let mut table = foosball_rl::env::FoosballEnv::new(env.clone()).unwrap();
    let goals = starts
        .iter()
        .filter(|&&s| {
            let mut o = Outcome::default();
            follow(
                &mut table,
                PlanStart::reset(s),
                &found.plan,
                5,
                None,
                &mut o,
            )
            .unwrap();
            o.scored
        })
        .count();
    assert_eq!(found.score_rate, goals as f64 / 8.0);
    assert_eq!(found.rollouts % 8, 0);
}

#[test]
fn the_planner_scores_where_doing_nothing_does_not_and_replays_exactly_on_any_thread_count() {
    let (one, cost) = planned(1);
    let (two, _) = planned(2);
    assert_eq!(one, two, "the same episodes on 1 and 2 threads");
    let scored = one.iter().filter(|e| e.summary.scored).count();
    let zero = Baseline {
        policy: ScriptedPolicy::Zero,
        seed: 0,
        env: FoosballConfig::default(),
        planner: None,
    };
    let still = zero.play(12, false).unwrap();
    assert_eq!(still.iter().filter(|e| e.summary.scored).count(), 0);
    assert!(scored >= 7, "the planner scored {scored} of 12");
    assert_eq!(cost.within_rollout_cap, 12);
    assert_eq!(
        cost.replayed_exactly, 12,
        "every plan earns what its search predicted"
    );
    assert!(cost.rollouts_per_episode > 1.0 && cost.rollouts_per_episode <= 129.0);
}

#[test]
fn evaluate_refuses_a_planner_budget_by_key_and_for_another_policy() {
    let dir = common::scratch("planner-cli");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "population = 8\nelites = 9\n").unwrap();
    let evaluate = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_evaluate"))
            .args(args)
            .output()
            .unwrap()
    };
    let o = evaluate(&["--policy", "planner", "--planner", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("planner.elites = 9"),
        "{err}"
    );
    assert!(
        err.contains("bad.toml") && !err.contains("panicked"),
        "{err}"
    );
    std::fs::write(&bad, "populaton = 8\n").unwrap();
    let o = evaluate(&["--policy", "planner", "--planner", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("populaton"), "{err}");
    let o = evaluate(&["--policy", "shooter", "--planner", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("--policy is shooter"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Black as the static one, but it cannot be copied: a search on its table replays the
/// episode's first steps for every rollout.
struct Unforkable;

impl Opponent for Unforkable {
    fn act(&mut self, _obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        [0.0; ACTION_DIM]
    }
}

#[test]
fn a_search_from_a_state_is_the_same_on_snapshots_as_by_replaying_the_episode() {
    let mut config = FoosballConfig::preset(Preset::Reference);
    config.opponent = OpponentKind::Static;
    let prefix: Vec<[f32; ACTION_DIM]> = (0..6)
        .map(|i| std::array::from_fn(|k| (0.13 * (i + k) as f32).sin()))
        .collect();
    let start = PlanStart {
        seed: 11,
        prefix: &prefix,
    };
    let planner = PlannerConfig {
        population: 16,
        elites: 4,
        iterations: 3,
        stop_when_scored: false,
        ..PlannerConfig::default()
    };
    let mut snapshots = FoosballEnv::new(config.clone()).unwrap();
    let mut replays = FoosballEnv::with_opponent(config, Box::new(Unforkable)).unwrap();
    let on_snapshots = search(&mut snapshots, start, 3, &planner, None).unwrap();
    let by_replay = search(&mut replays, start, 3, &planner, None).unwrap();
    assert_eq!(on_snapshots, by_replay);
    assert_eq!(on_snapshots.rollouts, 1 + 3 * 15);
}
