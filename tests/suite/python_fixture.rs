//! The trajectories the Python front must reproduce bit for bit
//! (`crates/py/tests/test_parity.py` reads the same file): one table and a batch of four
//! on the `reference` preset, fixed seeds, actions from a formula, some beyond [-1, 1].
//!
//! This test checks that the Rust env still writes exactly the committed
//! `crates/py/tests/data/trajectories.json`; after an intended change of the game,
//! `FOOSBALL_UPDATE_FIXTURES=1 cargo test --release --test suite python_fixture::` rewrites it.

use std::path::Path;

use foosball_rl::env::layout::ACTION_DIM;
use foosball_rl::env::{Env, FoosballConfig, FoosballEnv, VecEnv};
use serde::{Deserialize, Serialize};

const FIXTURE: &str = "crates/py/tests/data/trajectories.json";

/// Agent steps of one recorded episode at most.
const EPISODE_CAP: usize = 200;

/// Action value `k` at step `t` of table `env`: a smooth sweep, 1.3 x beyond [-1, 1].
fn action(env: usize, t: usize, k: usize) -> f32 {
    1.3 * (0.21 * t as f32 + 0.9 * k as f32 + 2.1 * env as f32).sin()
}

/// One table's episodes (the actions of table 1): the first reset seeded, the second
/// continuing its stream.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Single {
    seed: u64,
    episodes: Vec<Episode>,
}

#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Episode {
    /// The action of each step (Python replays these, not the formula: its `sin` may
    /// differ from Rust's in the last bit).
    actions: Vec<Vec<f32>>,
    /// Reset observation, then one per step.
    obs: Vec<Vec<f32>>,
    rewards: Vec<f32>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    /// End reason of the last step, if the episode ended within the cap.
    end: Option<String>,
}

/// A batch of tables seeded from one seed, auto-resetting.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Vector {
    seed: u64,
    num_envs: usize,
    /// The `[num_envs * 8]` actions of each step.
    actions: Vec<Vec<f32>>,
    /// Reset observations, then one `[num_envs * 38]` row per step.
    obs: Vec<Vec<f32>>,
    rewards: Vec<Vec<f32>>,
    terminated: Vec<Vec<bool>>,
    truncated: Vec<Vec<bool>>,
    /// `(step, env, final observation)` of every episode that ended.
    final_obs: Vec<(usize, usize, Vec<f32>)>,
}

#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Fixture {
    preset: String,
    /// `1.3 * sin(0.21 t + 0.9 k + 2.1 env)` for step t, action value k, table env.
    actions: String,
    single: Single,
    vector: Vector,
}

fn single(seed: u64) -> Single {
    let mut env = FoosballEnv::new(FoosballConfig::default()).unwrap();
    let episodes = [Some(seed), None]
        .into_iter()
        .map(|s| {
            let mut ep = Episode {
                actions: vec![],
                obs: vec![env.reset(s)],
                rewards: vec![],
                terminated: vec![],
                truncated: vec![],
                end: None,
            };
            for t in 0..EPISODE_CAP {
                let a: Vec<f32> = (0..ACTION_DIM).map(|k| action(1, t, k)).collect();
                let (obs, tr) = env.step(&a).unwrap();
                ep.actions.push(a);
                ep.obs.push(obs);
                ep.rewards.push(tr.reward);
                ep.terminated.push(tr.terminated);
                ep.truncated.push(tr.truncated);
                if tr.done() {
                    ep.end = tr.info.end.map(|e| e.name().to_string());
                    break;
                }
            }
            ep
        })
        .collect();
    Single { seed, episodes }
}

fn vector(seed: u64, num_envs: usize, steps: usize) -> Vector {
    let envs = (0..num_envs)
        .map(|_| FoosballEnv::new(FoosballConfig::default()).unwrap())
        .collect();
    let mut venv = VecEnv::new(envs, 2).unwrap();
    let mut v = Vector {
        seed,
        num_envs,
        actions: vec![],
        obs: vec![venv.reset(seed).to_vec()],
        rewards: vec![],
        terminated: vec![],
        truncated: vec![],
        final_obs: vec![],
    };
    for t in 0..steps {
        let a: Vec<f32> = (0..num_envs * ACTION_DIM)
            .map(|j| action(j / ACTION_DIM, t, j % ACTION_DIM))
            .collect();
        let s = venv.step(&a).unwrap();
        v.actions.push(a.clone());
        v.obs.push(s.obs.to_vec());
        v.rewards.push(s.rewards.to_vec());
        v.terminated.push(s.terminated.to_vec());
        v.truncated.push(s.truncated.to_vec());
        for i in 0..num_envs {
            if let Some(f) = s.final_observation(i) {
                v.final_obs.push((t, i, f.to_vec()));
            }
        }
    }
    v
}

fn fixture() -> Fixture {
    Fixture {
        preset: "reference".into(),
        actions: "1.3 * sin(0.21 t + 0.9 k + 2.1 env)".into(),
        single: single(7),
        vector: vector(3, 4, 40),
    }
}

#[test]
fn the_rust_env_writes_the_committed_python_fixture() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE);
    let now = fixture();
    // Both episodes and the batch must end episodes, or the fixture tests no reset.
    assert!(now.single.episodes.iter().all(|e| e.end.is_some()));
    assert!(!now.vector.final_obs.is_empty());
    if std::env::var_os("FOOSBALL_UPDATE_FIXTURES").is_some() {
        let text = serde_json::to_string(&now).unwrap();
        std::fs::write(&path, text + "\n").unwrap();
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (FOOSBALL_UPDATE_FIXTURES=1 writes it)",
            path.display()
        )
    });
    let committed: Fixture = serde_json::from_str(&text).unwrap();
    assert_eq!(committed, now, "the env no longer plays {FIXTURE}");
}

/// The standard test the Python front must reproduce (`crates/py/tests/test_evaluate.py`
/// reads the same file): `evaluate`'s metrics of two policies that numpy computes with
/// the same bits (all zeros; rods swinging by comparisons of observation values), 40
/// episodes from the test seeds of seed 3 on `reference`.
const TEST_FIXTURE: &str = "crates/py/tests/data/standard_test.json";

#[test]
fn the_rust_evaluate_writes_the_committed_python_test_fixture() {
    use foosball_rl::play::evaluation::{Episodes, OwnedPolicy, play_owned};
    use foosball_rl::play::metrics::TestMetrics;
    use std::collections::BTreeMap;

    let table = FoosballConfig::default();
    let episodes = Episodes {
        env: &table,
        seed: 3,
        stream: foosball_rl::env::seeding::TEST_ENVS,
        n: 40,
        record: false,
    };
    let zero: OwnedPolicy = Box::new(|obs: &[f32]| Ok(vec![0.0; obs.len() / 38 * ACTION_DIM]));
    // Every rod slides to the side of the ball's x and swings its feet to the other side
    // of where they are: the rods keep turning and kick the ball about.
    let swing: OwnedPolicy = Box::new(|obs: &[f32]| {
        Ok(obs
            .chunks_exact(38)
            .flat_map(|row| {
                (0..4).flat_map(move |r| {
                    let slide = if row[0] > 0.0 { 1.0 } else { -1.0 };
                    let turn = if row[22 + r] > 0.0 { -1.0 } else { 1.0 };
                    [slide, turn]
                })
            })
            .collect())
    });
    let mut now = BTreeMap::new();
    for (name, mut policy) in [("zero", zero), ("swing", swing)] {
        let played = play_owned(&mut policy, &episodes).unwrap();
        let summaries: Vec<_> = played.iter().map(|e| e.summary).collect();
        now.insert(name, TestMetrics::from_episodes(&summaries));
    }
    let text = serde_json::to_string_pretty(&now).unwrap() + "\n";
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(TEST_FIXTURE);
    if std::env::var_os("FOOSBALL_UPDATE_FIXTURES").is_some() {
        std::fs::write(&path, &text).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (FOOSBALL_UPDATE_FIXTURES=1 writes it)",
            path.display()
        )
    });
    assert_eq!(committed, text, "evaluate no longer gives {TEST_FIXTURE}");
}
