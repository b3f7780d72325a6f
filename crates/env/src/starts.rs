//! Where a training episode begins: the table's own draw, a practice spot for a share of
//! the serves ([`Drill`]), or a point along a recorded episode (a teacher's trajectory,
//! issue 49's reverse curriculum). A recorded episode is
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

use serde::{Deserialize, Serialize};

use crate::config::non_negative;
use crate::config_error::ConfigError;
use crate::layout::ACTION_DIM;

/// A practice spot for a share of a training env's serves: the ball at rest at
/// x ~ N(x_mean, x_std²), y ~ N(y_mean, y_std²), cm in the env's `ball_frame` (as
/// `start`'s numbers), kept on the field and turned onto black's side whenever `start`
/// turns a serve there. Installed on training envs only
/// ([`crate::FoosballEnv::with_drills`]): evaluations, tests and matches serve from
/// `start`. E.g. `y_mean = -52` in the joint frame lies between yellow's goalie and its
/// end wall, where a ball that its goalie does not play is held.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Drill {
    /// Share of the serves, in [0, 1]; the drills' shares sum to at most 1, and the
    /// serves left over are drawn from `start`.
    pub share: f32,
    /// Mean lateral position, cm.
    pub x_mean: f32,
    /// Its standard deviation, cm (default 0).
    #[serde(default)]
    pub x_std: f32,
    /// Mean position along the table (towards black's goal), cm.
    pub y_mean: f32,
    /// Its standard deviation, cm (default 0).
    #[serde(default)]
    pub y_std: f32,
}

/// Rejects shares outside [0, 1] (or summing past 1), negative spreads and non-finite
/// means, naming the key as `drills[i].key`.
pub fn validate_drills(drills: &[Drill]) -> Result<(), ConfigError> {
    let err = |i: usize, key: &str, message: String| {
        ConfigError::new(format!("drills[{i}].{key}"), message)
    };
    for (i, d) in drills.iter().enumerate() {
        if !(0.0..=1.0).contains(&d.share) {
            return Err(err(
                i,
                "share",
                format!("must be in [0, 1], got {}", d.share),
            ));
        }
        for (key, v) in [("x_mean", d.x_mean), ("y_mean", d.y_mean)] {
            if !v.is_finite() {
                return Err(err(i, key, format!("must be finite, got {v}")));
            }
        }
        for (key, v) in [("x_std", d.x_std), ("y_std", d.y_std)] {
            non_negative(&format!("drills[{i}].{key}"), v)?;
        }
    }
    let total: f32 = drills.iter().map(|d| d.share).sum();
    if total > 1.0 + 1e-6 {
        return Err(ConfigError::new(
            "drills",
            format!("the shares sum to {total}, past 1"),
        ));
    }
    Ok(())
}

/// The drill a serve comes from, given `u` uniform in [0, 1): the first whose running
/// share passes `u`; `None` (serve from `start`) past the last.
pub fn drill_at(drills: &[Drill], u: f32) -> Option<&Drill> {
    let mut reached = 0.0;
    drills.iter().find(|d| {
        reached += d.share;
        u < reached
    })
}

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

    /// The observations of the episode reset from `seed` and stepped through `actions`.
    fn recorded(seed: u64, actions: &[[f32; ACTION_DIM]]) -> Vec<Vec<f32>> {
        let mut recorder = env();
        recorder.reset(Some(seed));
        play(&mut recorder, actions)
    }

    fn drill(share: f32, x_mean: f32, y_mean: f32) -> Drill {
        Drill {
            share,
            x_mean,
            x_std: 0.0,
            y_mean,
            y_std: 0.0,
        }
    }

    /// The ball's world (x, y) on `env`'s table, cm.
    fn ball_xy(env: &FoosballEnv) -> [f32; 2] {
        let [x, y, _] = env.table().unwrap().ball_position();
        [x, y]
    }

    #[test]
    fn a_drill_is_picked_by_the_running_share_of_the_draw() {
        let drills = [drill(0.25, 1.0, 0.0), drill(0.5, 2.0, 0.0)];
        let picked = |u| drill_at(&drills, u).map(|d| d.x_mean);
        assert_eq!(picked(0.0), Some(1.0));
        assert_eq!(picked(0.2499), Some(1.0));
        assert_eq!(picked(0.25), Some(2.0));
        assert_eq!(picked(0.7499), Some(2.0));
        assert_eq!(picked(0.75), None, "past the drills: serve from `start`");
        assert_eq!(drill_at(&[], 0.0), None);
    }

    #[test]
    fn bad_drills_are_refused_by_their_key() {
        let key = |drills: &[Drill]| validate_drills(drills).unwrap_err().key;
        assert!(validate_drills(&[drill(0.5, 0.0, -52.0), drill(0.5, 0.0, 0.0)]).is_ok());
        assert_eq!(key(&[drill(1.5, 0.0, 0.0)]), "drills[0].share");
        assert_eq!(
            key(&[drill(0.1, 0.0, 0.0), drill(0.1, f32::NAN, 0.0)]),
            "drills[1].x_mean"
        );
        let mut spread = drill(0.1, 0.0, 0.0);
        spread.y_std = -1.0;
        assert_eq!(key(&[spread]), "drills[0].y_std");
        assert_eq!(key(&[drill(0.6, 0.0, 0.0), drill(0.6, 0.0, 0.0)]), "drills");
    }

    #[test]
    fn a_drill_serves_its_share_of_the_balls_at_its_spot_in_the_ball_frame() {
        let config = FoosballConfig::default();
        let [ox, oy, _] = config.ball_frame.origin();
        let spot = [5.0 + ox, -52.0 + oy];
        let mut drilled = env().with_drills(vec![drill(0.3, 5.0, -52.0)]);
        let mut plain = env();
        let mut at_spot = 0;
        for seed in 0..200 {
            drilled.reset(Some(seed));
            plain.reset(Some(seed));
            let ball = ball_xy(&drilled);
            if ball == spot {
                at_spot += 1;
            } else {
                assert!(
                    ball[1] > -20.0,
                    "seed {seed}: the paper's serve, by the centre"
                );
            }
            assert!(
                ball_xy(&plain)[1] > -20.0,
                "no drill: every serve from `start`"
            );
        }
        assert!(
            (40..=80).contains(&at_spot),
            "{at_spot} of 200 serves on the drill's spot, 60 expected"
        );
        let mut black = FoosballConfig::default();
        black.start.black_share = 1.0;
        let mut turned = FoosballEnv::new(black)
            .unwrap()
            .with_drills(vec![drill(1.0, 5.0, -52.0)]);
        turned.reset(Some(3));
        assert_eq!(
            ball_xy(&turned),
            [-spot[0], -spot[1]],
            "black's serves are turned about the centre"
        );
    }

    #[test]
    fn a_replayed_start_is_served_as_recorded_beside_drills() {
        let acts = actions(6, 4);
        let recorded = recorded(42, &acts);
        let start = ReplayStart {
            seed: 42,
            actions: acts[..3].to_vec(),
        };
        let (learner, _) = with_given(vec![Some(start)]);
        let mut learner = learner.with_drills(vec![drill(1.0, 5.0, -52.0)]);
        learner.reset(Some(7));
        assert_eq!(learner.reset(None), recorded[2]);
        assert_eq!(play(&mut learner, &acts[3..]), recorded[3..].to_vec());
    }

    #[test]
    fn no_drills_leave_every_draw_as_it_was() {
        let mut drilled = env().with_drills(Vec::new());
        let mut plain = env();
        let acts = actions(4, 3);
        assert_eq!(drilled.reset(Some(11)), plain.reset(Some(11)));
        assert_eq!(play(&mut drilled, &acts), play(&mut plain, &acts));
        assert_eq!(drilled.reset(None), plain.reset(None));
    }

    #[test]
    fn a_replayed_start_is_the_recorded_state_and_the_episode_goes_on_as_recorded() {
        let acts = actions(9, 1);
        let recorded = recorded(42, &acts);
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
