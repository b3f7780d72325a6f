//! Demonstrations a run learns from (`protocol.demonstrations`): one or several
//! `trajectories.bin` that `evaluate` wrote (the planner's episodes on seeds of their
//! own, against one opponent or another, say), checked
//! against the run's held-out seeds, its world-frame states read in the run's ball frame
//! with what its observation hides hidden (what the agent observes), each terminated
//! episode marked absorbing when its last state has the ball in a goal, and handed to the
//! agent. They are read again on a
//! resume (a checkpoint does not hold them).

use crate::config::RunConfig;
use crate::play::scripted::Baseline;
use crate::play::trajectories::{RecordedEpisode, read_trajectories};
use foosball_algos::{Agent, Demonstration};
use foosball_env::foosball::in_ball_frame;
use foosball_env::layout::OBS_DIM;
use foosball_env::seeding::{EVAL_ENVS, TEST_ENVS, derive_seed};
use foosball_env::{ObservationKind, ball_in_a_goal};
use std::collections::HashSet;
use std::path::Path;

/// A demonstrated episode the run holds (the owned form of [`Demonstration`]): `obs`
/// `[T, obs_dim]` as the agent observes them, `actions` `[T, action_dim]`, `rewards` `[T]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DemoEpisode {
    /// States acted on, as the agent observes them, `[T, obs_dim]`.
    pub obs: Vec<f32>,
    /// Actions played, `[T, action_dim]`, in `[-1, 1]`.
    pub actions: Vec<f32>,
    /// Rewards received, `[T]`.
    pub rewards: Vec<f32>,
    /// It ended in a terminal state (else it was cut).
    pub terminated: bool,
    /// That terminal state has the ball lying in a goal.
    pub absorbing: bool,
}

impl DemoEpisode {
    /// The borrowed form the agents take.
    pub fn view(&self) -> Demonstration<'_> {
        Demonstration {
            obs: &self.obs,
            actions: &self.actions,
            rewards: &self.rewards,
            terminated: self.terminated,
            absorbing: self.absorbing,
        }
    }
}

/// Gives `agent` the episodes of the files of `config.protocol.demonstrations`, in
/// order, and returns how many rows it kept (`None` when the key is unset). A refusal
/// names the key and the files ([`file_demonstrations`]), or says why the agent cannot
/// take them (a learner without `off_policy.demo_share` or `[ppo.demonstrations]`).
pub fn give_demonstrations(
    config: &RunConfig,
    agent: &mut dyn Agent,
) -> Result<Option<usize>, String> {
    let Some(files) = &config.protocol.demonstrations else {
        return Ok(None);
    };
    let episodes = file_demonstrations(config)?;
    let demos: Vec<Demonstration<'_>> = episodes.iter().map(DemoEpisode::view).collect();
    agent
        .set_demonstrations(&demos)
        .map(Some)
        .map_err(|why| format!("protocol.demonstrations = {}: {why}", names(files.paths())))
}

/// The episodes of the files of `config.protocol.demonstrations` (none when the key is
/// unset), in order, as the agent observes them. An episode shorter than the table's
/// `max_episode_steps` ended in a terminal state; one that long was cut. A refusal names
/// the key and the file: unreadable, an image observation (the files hold states), an
/// episode played from one of the run's evaluation or test starts (they would leak into
/// the held-out seeds), or widths that are not the table's.
pub fn file_demonstrations(config: &RunConfig) -> Result<Vec<DemoEpisode>, String> {
    let Some(files) = &config.protocol.demonstrations else {
        return Ok(Vec::new());
    };
    let key = "protocol.demonstrations";
    if config.env.observation.kind != ObservationKind::State {
        return Err(format!(
            "{key}: the files hold states; this run observes images"
        ));
    }
    let limit = config.env.max_episode_steps as usize;
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
        // A terminated episode ends absorbing when its last state has the ball in a
        // goal (under the paper's rules it lies there until it is still).
        let absorbing = t
            .obs
            .chunks_exact(OBS_DIM)
            .last()
            .is_some_and(|s| ball_in_a_goal(&config.env, s));
        episodes.push(DemoEpisode {
            obs: as_observed(config, &t.obs),
            terminated: t.rewards.len() < limit,
            actions: t.actions,
            rewards: t.rewards,
            absorbing,
        });
    }
    Ok(episodes)
}

/// The table's 38-dim world states `states` (row-major, as `trajectories.bin` holds them)
/// as the run's agent observes them: read in its ball frame, what its observation hides
/// hidden.
pub fn as_observed(config: &RunConfig, states: &[f32]) -> Vec<f32> {
    states
        .chunks_exact(OBS_DIM)
        .flat_map(|s| {
            let mut row = in_ball_frame(s.try_into().expect("a full row"), config.env.ball_frame);
            config.env.observation.conceal(&mut row);
            row
        })
        .collect()
}

/// The episodes of the files `paths`, in order, each with its file and its index there,
/// for a run to learn from; one that starts from the run's evaluation or test starts
/// (which would leak into its held-out seeds), a file recorded on another table than the
/// run's ([`recorded_on_another_table`]) or one that cannot be read is refused, naming
/// `key` and the file.
pub fn learnable_episodes<'a>(
    config: &RunConfig,
    key: &str,
    paths: &'a [String],
) -> Result<Vec<(&'a str, usize, RecordedEpisode)>, String> {
    let held_out = held_out_seeds(config);
    let mut kept = Vec::new();
    for path in paths {
        let refuse = |why: String| format!("{key} = \"{path}\": {why}");
        if let Some(why) = recorded_on_another_table(config, Path::new(path)).map_err(refuse)? {
            return Err(refuse(why));
        }
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

/// Why the episodes of `trajectories` were played on another table than the run's, read
/// from the `baseline.toml` that `evaluate` wrote beside them (`None` on the same table,
/// or for a file with no such record); an unreadable record is an error.
fn recorded_on_another_table(
    config: &RunConfig,
    trajectories: &Path,
) -> Result<Option<String>, String> {
    let Some(dir) = trajectories
        .parent()
        .filter(|d| d.join("baseline.toml").is_file())
    else {
        return Ok(None);
    };
    let recorded = Baseline::read(dir).map_err(|e| format!("its baseline.toml: {e}"))?;
    Ok(config
        .env
        .table_difference(&recorded.env)
        .map(|(key, ours, theirs)| {
            format!(
                "recorded on another table: `{key} = {theirs}` there (its baseline.toml), \
             `{key} = {ours}` in this run; record them again on this run's table \
             (`evaluate --config` with this run's config)"
            )
        }))
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
