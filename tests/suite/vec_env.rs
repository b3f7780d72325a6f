//! VecEnv: batching order, auto-reset with final observations, refused batches, and
//! results independent of the thread count.

use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use foosball_rl::env::{
    Env, EnvRng, FoosballConfig, FoosballEnv, OpponentKind, Pendulum, VecEnv, VecEnvError,
};
use rand::{Rng, SeedableRng};

fn foosball_vec(n: usize, threads: usize) -> VecEnv<FoosballEnv> {
    let config = FoosballConfig {
        opponent: OpponentKind::Random,
        ..FoosballConfig::default()
    };
    let envs = (0..n)
        .map(|_| FoosballEnv::new(config.clone()).unwrap())
        .collect();
    VecEnv::new(envs, threads).unwrap()
}

/// Every observation, reward, flag and final observation of `steps` batched steps.
fn trace(threads: usize, steps: usize) -> Vec<u32> {
    let n = 5;
    let mut venv = foosball_vec(n, threads);
    let mut rng = EnvRng::seed_from_u64(9);
    let mut out: Vec<u32> = venv.reset(123).iter().map(|v| v.to_bits()).collect();
    for _ in 0..steps {
        let actions: Vec<f32> = (0..n * ACTION_DIM)
            .map(|_| rng.random_range(-1.0..=1.0))
            .collect();
        let s = venv.step(&actions).unwrap();
        out.extend(s.obs.iter().chain(s.rewards).map(|v| v.to_bits()));
        out.extend(
            s.terminated
                .iter()
                .chain(s.truncated)
                .map(|&b| u32::from(b)),
        );
        for i in 0..n {
            if let Some(f) = s.final_observation(i) {
                out.extend(f.iter().map(|v| v.to_bits()));
            }
        }
    }
    out
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let one = trace(1, 1000);
    assert_eq!(one, trace(2, 1000), "1 vs 2 threads");
    assert_eq!(one, trace(3, 1000), "1 vs 3 threads");
}

#[test]
fn env_i_of_a_batch_matches_a_lone_env_seeded_alike() {
    let n = 3;
    let mut venv = foosball_vec(n, 2);
    let first = venv.reset(7).to_vec();
    let seed = foosball_rl::env::seeding::derive_seed(7, foosball_rl::env::seeding::TRAIN_ENVS, 2);
    let mut lone = FoosballEnv::new(venv.envs()[2].config().clone()).unwrap();
    assert_eq!(lone.reset(Some(seed)), first[2 * OBS_DIM..]);
    let actions = vec![0.25; n * ACTION_DIM];
    for _ in 0..30 {
        let s = venv.step(&actions).unwrap();
        let (obs, t) = lone.step(&actions[..ACTION_DIM]).unwrap();
        if t.done() {
            assert_eq!(s.final_observation(2).unwrap(), &obs[..]);
            let next = lone.reset(None);
            assert_eq!(&s.obs[2 * OBS_DIM..], &next[..]);
        } else {
            assert!(s.final_observation(2).is_none());
            assert_eq!(&s.obs[2 * OBS_DIM..], &obs[..]);
        }
        assert_eq!(s.rewards[2], t.reward);
    }
}

#[test]
fn truncated_pendulum_episodes_auto_reset_and_keep_their_final_observation() {
    let envs = (0..2).map(|_| Pendulum::new()).collect();
    let mut venv = VecEnv::new(envs, 2).unwrap();
    venv.reset(1);
    for step in 1..=200 {
        let s = venv.step(&[0.5, -0.5]).unwrap();
        assert_eq!(s.truncated, [step == 200, step == 200]);
        if step == 200 {
            let f = s.final_observation(0).unwrap();
            assert_ne!(f, &s.obs[..3], "the next episode starts elsewhere");
        }
    }
    // The new episodes run on.
    assert!(venv.step(&[0.0, 0.0]).is_ok());
}

#[test]
fn a_bad_action_refuses_the_whole_batch() {
    let mut venv = foosball_vec(3, 2);
    assert!(matches!(venv.step(&[0.0; 24]), Err(VecEnvError::NotReset)));
    let before = venv.reset(5).to_vec();
    let mut actions = vec![0.1; 3 * ACTION_DIM];
    actions[ACTION_DIM + 2] = f32::NAN;
    let err = venv.step(&actions).unwrap_err();
    assert!(matches!(err, VecEnvError::Env { index: 1, .. }), "{err}");
    assert!(err.to_string().starts_with("env 1:"), "{err}");
    assert!(matches!(
        venv.step(&[0.0; 5]),
        Err(VecEnvError::BatchSize {
            expected: 24,
            got: 5,
            ..
        })
    ));
    // Nothing moved: stepping now matches a fresh VecEnv's first step.
    let mut fresh = foosball_vec(3, 1);
    assert_eq!(fresh.reset(5), &before[..]);
    let good = vec![0.1; 3 * ACTION_DIM];
    let a = venv.step(&good).unwrap().obs.to_vec();
    assert_eq!(a, fresh.step(&good).unwrap().obs);
}

#[test]
fn a_restart_cuts_running_episodes_and_reseeds_every_env() {
    let n = 3;
    let actions = vec![0.0f32; n * ACTION_DIM];
    let mut plain = foosball_vec(n, 1);
    plain.reset(4);
    let stepped = plain.step(&actions).unwrap().obs.to_vec();
    let mut cut = foosball_vec(n, 1);
    cut.reset(4);
    let seeds = [11, 12, 13];
    let s = cut.step_then_restart(&actions, &seeds).unwrap();
    assert!(s.truncated.iter().all(|&t| t), "every episode ends");
    for i in 0..n {
        let last = &stepped[i * OBS_DIM..(i + 1) * OBS_DIM];
        assert_eq!(s.final_observation(i).unwrap(), last, "env {i}");
    }
    let mut fresh = foosball_vec(n, 1);
    assert_eq!(s.obs, fresh.reset_with_seeds(&seeds));
}

#[test]
fn an_unseeded_reset_continues_every_env_stream() {
    // reset(seed), then reset_unseeded(): each env's second episode is the one that
    // env alone would start after its own seeded first episode.
    let mut venv = foosball_vec(3, 2);
    venv.reset(5);
    let batch = venv.reset_unseeded().to_vec();
    for i in 0..3 {
        let mut env = FoosballEnv::new(venv.envs()[i].config().clone()).unwrap();
        env.reset(Some(foosball_rl::env::seeding::derive_seed(
            5,
            foosball_rl::env::seeding::TRAIN_ENVS,
            i as u64,
        )));
        assert_eq!(env.reset(None), batch[i * OBS_DIM..(i + 1) * OBS_DIM]);
    }
}
