//! Demonstrations: episodes another player played (the planner's, say). The off-policy
//! learners hold them in a replay buffer of their own that is never overwritten and mixed
//! into every minibatch at `off_policy.demo_share` (RLPD's symmetric sampling when 0.5;
//! Ball et al. 2023); PPO clones their state-action rows ([`crate::demo_cloning`]).

use crate::replay::ReplayBuffer;

/// One demonstrated episode, row-major, of `T` steps: `obs` `[T, obs_dim]` (the states
/// acted on), `actions` `[T, action_dim]` in `[-1, 1]`, `rewards` `[T]` (the env's,
/// unscaled); `terminated` says whether it ended in a terminal state (else it was cut).
#[derive(Clone, Copy, Debug)]
pub struct Demonstration<'a> {
    /// States acted on, `[T, obs_dim]`.
    pub obs: &'a [f32],
    /// Actions played, `[T, action_dim]`.
    pub actions: &'a [f32],
    /// Rewards received, `[T]`.
    pub rewards: &'a [f32],
    /// The episode ended in a terminal state on its last step.
    pub terminated: bool,
    /// That terminal state is absorbing (the env's `StepInfo::absorbing`: for foosball
    /// the ball lying in a goal); ignored when not `terminated`.
    pub absorbing: bool,
}

/// The transitions of `episodes` in a buffer of exactly their number:
/// `(s_t, a_t, store(r_t, ends_absorbing), s_(t+1))`, `store` being what the replay does
/// to a reward (`OffPolicyConfig::stored_reward`; `ends_absorbing` only on the last step
/// of a terminated, absorbing episode). The last step of a terminated episode is terminal
/// (its next state never enters a target); the last step of a cut one is dropped, its
/// next state being unknown. An error names the episode whose widths do not fit
/// `obs_dim`/`action_dim` or that holds a non-finite value.
pub fn demonstration_buffer(
    episodes: &[Demonstration<'_>],
    obs_dim: usize,
    action_dim: usize,
    store: impl Fn(f32, bool) -> f32,
) -> Result<ReplayBuffer, String> {
    check_episodes(episodes, obs_dim, action_dim)?;
    let rows: usize = (episodes.iter())
        .map(|e| {
            let t = e.rewards.len();
            if e.terminated { t } else { t.saturating_sub(1) }
        })
        .sum();
    if rows == 0 {
        return Err("the demonstrations hold no transition".into());
    }
    let mut buffer = ReplayBuffer::new(rows, obs_dim, action_dim);
    for e in episodes {
        let t = e.rewards.len();
        for i in 0..t {
            let last = i + 1 == t;
            if last && !e.terminated {
                break;
            }
            let next = if last { i } else { i + 1 };
            buffer.push(
                &e.obs[i * obs_dim..(i + 1) * obs_dim],
                &e.actions[i * action_dim..(i + 1) * action_dim],
                store(e.rewards[i], last && e.absorbing),
                &e.obs[next * obs_dim..(next + 1) * obs_dim],
                last,
                false,
            );
        }
    }
    Ok(buffer)
}

/// Every state of `episodes` with the action played there, row-major: `(obs [rows,
/// obs_dim], actions [rows, action_dim])`, the episodes one after the other (a cut
/// episode's last state included: cloning needs no next state). The same refusals as
/// [`demonstration_buffer`].
pub fn demonstration_rows(
    episodes: &[Demonstration<'_>],
    obs_dim: usize,
    action_dim: usize,
) -> Result<(Vec<f32>, Vec<f32>), String> {
    check_episodes(episodes, obs_dim, action_dim)?;
    if episodes.iter().all(|e| e.rewards.is_empty()) {
        return Err("the demonstrations hold no state".into());
    }
    let obs = episodes
        .iter()
        .flat_map(|e| e.obs.iter().copied())
        .collect();
    let actions = (episodes.iter())
        .flat_map(|e| e.actions.iter().copied())
        .collect();
    Ok((obs, actions))
}

/// Refuses an episode whose widths do not fit `obs_dim`/`action_dim` or that holds a
/// non-finite value, naming it.
fn check_episodes(
    episodes: &[Demonstration<'_>],
    obs_dim: usize,
    action_dim: usize,
) -> Result<(), String> {
    for (k, e) in episodes.iter().enumerate() {
        let t = e.rewards.len();
        if e.obs.len() != t * obs_dim || e.actions.len() != t * action_dim {
            return Err(format!(
                "demonstration {k}: {} observation and {} action values for {t} steps; \
                 the learner takes {obs_dim} and {action_dim} per step",
                e.obs.len(),
                e.actions.len()
            ));
        }
        let finite = e.obs.iter().chain(e.actions).chain(e.rewards);
        if !finite.clone().all(|x| x.is_finite()) {
            return Err(format!("demonstration {k}: a non-finite value"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn transitions_link_consecutive_states_end_terminal_or_drop_the_cut_step() {
        // Observation k is [k]; action k is [-k / 10]; reward k is k + 1; both episodes
        // end absorbing, which counts only for the terminated one's last step.
        let obs: Vec<f32> = (0..3).map(|k| k as f32).collect();
        let actions: Vec<f32> = (0..3).map(|k| -(k as f32) / 10.0).collect();
        let rewards: Vec<f32> = (0..3).map(|k| k as f32 + 1.0).collect();
        let ended = Demonstration {
            obs: &obs,
            actions: &actions,
            rewards: &rewards,
            terminated: true,
            absorbing: true,
        };
        let cut = Demonstration {
            terminated: false,
            ..ended
        };
        let store = |r: f32, absorbing: bool| if absorbing { 100.0 * r } else { 0.5 * r };
        let buffer = demonstration_buffer(&[ended, cut], 1, 1, store).unwrap();
        assert_eq!(buffer.len(), 5);
        assert_eq!(buffer.capacity(), 5);
        let batch = buffer.sample(400, &mut ChaCha8Rng::seed_from_u64(0));
        let mut seen: Vec<(f32, f32, f32, f32, f32)> = (0..400)
            .map(|i| {
                let b = &batch;
                (
                    b.obs[i],
                    b.actions[i],
                    b.rewards[i],
                    b.next_obs[i],
                    b.dones[i],
                )
            })
            .collect();
        seen.sort_by(|x, y| x.partial_cmp(y).unwrap());
        seen.dedup();
        assert_eq!(
            seen,
            vec![
                (0.0, 0.0, 0.5, 1.0, 0.0),
                (1.0, -0.1, 1.0, 2.0, 0.0),
                (2.0, -0.2, 300.0, 2.0, 1.0),
            ]
        );
    }

    #[test]
    fn misfit_widths_non_finite_values_and_no_rows_are_refused_by_episode() {
        let good = Demonstration {
            obs: &[0.0, 1.0],
            actions: &[0.5],
            rewards: &[1.0],
            terminated: true,
            absorbing: false,
        };
        let wide = demonstration_buffer(&[good, good], 1, 1, |r, _| r).unwrap_err();
        assert!(
            wide.contains("demonstration 0") && wide.contains("takes 1 and 1"),
            "{wide}"
        );
        let nan = Demonstration {
            obs: &[0.0],
            actions: &[f32::NAN],
            ..good
        };
        let err = demonstration_buffer(&[nan], 1, 1, |r, _| r).unwrap_err();
        assert!(err.contains("non-finite"), "{err}");
        let one_cut = Demonstration {
            obs: &[0.0],
            terminated: false,
            ..good
        };
        let err = demonstration_buffer(&[one_cut], 1, 1, |r, _| r).unwrap_err();
        assert!(err.contains("no transition"), "{err}");
        // As rows to clone, the cut episode's one state counts; the same refusals.
        let (obs, actions) = demonstration_rows(&[one_cut, one_cut], 1, 1).unwrap();
        assert_eq!((obs, actions), (vec![0.0, 0.0], vec![0.5, 0.5]));
        let wide = demonstration_rows(&[good], 1, 1).unwrap_err();
        assert!(wide.contains("demonstration 0"), "{wide}");
        let err = demonstration_rows(&[one_cut, nan], 1, 1).unwrap_err();
        assert!(err.contains("demonstration 1: a non-finite"), "{err}");
        let empty = Demonstration {
            obs: &[],
            actions: &[],
            rewards: &[],
            ..good
        };
        let err = demonstration_rows(&[empty], 1, 1).unwrap_err();
        assert!(err.contains("no state"), "{err}");
    }
}
