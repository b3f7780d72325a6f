//! Demonstrations a run learns from (`protocol.demonstrations`): one or several
//! `trajectories.bin` that `evaluate` wrote (the planner's episodes on seeds of their
//! own, against one opponent or another, say), checked
//! against the run's held-out seeds, its world-frame states read in the run's ball frame
//! with what its observation hides hidden (what the agent observes), each terminated
//! episode marked absorbing when its last state has the ball in a goal, and handed to the
//! agent. They are read again on a
//! resume (a checkpoint does not hold them).

use crate::config::RunConfig;
use crate::play::trajectories::{RecordedEpisode, read_trajectories};
use foosball_algos::{Agent, Demonstration};
use foosball_env::foosball::in_ball_frame;
use foosball_env::layout::OBS_DIM;
use foosball_env::seeding::{EVAL_ENVS, TEST_ENVS, derive_seed};
use foosball_env::{ObservationKind, ball_in_a_goal};
use std::collections::HashSet;
use std::path::Path;

/// Gives `agent` the episodes of the files of `config.protocol.demonstrations`, in
/// order, and returns how many transitions it kept (`None` when the key is unset). An
/// episode shorter than the table's `max_episode_steps` ended in a terminal state; one
/// that long was cut. A refusal names the key and the file: unreadable, an image
/// observation (the files hold states), an episode played from one of the run's
/// evaluation or test starts (they would leak into the held-out seeds), widths the agent
/// does not take, or an algorithm without `off_policy.demo_share`.
pub fn give_demonstrations(
    config: &RunConfig,
    agent: &mut dyn Agent,
) -> Result<Option<usize>, String> {
    let Some(files) = &config.protocol.demonstrations else {
        return Ok(None);
    };
    let key = "protocol.demonstrations";
    if config.env.observation.kind != ObservationKind::State {
        return Err(format!(
            "{key}: the files hold states; this run observes images"
        ));
    }
    let limit = config.env.max_episode_steps as usize;
    let frame = config.env.ball_frame;
    // Per episode: its states in the run's ball frame, its actions and rewards.
    let mut episodes = Vec::new();
    for (path, k, e) in learnable_episodes(config, key, files.paths())? {
        let refuse = |why: String| format!("{key} = \"{path}\": {why}");
        let t = e.trajectory;
        if t.obs.len() != t.rewards.len() * OBS_DIM {
            return Err(refuse(format!(
                "episode {k} holds {} state values for {} steps, not {OBS_DIM} per step",
                t.obs.len(),
                t.rewards.len()
            )));
        }
        let rows: Vec<f32> = t
            .obs
            .chunks_exact(OBS_DIM)
            .flat_map(|s| {
                let mut row = in_ball_frame(s.try_into().expect("a full row"), frame);
                config.env.observation.conceal(&mut row);
                row
            })
            .collect();
        // A terminated episode ends absorbing when its last state has the ball in a
        // goal (under the paper's rules it lies there until it is still).
        let absorbing = t
            .obs
            .chunks_exact(OBS_DIM)
            .last()
            .is_some_and(|s| ball_in_a_goal(&config.env, s));
        episodes.push((rows, t.actions, t.rewards, absorbing));
    }
    let demos: Vec<Demonstration<'_>> = episodes
        .iter()
        .map(|(obs, actions, rewards, absorbing)| Demonstration {
            obs,
            actions,
            rewards,
            terminated: rewards.len() < limit,
            absorbing: *absorbing,
        })
        .collect();
    agent
        .set_demonstrations(&demos)
        .map(Some)
        .map_err(|why| format!("{key} = {}: {why}", names(files.paths())))
}

/// The episodes of the files `paths`, in order, each with its file and its index there,
/// for a run to learn from; one that starts from the run's evaluation or test starts
/// (which would leak into its held-out seeds) or a file that cannot be read is refused,
/// naming `key` and the file.
pub fn learnable_episodes<'a>(
    config: &RunConfig,
    key: &str,
    paths: &'a [String],
) -> Result<Vec<(&'a str, usize, RecordedEpisode)>, String> {
    let held_out = held_out_seeds(config);
    let mut kept = Vec::new();
    for path in paths {
        let refuse = |why: String| format!("{key} = \"{path}\": {why}");
        for (k, e) in read_trajectories(Path::new(path))
            .map_err(refuse)?
            .into_iter()
            .enumerate()
        {
            if held_out.contains(&e.seed) {
                return Err(refuse(format!(
                    "episode {k} starts from seed {}, one of this run's evaluation or test \
                     starts (record it with another `evaluate --seed` than the run's)",
                    e.seed
                )));
            }
            kept.push((path.as_str(), k, e));
        }
    }
    Ok(kept)
}

/// The reset seeds of the run's evaluation and test episodes, which no episode it learns
/// from may start from.
fn held_out_seeds(config: &RunConfig) -> HashSet<u64> {
    let p = &config.protocol;
    (0..u64::from(p.eval_episodes))
        .map(|k| derive_seed(p.seed, EVAL_ENVS, k))
        .chain((0..u64::from(p.test_episodes)).map(|k| derive_seed(p.seed, TEST_ENVS, k)))
        .collect()
}

/// The files as the config names them: `"a"` or `["a", "b"]`.
pub fn names(paths: &[String]) -> String {
    let quoted: Vec<String> = paths.iter().map(|p| format!("\"{p}\"")).collect();
    match quoted.as_slice() {
        [one] => one.clone(),
        _ => format!("[{}]", quoted.join(", ")),
    }
}
