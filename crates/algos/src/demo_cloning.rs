//! Demonstrations cloned beside PPO (`[ppo.demonstrations]`): after each rollout's
//! epochs, `updates` gradient steps each pull the policy's means towards the actions of
//! `batch_size` state-action rows drawn (with replacement) from the demonstrations the
//! agent holds ([`crate::Agent::set_demonstrations`]: another player's episodes, such
//! as the planner's answers to the learner's own states under `[dagger]`)
//!
//! ```text
//! L_demo   = coef / n * sum_rows sum_(j in J) (mu_j(s) - a_j)^2   ((s, a) demonstrated, n rows)
//! dL/dmu_j = 2 coef / n * (mu_j(s) - a_j)   (j in J; 0 elsewhere)
//! ```
//!
//! (`J`: the slide and turn commands of `rods`, all four by default)
//!
//! the squared error of the Gaussian's mean, the part of `-log pi(a|s)` that does not
//! involve the standard deviation ([`crate::kickstart`]'s term on other rows: those a
//! player demonstrated, not the learner's rollout). These steps read nothing of the
//! return, so the value network's gradient is zero; it shares the one Adam optimiser,
//! whose momentum still moves it a little on each of them.

use crate::config::{ConfigError, ensure};
use crate::demonstrations::{Demonstration, demonstration_rows};
use crate::kickstart::{check_rods, rod_actions};
use crate::tensors::gather_rows;
use foosball_nets::{Snapshot, SnapshotError};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// `[ppo.demonstrations]`: how the demonstrations PPO holds are cloned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DemoCloningConfig {
    /// Weight of the cloning term (`coef` above).
    pub coef: f32,
    /// Rows of each cloning step.
    pub batch_size: usize,
    /// Cloning steps after each rollout's epochs.
    pub updates: usize,
    /// The rods whose commands are cloned (0 goalie, 1 defence, 2 midfield, 3 attack; all
    /// four by default): a demonstrator whose attack is wanted, not its defence, names 2
    /// and 3.
    pub rods: Vec<usize>,
}

impl Default for DemoCloningConfig {
    fn default() -> Self {
        Self {
            coef: 1.0,
            batch_size: 256,
            updates: 16,
            rods: vec![0, 1, 2, 3],
        }
    }
}

impl DemoCloningConfig {
    /// Which of `action_dim` action values are cloned (the commands of `rods`).
    pub fn cloned_actions(&self, action_dim: usize) -> Vec<bool> {
        rod_actions(&self.rods, action_dim)
    }

    /// Rejects a negative or non-finite weight, empty steps and rods that are not the
    /// table's four, naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_rods(&self.rods)?;
        ensure(
            self.coef.is_finite() && self.coef >= 0.0,
            "coef",
            "must be finite and >= 0",
        )?;
        ensure(self.batch_size > 0, "batch_size", "must be at least 1")?;
        ensure(self.updates > 0, "updates", "must be at least 1")
    }
}

/// The demonstrated rows PPO clones: every state with the action played there.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DemoRows {
    /// States, `[rows, obs_dim]`, as the networks read them.
    obs: Vec<f32>,
    /// Actions in `[-1, 1]`, `[rows, action_dim]`.
    actions: Vec<f32>,
    obs_dim: usize,
    action_dim: usize,
    /// Where [`DemoRows::keep_newest`] writes the next row once the rows are full.
    next: usize,
}

/// One cloning step's rows: states `[n, obs_dim]` and the actions to clone `[n, action_dim]`.
pub struct DemoBatch {
    /// States.
    pub obs: Vec<f32>,
    /// Demonstrated actions.
    pub actions: Vec<f32>,
}

impl DemoRows {
    /// Every row of `episodes` (refused, naming the episode, where widths do not fit or a
    /// value is not finite).
    pub fn new(
        episodes: &[Demonstration<'_>],
        obs_dim: usize,
        action_dim: usize,
    ) -> Result<Self, String> {
        let (obs, actions) = demonstration_rows(episodes, obs_dim, action_dim)?;
        Ok(Self {
            obs,
            actions,
            obs_dim,
            action_dim,
            next: 0,
        })
    }

    /// No rows yet, for states `[obs_dim]` and actions `[action_dim]`.
    pub fn empty(obs_dim: usize, action_dim: usize) -> Self {
        Self {
            obs_dim,
            action_dim,
            ..Self::default()
        }
    }

    /// Adds the rows `obs [n, obs_dim]` with `actions [n, action_dim]`, holding the newest
    /// `keep` at most: once `keep` are held, each new row takes the place of the oldest.
    pub fn keep_newest(&mut self, obs: &[f32], actions: &[f32], keep: usize) {
        let (o, a) = (self.obs_dim, self.action_dim);
        for (s, act) in obs.chunks_exact(o).zip(actions.chunks_exact(a)) {
            if self.len() < keep {
                self.obs.extend_from_slice(s);
                self.actions.extend_from_slice(act);
            } else {
                let at = self.next % keep;
                self.obs[at * o..(at + 1) * o].copy_from_slice(s);
                self.actions[at * a..(at + 1) * a].copy_from_slice(act);
                self.next = at + 1;
            }
        }
    }

    /// Stores the rows under `prefix.*`.
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        snap.put_f32(format!("{prefix}.obs"), &self.obs[..]);
        snap.put_f32(format!("{prefix}.actions"), &self.actions[..]);
        snap.put_u64(format!("{prefix}.next"), self.next as u64);
    }

    /// The rows [`DemoRows::save_state`] stored under `prefix.*`.
    pub fn load_state(&mut self, snap: &Snapshot<'_>, prefix: &str) -> Result<(), SnapshotError> {
        self.obs = snap.f32s(&format!("{prefix}.obs"))?.to_vec();
        let values = self.len() * self.action_dim;
        self.actions = (snap.f32s_of_len(&format!("{prefix}.actions"), values))?.to_vec();
        self.next = snap.u64(&format!("{prefix}.next"))? as usize;
        Ok(())
    }

    /// Rows held.
    pub fn len(&self) -> usize {
        self.obs.len() / self.obs_dim.max(1)
    }

    /// Whether no row is held.
    pub fn is_empty(&self) -> bool {
        self.obs.is_empty()
    }

    /// `n` rows drawn uniformly with replacement.
    pub fn sample(&self, n: usize, rng: &mut ChaCha8Rng) -> DemoBatch {
        let rows: Vec<usize> = (0..n).map(|_| rng.random_range(0..self.len())).collect();
        DemoBatch {
            obs: gather_rows(&self.obs, self.obs_dim, &rows),
            actions: gather_rows(&self.actions, self.action_dim, &rows),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn every_state_is_a_row_and_a_draw_keeps_states_with_their_actions() {
        // Episode 0: states [0], [1] with actions -0, -1; episode 1 (cut): state [2].
        let first = Demonstration {
            obs: &[0.0, 1.0],
            actions: &[0.0, -1.0],
            rewards: &[1.0, 1.0],
            terminated: true,
            absorbing: false,
        };
        let cut = Demonstration {
            obs: &[2.0],
            actions: &[-2.0],
            rewards: &[0.0],
            terminated: false,
            absorbing: false,
        };
        let rows = DemoRows::new(&[first, cut], 1, 1).unwrap();
        assert_eq!(rows.len(), 3);
        let batch = rows.sample(300, &mut ChaCha8Rng::seed_from_u64(3));
        assert!(batch.obs.iter().zip(&batch.actions).all(|(s, a)| *a == -*s));
        for state in [0.0, 1.0, 2.0] {
            assert!(batch.obs.contains(&state), "state {state} never drawn");
        }
        assert!(DemoRows::default().is_empty());
    }

    /// The newest rows are kept, each new one in the oldest's place once full, and the
    /// rows come back from a snapshot as they were.
    #[test]
    fn the_newest_rows_are_kept_and_saved() {
        let mut rows = DemoRows::empty(1, 1);
        rows.keep_newest(&[0.0, 1.0, 2.0], &[0.0, -1.0, -2.0], 4);
        assert_eq!(rows.len(), 3);
        rows.keep_newest(&[3.0, 4.0, 5.0], &[-3.0, -4.0, -5.0], 4);
        assert_eq!(rows.len(), 4);
        let mut held = rows.obs.clone();
        held.sort_by(f32::total_cmp);
        assert_eq!(held, [2.0, 3.0, 4.0, 5.0]);
        assert!(rows.obs.iter().zip(&rows.actions).all(|(s, a)| *a == -*s));
        let mut snap = Snapshot::new();
        rows.save_state(&mut snap, "k");
        let mut back = DemoRows::empty(1, 1);
        back.load_state(&snap, "k").unwrap();
        assert_eq!(back, rows);
        rows.keep_newest(&[6.0], &[-6.0], 4);
        back.keep_newest(&[6.0], &[-6.0], 4);
        assert_eq!(back, rows, "a restored ring goes on as the original");
        assert!(!rows.obs.contains(&2.0));
    }

    #[test]
    fn out_of_range_settings_are_refused_by_key() {
        assert!(DemoCloningConfig::default().validate().is_ok());
        for (bad, key) in [
            (
                DemoCloningConfig {
                    coef: f32::NAN,
                    ..Default::default()
                },
                "coef",
            ),
            (
                DemoCloningConfig {
                    batch_size: 0,
                    ..Default::default()
                },
                "batch_size",
            ),
            (
                DemoCloningConfig {
                    updates: 0,
                    ..Default::default()
                },
                "updates",
            ),
            (
                DemoCloningConfig {
                    rods: vec![2, 4],
                    ..Default::default()
                },
                "rods",
            ),
        ] {
            assert!(bad.validate().unwrap_err().to_string().contains(key));
        }
    }
}
