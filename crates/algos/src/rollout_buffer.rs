//! PPO's rollout storage and generalised advantage estimation (SB3's `RolloutBuffer`).

use foosball_nets::{Snapshot, SnapshotError};

/// `[n_steps, n_envs]` advantages and returns from a rollout, row-major (step-major).
///
/// `rewards`, `values`, `episode_starts` are `[n_steps * n_envs]`; `episode_starts[t, e]`
/// is 1 when step `t` began an episode of env `e`. `last_values` and `last_dones` are
/// `[n_envs]`: `V` of the observation after the last step and whether that step ended its
/// episode. Truncations must already be folded into `rewards` as `r += gamma * V(s_final)`.
///
/// `delta_t = r_t + gamma V_{t+1} (1 - done_{t+1}) - V_t`,
/// `A_t = delta_t + gamma lambda (1 - done_{t+1}) A_{t+1}`, returns `= A + V`.
pub fn gae(
    rewards: &[f32],
    values: &[f32],
    episode_starts: &[f32],
    last_values: &[f32],
    last_dones: &[f32],
    gamma: f32,
    lambda: f32,
) -> (Vec<f32>, Vec<f32>) {
    let n_envs = last_values.len();
    let n = rewards.len();
    assert!(
        n_envs > 0 && n.is_multiple_of(n_envs),
        "rollout arrays must be [n_steps, n_envs]"
    );
    assert_eq!(
        (values.len(), episode_starts.len(), last_dones.len()),
        (n, n, n_envs)
    );
    let mut advantages = vec![0.0; n];
    for e in 0..n_envs {
        let mut running = 0.0;
        for i in (e..n).step_by(n_envs).rev() {
            let (next_value, next_non_terminal) = if i + n_envs >= n {
                (last_values[e], 1.0 - last_dones[e])
            } else {
                (values[i + n_envs], 1.0 - episode_starts[i + n_envs])
            };
            let delta = rewards[i] + gamma * next_value * next_non_terminal - values[i];
            running = delta + gamma * lambda * next_non_terminal * running;
            advantages[i] = running;
        }
    }
    let returns = advantages.iter().zip(values).map(|(a, v)| a + v).collect();
    (advantages, returns)
}

/// One PPO rollout of `n_steps` vec-env steps, stored step-major.
#[derive(Clone, Debug, Default)]
pub struct RolloutBuffer {
    /// Observations acted on, `[len, obs_dim]`.
    pub obs: Vec<f32>,
    /// Unclipped actions sampled from the policy, `[len, action_dim]`.
    pub actions: Vec<f32>,
    /// Rewards, truncations already bootstrapped, `[len]`.
    pub rewards: Vec<f32>,
    /// 1 where the observation began an episode, `[len]`.
    pub episode_starts: Vec<f32>,
    /// `V(obs)` at collection time, `[len]`.
    pub values: Vec<f32>,
    /// `log pi(action|obs)` at collection time, `[len]`.
    pub log_probs: Vec<f32>,
    /// A teacher's action on each observation, `[len, action_dim]`; empty without a
    /// teacher ([`crate::kickstart`]).
    pub teacher: Vec<f32>,
}

impl RolloutBuffer {
    /// Rows stored (vec-env steps times envs).
    pub fn len(&self) -> usize {
        self.rewards.len()
    }

    /// Whether nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.rewards.is_empty()
    }

    /// Forgets every row, keeping the allocations.
    pub fn clear(&mut self) {
        for column in self.columns_mut() {
            column.clear();
        }
    }

    /// The columns, in [`RolloutBuffer::COLUMNS`] order.
    fn columns(&self) -> [&[f32]; 7] {
        [
            &self.obs,
            &self.actions,
            &self.rewards,
            &self.episode_starts,
            &self.values,
            &self.log_probs,
            &self.teacher,
        ]
    }

    fn columns_mut(&mut self) -> [&mut Vec<f32>; 7] {
        [
            &mut self.obs,
            &mut self.actions,
            &mut self.rewards,
            &mut self.episode_starts,
            &mut self.values,
            &mut self.log_probs,
            &mut self.teacher,
        ]
    }

    /// The columns' names in saved state.
    const COLUMNS: [&str; 7] = [
        "obs",
        "actions",
        "rewards",
        "episode_starts",
        "values",
        "log_probs",
        "teacher",
    ];

    /// Stores the rows collected so far under `prefix` (borrowed, not copied).
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        for (name, column) in Self::COLUMNS.iter().zip(self.columns()) {
            snap.put_f32(format!("{prefix}.{name}"), column);
        }
    }

    /// Restores what [`RolloutBuffer::save_state`] stored under `prefix`; a checkpoint
    /// written before the teacher's column existed holds no labels.
    pub fn load_state(&mut self, snap: &Snapshot<'_>, prefix: &str) -> Result<(), SnapshotError> {
        for (name, column) in Self::COLUMNS.iter().zip(self.columns_mut()) {
            let key = format!("{prefix}.{name}");
            *column = if *name == "teacher" && !snap.contains(&key) {
                Vec::new()
            } else {
                snap.f32s(&key)?.to_vec()
            };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_envs_are_independent_columns() {
        // Env 0: one episode ending at the last step (done); env 1: a reset at step 1.
        let rewards = [1.0, 2.0, 1.0, 2.0, 1.0, 2.0];
        let values = [0.5, 0.1, 0.5, 0.2, 0.5, 0.3];
        let starts = [1.0, 1.0, 0.0, 1.0, 0.0, 0.0];
        let (adv, ret) = gae(
            &rewards,
            &values,
            &starts,
            &[9.0, 0.4],
            &[1.0, 0.0],
            0.9,
            0.5,
        );
        // Env 0 by hand (last step terminal, so last_value is ignored).
        let a2 = 1.0 - 0.5;
        let a1 = 1.0 + 0.9 * 0.5 - 0.5 + 0.45 * a2;
        let a0 = 1.0 + 0.9 * 0.5 - 0.5 + 0.45 * a1;
        // Env 1: step 0's episode ends (step 1 starts anew), steps 1..2 bootstrap 0.4.
        let b2 = 2.0 + 0.9 * 0.4 - 0.3;
        let b1 = 2.0 + 0.9 * 0.3 - 0.2 + 0.45 * b2;
        let b0 = 2.0 - 0.1;
        let expected = [a0, b0, a1, b1, a2, b2];
        for (x, y) in adv.iter().zip(expected) {
            assert!((x - y).abs() < 1e-6, "{adv:?} vs {expected:?}");
        }
        for i in 0..6 {
            assert!((ret[i] - adv[i] - values[i]).abs() < 1e-6);
        }
    }
}
