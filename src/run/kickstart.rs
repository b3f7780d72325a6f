//! The teacher of a run with `[ppo.kickstart]` ([`foosball_algos::kickstart`]): a
//! player that labels every state the learner acts on with its own action, in the env's
//! action space, for PPO's cloning term: a built-in controller, or a trained state policy
//! (a run's networks), which is how a pixel learner is taught by a state teacher (issue
//! 92: the teacher reads the state each picture was drawn from, [`Env::teacher_view`]).
//!
//! The labels are those the teacher plays on the run's table read as a state table
//! ([`Contestant::policy`]: a controller reads the ball back in world coordinates, a run's
//! networks their own observation; either's commands in the run's action map). A teacher
//! keeps no state between steps (a kicker reads where a rod is in its swing off its
//! angle; networks act deterministically), so one copy labels every env's state and a
//! resumed run labels as the uninterrupted one. A player that draws its actions (`random`,
//! a run's `~sampled` actions) is refused, and so are players whose answer can fail
//! mid-rollout (an ONNX file, a program).
//!
//! [`Env::teacher_view`]: foosball_env::Env::teacher_view

use crate::config::{AlgoConfig, RunConfig, TestActions};
use crate::play::contestant::Contestant;
use crate::play::scripted::ScriptedPolicy;
use foosball_algos::BatchPolicy;
use foosball_env::{FoosballConfig, ObservationKind};

/// The key a teacher is named under.
const KEY: &str = "ppo.kickstart.teacher";

/// `config`'s teacher as a player (`None` where the run has none), or why it cannot
/// teach; messages name the key.
fn teacher(config: &RunConfig) -> Result<Option<Contestant>, String> {
    let AlgoConfig::Ppo(ppo) = &config.algorithm else {
        return Ok(None);
    };
    let Some(name) = &ppo.kickstart.teacher else {
        return Ok(None);
    };
    let player: Contestant = name.parse().map_err(|e| format!("{KEY}: {e}"))?;
    refusal(&player).map_or(Ok(Some(player)), |why| {
        Err(format!("{KEY}: `{name}` {why}"))
    })
}

/// Why `player` cannot label states, if it cannot.
fn refusal(player: &Contestant) -> Option<&'static str> {
    match player {
        Contestant::Scripted(ScriptedPolicy::Random)
        | Contestant::Run {
            actions: TestActions::Stochastic,
            ..
        } => Some("draws its actions: a teacher acts on the state alone"),
        Contestant::Onnx { .. } | Contestant::Process { .. } => {
            Some("can fail mid-rollout: a teacher is a built-in player or a run directory")
        }
        Contestant::Held { player, .. } => refusal(player),
        Contestant::Scripted(_) | Contestant::Run { .. } => None,
    }
}

/// The labeller of `config`'s teacher: states `[n, 38]` in (as a state learner of the
/// run's table is handed them), the teacher's actions `[n, 8]` out; `None` where the run
/// has no teacher. A run directory that cannot teach on this table is refused by key.
pub fn teacher_labels(config: &RunConfig) -> Result<Option<Box<BatchPolicy<'static>>>, String> {
    let Some(player) = teacher(config)? else {
        return Ok(None);
    };
    let mut table: FoosballConfig = config.env.clone();
    table.observation.kind = ObservationKind::State;
    // The seed is never read: the teachers allowed act on the state alone.
    let mut policy = player
        .policy(&table, 0)
        .map_err(|e| format!("{KEY}: {e}"))?;
    Ok(Some(Box::new(move |states: &[f32]| {
        policy(states).expect("built-in players and a run's networks always answer")
    })))
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
            teacher_labels(&config("algo = \"ppo\"")).unwrap().is_none(),
            "no teacher, no labels"
        );
        let config = config("algo = \"ppo\"\n[ppo.kickstart]\nteacher = \"shooter\"\n");
        assert_eq!(config.env.ball_frame, BallFrame::Joint);
        let mut label = teacher_labels(&config).unwrap().expect("a teacher");
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
