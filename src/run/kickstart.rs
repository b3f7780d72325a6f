//! The teacher of a run with `[ppo.kickstart]` ([`foosball_algos::kickstart`]): a
//! built-in controller that labels every observation the learner acts on with its own
//! action, in the env's action space, for PPO's cloning term.
//!
//! The labels are those the controller plays on the run's table
//! ([`crate::play::scripted::controller_policy`]: the ball read back in world
//! coordinates, the commands in the run's action map). The built-in players keep no state
//! between steps (a kicker reads where a rod is in its swing off its angle), so one copy
//! labels every env's observation and a resumed run labels as the uninterrupted one; the
//! random player, whose action is a draw and not a function of the state, is refused
//! ([`crate::config::RunConfig::validate`]).

use crate::config::{AlgoConfig, RunConfig};
use crate::play::scripted::controller_policy;
use foosball_algos::BatchPolicy;
use foosball_env::roster::opponent_for;

/// The labeller of `config`'s teacher: observations `[n, 38]` in, the teacher's actions
/// `[n, 8]` out; `None` where the run has no teacher.
pub fn teacher_labels(config: &RunConfig) -> Option<Box<BatchPolicy<'static>>> {
    let AlgoConfig::Ppo(ppo) = &config.algorithm else {
        return None;
    };
    let teacher = opponent_for(ppo.kickstart.teacher?);
    // The seed is never read: the teachers allowed act on the state alone.
    Some(controller_policy(teacher, 0, &config.env))
}

#[cfg(test)]
mod tests {
    use super::*;
    use foosball_env::config::BallFrame;
    use foosball_env::foosball::in_ball_frame;
    use foosball_env::layout::{ACTION_DIM, BALL_POS, OBS_DIM, action_turn};
    use foosball_env::{EnvRng, Opponent, scripted::Kicker};
    use rand::SeedableRng;
    use std::path::Path;

    fn config(text: &str) -> RunConfig {
        RunConfig::from_toml(text, Path::new("x.toml")).unwrap()
    }

    /// On `reference`'s joint frame the learner reads the ball 4 cm off its world y; the
    /// labels are what the shooter plays on the world state.
    #[test]
    fn the_shooter_labels_each_row_as_it_would_play_it() {
        assert!(
            teacher_labels(&config("algo = \"ppo\"")).is_none(),
            "no teacher, no labels"
        );
        let config = config("algo = \"ppo\"\n[ppo.kickstart]\nteacher = \"shooter\"\n");
        assert_eq!(config.env.ball_frame, BallFrame::Joint);
        let mut label = teacher_labels(&config).expect("a teacher");
        // Two world states: the ball just ahead of yellow's attack rod and far behind it.
        let attack_y = foosball_env::geometry::RODS[3].yellow_y;
        let worlds: Vec<[f32; OBS_DIM]> = [attack_y + 2.0, -40.0]
            .iter()
            .map(|&y| {
                let mut world = [0.0; OBS_DIM];
                world[BALL_POS.start + 1] = y;
                world
            })
            .collect();
        let seen: Vec<f32> = (worlds.iter())
            .flat_map(|w| in_ball_frame(w, config.env.ball_frame))
            .collect();
        let labels = label(&seen);
        assert_eq!(labels.len(), 2 * ACTION_DIM);
        let mut rng = EnvRng::seed_from_u64(1);
        for (row, world) in worlds.iter().enumerate() {
            let expected = Kicker::shooter().act_in(config.env.action_map, world, &mut rng);
            assert_eq!(labels[row * ACTION_DIM..(row + 1) * ACTION_DIM], expected);
        }
        assert!(
            labels[action_turn(3)] != labels[ACTION_DIM + action_turn(3)],
            "the attack rod plays the two states differently"
        );
    }
}
