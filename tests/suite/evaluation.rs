//! Evaluation episodes played side by side: seed order, reproducibility, trajectories
//! consistent with the summaries, agreement with one-at-a-time play, and sampled
//! (stochastic) tests that repeat exactly from their seed.

use foosball_rl::algos::{
    ActMode, Agent, BatchPolicy, Ppo, PpoConfig, Sac, SacConfig, Td3, Td3Config, deterministic,
    play_episode, play_episodes,
};
use foosball_rl::config::TestActions;
use foosball_rl::env::{FoosballConfig, FoosballEnv};
use foosball_rl::nets::Backend;
use foosball_rl::play::evaluation::{Episodes, PlayedEpisode, play_agent};
use foosball_rl::play::metrics::TestMetrics;

fn config() -> FoosballConfig {
    FoosballConfig {
        max_episode_steps: 40,
        ..FoosballConfig::default()
    }
}

fn agent() -> impl Agent {
    let mut c = SacConfig::default();
    c.net.hidden = vec![32];
    Sac::agent(
        38,
        8,
        c,
        3,
        &Backend::default_cpu().unwrap().device().unwrap(),
    )
}

fn envs(n: usize) -> Vec<FoosballEnv> {
    (0..n)
        .map(|_| FoosballEnv::new(config()).unwrap())
        .collect()
}

/// Foosball episodes of `policy` from `seeds`, `n` side by side.
fn play(policy: &mut BatchPolicy<'_>, n: usize, seeds: &[u64], record: bool) -> Vec<PlayedEpisode> {
    play_episodes(policy, &mut envs(n), seeds, |seed| {
        PlayedEpisode::new(seed, record)
    })
    .unwrap()
}

#[test]
fn episodes_come_back_in_seed_order_and_repeat_exactly() {
    let mut agent = agent();
    let seeds: Vec<u64> = (100..107).collect();
    let a = play(&mut deterministic(&mut agent), 3, &seeds, true);
    let b = play(&mut deterministic(&mut agent), 3, &seeds, true);
    assert_eq!(a, b);
    assert_eq!(a.iter().map(|e| e.seed).collect::<Vec<_>>(), seeds);
    for e in &a {
        let t = e.trajectory.as_ref().unwrap();
        let steps = e.summary.steps as usize;
        assert!((1..=40).contains(&steps));
        assert_eq!(
            (t.obs.len(), t.actions.len(), t.rewards.len()),
            (38 * steps, 8 * steps, steps)
        );
        let sum: f64 = t.rewards.iter().map(|&r| f64::from(r)).sum();
        assert!((sum - e.summary.ret).abs() < 1e-6 * sum.abs().max(1.0));
        assert!(e.summary.distance_sum > 0.0 && e.summary.final_distance > 0.0);
    }
    let m = TestMetrics::from_episodes(&a.iter().map(|e| e.summary).collect::<Vec<_>>());
    assert_eq!(m.episodes, 7);
    assert!(m.mean_goal_distance.mean > 0.0 && m.mean_goal_distance.mean < 200.0);
}

#[test]
fn one_env_at_a_time_matches_play_episode() {
    let mut agent = agent();
    let seeds = [5, 6];
    let batched = play(&mut deterministic(&mut agent), 1, &seeds, false);
    let mut env = FoosballEnv::new(config()).unwrap();
    for (played, seed) in batched.iter().zip(seeds) {
        let episode = play_episode(&mut agent, &mut env, seed).unwrap();
        assert_eq!(played.summary.ret, episode.ret);
        assert_eq!(played.summary.steps, episode.len);
        assert!(played.trajectory.is_none());
    }
}

#[test]
fn an_episode_ends_the_same_whichever_env_and_neighbours_play_it() {
    // A scripted policy acts on each row alone, so every episode must come out the same
    // however many envs play side by side (env reuse, seed hand-out and order included).
    let mut scripted = |obs: &[f32]| {
        obs.chunks(38)
            .flat_map(|o| {
                let vy = o[36];
                [vy.sin(), 0.5, -0.3, vy.cos(), 0.2, -0.8, 0.1, 0.9]
            })
            .collect::<Vec<f32>>()
    };
    let seeds: Vec<u64> = (20..29).collect();
    let one = play(&mut scripted, 1, &seeds, true);
    for n in [2, 4, 9] {
        assert_eq!(play(&mut scripted, n, &seeds, true), one, "{n} envs");
    }
}

/// Actions of a recorded episode set, flattened.
fn actions(played: &[PlayedEpisode]) -> Vec<f32> {
    played
        .iter()
        .flat_map(|e| e.trajectory.as_ref().unwrap().actions.clone())
        .collect()
}

/// Four recorded test-stream episodes of run seed 9 on the short table.
fn test_episodes(config: &FoosballConfig) -> Episodes<'_> {
    Episodes {
        env: config,
        seed: 9,
        stream: 3,
        n: 4,
        record: true,
    }
}

/// The episodes `agent` plays acting as `how`.
fn sampled_or_not(agent: &mut dyn Agent, how: TestActions) -> Vec<PlayedEpisode> {
    play_agent(agent, how, &test_episodes(&config())).unwrap()
}

#[test]
fn a_stochastic_test_samples_and_repeats_from_its_seed_whatever_came_before() {
    let mut c = PpoConfig::default();
    c.net.hidden = vec![32];
    let device = Backend::default_cpu().unwrap().device().unwrap();
    let agents: [(&str, Box<dyn Agent>); 2] = [
        ("sac", Box::new(agent())),
        ("ppo", Box::new(Ppo::new(38, 8, c, 3, &device))),
    ];
    for (name, mut agent) in agents {
        let sampled = sampled_or_not(agent.as_mut(), TestActions::Stochastic);
        assert_eq!(
            sampled_or_not(agent.as_mut(), TestActions::Stochastic),
            sampled,
            "{name}"
        );
        let fixed = sampled_or_not(agent.as_mut(), TestActions::Deterministic);
        assert_ne!(
            actions(&sampled),
            actions(&fixed),
            "{name}: sampling moves actions"
        );
        assert!(actions(&sampled).iter().all(|a| (-1.0..=1.0).contains(a)));
        // Exploring in between moves the agent's own stream, not the test's.
        for _ in 0..3 {
            agent.act(&[0.0; 38], ActMode::Explore);
        }
        assert_eq!(
            sampled_or_not(agent.as_mut(), TestActions::Stochastic),
            sampled,
            "{name}"
        );
    }
}

#[test]
fn td3_samples_its_deterministic_action_as_sb3_predict_does() {
    let mut c = Td3Config::default();
    c.net.hidden = vec![32];
    let device = Backend::default_cpu().unwrap().device().unwrap();
    let mut agent = Td3::agent(38, 8, c, 3, &device);
    assert_eq!(
        sampled_or_not(&mut agent, TestActions::Stochastic),
        sampled_or_not(&mut agent, TestActions::Deterministic)
    );
}
