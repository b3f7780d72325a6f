//! Where a training episode begins: the table's own draw, or a point along a recorded
//! episode (a teacher's trajectory, issue 49's reverse curriculum). A recorded episode is
//! reached exactly, not approximately: the table is reset from the episode's own seed and
//! its first actions are played again, so the state, the episode's counters and every
//! random stream are where they were when it was recorded (on the same game; a caller
//! checks that once, e.g. by replaying each episode to its end).
//!
//! [`crate::FoosballEnv::with_starts`] installs an [`EpisodeStarts`]; the env asks it at
//! every reset without a seed (a vector env's automatic restarts). While a replayed
//! episode runs, the env keeps its own random stream aside and takes it up again at its
//! next own draw, so the episodes it draws itself are the ones it would have drawn
//! without the replayed ones in between.

use crate::layout::ACTION_DIM;

/// A start along a recorded episode: reset from `seed`, then play `actions`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayStart {
    /// The seed the recorded episode was reset with.
    pub seed: u64,
    /// Its first actions, one row per agent step, in `[-1, 1]`; the agent takes over
    /// after the last (none: the recorded episode's start itself).
    pub actions: Vec<[f32; ACTION_DIM]>,
}

/// Chooses the start of each training episode.
pub trait EpisodeStarts: Send {
    /// The next episode's start, asked at every reset without a seed, after `env_steps`
    /// agent steps of this env (replayed steps not counted): `None` for the env's own draw.
    fn next_start(&mut self, env_steps: u64) -> Option<ReplayStart>;

    /// Called at every reset with a seed (a vector env's restarts): a chooser with a
    /// random stream of its own reseeds it from `seed` here, so that what follows depends
    /// on the seed alone (a run resumed at that restart chooses as the uninterrupted one).
    fn reseed(&mut self, _seed: u64) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Env, FoosballConfig, FoosballEnv};
    use rand::{Rng, SeedableRng};
    use std::collections::VecDeque;
    use std::sync::{Arc, Mutex};

    /// Hands out the starts it was given, in order (then the env's own draws), and
    /// notes every reseed.
    struct Given {
        starts: VecDeque<Option<ReplayStart>>,
        asked_at: Arc<Mutex<Vec<u64>>>,
        reseeds: Arc<Mutex<Vec<u64>>>,
    }

    impl EpisodeStarts for Given {
        fn next_start(&mut self, env_steps: u64) -> Option<ReplayStart> {
            self.asked_at.lock().unwrap().push(env_steps);
            self.starts.pop_front().flatten()
        }

        fn reseed(&mut self, seed: u64) {
            self.reseeds.lock().unwrap().push(seed);
        }
    }

    fn env() -> FoosballEnv {
        FoosballEnv::new(FoosballConfig::default()).unwrap()
    }

    /// An env that starts where `starts` say, and the logs of when it was asked and
    /// reseeded.
    fn with_given(starts: Vec<Option<ReplayStart>>) -> (FoosballEnv, [Arc<Mutex<Vec<u64>>>; 2]) {
        let logs = [Arc::default(), Arc::default()];
        let given = Given {
            starts: starts.into(),
            asked_at: Arc::clone(&logs[0]),
            reseeds: Arc::clone(&logs[1]),
        };
        (env().with_starts(Box::new(given)), logs)
    }

    /// `n` random actions from `seed`.
    fn actions(n: usize, seed: u64) -> Vec<[f32; ACTION_DIM]> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| std::array::from_fn(|_| rng.random_range(-1.0..1.0)))
            .collect()
    }

    /// Steps `env` through `actions`, returning each observation after a step (stopping
    /// at the episode's end).
    fn play(env: &mut FoosballEnv, actions: &[[f32; ACTION_DIM]]) -> Vec<Vec<f32>> {
        let mut seen = Vec::new();
        for a in actions {
            let (obs, t) = env.step(a).unwrap();
            seen.push(obs);
            if t.done() {
                break;
            }
        }
        seen
    }

    #[test]
    fn a_replayed_start_is_the_recorded_state_and_the_episode_goes_on_as_recorded() {
        let acts = actions(9, 1);
        let mut recorder = env();
        recorder.reset(Some(42));
        let recorded = play(&mut recorder, &acts);
        assert_eq!(recorded.len(), 9, "the recorded episode runs 9 steps");
        let start = ReplayStart {
            seed: 42,
            actions: acts[..5].to_vec(),
        };
        let (mut learner, [asked_at, reseeds]) = with_given(vec![Some(start)]);
        learner.reset(Some(7));
        let obs = learner.reset(None);
        assert_eq!(
            obs, recorded[4],
            "the observation after the 5 replayed steps"
        );
        let (after, t) = learner.step(&acts[5]).unwrap();
        assert_eq!(after, recorded[5]);
        assert_eq!(t.info.replayed, Some(5), "the info says how it began");
        assert_eq!(t.info.steps, 6, "the replayed steps are the episode's");
        assert_eq!(play(&mut learner, &acts[6..]), recorded[6..].to_vec());
        assert_eq!(
            *reseeds.lock().unwrap(),
            [7],
            "the seeded reset reseeds the chooser"
        );
        assert_eq!(
            *asked_at.lock().unwrap(),
            [0],
            "asked once, before any agent step"
        );
    }

    #[test]
    fn the_env_draws_its_own_starts_as_if_no_episode_had_been_replayed() {
        let acts = actions(3, 2);
        let mut plain = env();
        plain.reset(Some(9));
        play(&mut plain, &acts);
        let own = plain.reset(None);
        let after_own = play(&mut plain, &acts);

        let replayed = ReplayStart {
            seed: 1234,
            actions: acts.clone(),
        };
        let (mut learner, [asked_at, _]) = with_given(vec![Some(replayed), None]);
        learner.reset(Some(9));
        play(&mut learner, &acts);
        let obs = learner.reset(None);
        assert_ne!(obs, own, "the first restart is the replayed episode");
        play(&mut learner, &acts[..2]);
        assert_eq!(
            learner.reset(None),
            own,
            "then the own draw, as without the replay"
        );
        assert_eq!(play(&mut learner, &acts), after_own);
        assert_eq!(
            *asked_at.lock().unwrap(),
            [3, 5],
            "agent steps, replayed ones not counted"
        );
    }

    #[test]
    fn a_start_whose_episode_ends_on_the_way_gives_way_to_the_own_draw() {
        // Forty still actions: the recorded episode ends (a still ball) long before.
        let still = ReplayStart {
            seed: 5,
            actions: vec![[0.0; ACTION_DIM]; 40],
        };
        let mut ended = env();
        ended.reset(Some(5));
        assert!(
            play(&mut ended, &still.actions).len() < 40,
            "still rods end the episode"
        );
        let mut plain = env();
        plain.reset(Some(3));
        let own = plain.reset(None);
        let (mut learner, _) = with_given(vec![Some(still)]);
        learner.reset(Some(3));
        assert_eq!(learner.reset(None), own);
        let (_, t) = learner.step(&[0.0; ACTION_DIM]).unwrap();
        assert_eq!(t.info.replayed, None, "an episode the env drew itself");
    }
}
