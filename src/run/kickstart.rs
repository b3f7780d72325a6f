//! The teacher of a run with `[ppo.kickstart]` ([`foosball_algos::kickstart`]): a
//! built-in controller that labels every observation the learner acts on with its own
//! action, in the env's action space, for PPO's cloning term.
//!
//! The built-in players keep no state between steps (a kicker reads where a rod is in its
//! swing off its angle), so one copy labels every env's observation and a resumed run
//! labels as the uninterrupted one; the random player, whose action is a draw and not a
//! function of the state, is refused ([`crate::config::RunConfig::validate`]).

use crate::config::{AlgoConfig, RunConfig};
use foosball_algos::BatchPolicy;
use foosball_env::EnvRng;
use foosball_env::layout::OBS_DIM;
use foosball_env::roster::opponent_for;
use rand::SeedableRng;

/// The labeller of `config`'s teacher: observations `[n, 38]` in, the teacher's actions
/// `[n, 8]` out; `None` where the run has no teacher.
pub fn teacher_labels(config: &RunConfig) -> Option<Box<BatchPolicy<'static>>> {
    let AlgoConfig::Ppo(ppo) = &config.algorithm else {
        return None;
    };
    let mut teacher = opponent_for(ppo.kickstart.teacher?);
    let map = config.env.action_map;
    // Never read: the teachers allowed act on the state alone.
    let mut rng = EnvRng::seed_from_u64(0);
    Some(Box::new(move |obs: &[f32]| {
        obs.chunks_exact(OBS_DIM)
            .flat_map(|o| {
                let o = o.try_into().expect("chunks of the state's width");
                teacher.act_in(map, o, &mut rng)
            })
            .collect()
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use foosball_env::layout::{ACTION_DIM, BALL_POS, action_turn};
    use foosball_env::{Opponent, scripted::Kicker};
    use std::path::Path;

    fn config(text: &str) -> RunConfig {
        RunConfig::from_toml(text, Path::new("x.toml")).unwrap()
    }

    #[test]
    fn the_shooter_labels_each_row_as_it_would_play_it() {
        assert!(
            teacher_labels(&config("algo = \"ppo\"")).is_none(),
            "no teacher, no labels"
        );
        let config = config("algo = \"ppo\"\n[ppo.kickstart]\nteacher = \"shooter\"\n");
        let mut label = teacher_labels(&config).expect("a teacher");
        // Two states: the ball just ahead of yellow's attack rod and far behind it.
        let mut obs = vec![0.0; 2 * OBS_DIM];
        let attack_y = foosball_env::geometry::RODS[3].yellow_y;
        obs[BALL_POS.start + 1] = attack_y + 2.0;
        obs[OBS_DIM + BALL_POS.start + 1] = -40.0;
        let labels = label(&obs);
        assert_eq!(labels.len(), 2 * ACTION_DIM);
        let mut rng = EnvRng::seed_from_u64(1);
        for (row, o) in obs.chunks_exact(OBS_DIM).enumerate() {
            let expected =
                Kicker::shooter().act_in(config.env.action_map, o.try_into().unwrap(), &mut rng);
            assert_eq!(labels[row * ACTION_DIM..(row + 1) * ACTION_DIM], expected);
        }
        assert!(
            labels[action_turn(3)] != labels[ACTION_DIM + action_turn(3)],
            "the attack rod plays the two states differently"
        );
    }
}
