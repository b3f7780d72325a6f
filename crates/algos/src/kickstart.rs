//! Kickstarting (Schmitt et al., "Kickstarting Deep Reinforcement Learning", 2018) beside
//! PPO (`[ppo.kickstart]`): a teacher labels every state of the learner's own rollouts
//! with its action, and each PPO minibatch step adds a cloning term on the policy's means
//!
//! ```text
//! L_ks  = coef(p) / n * sum_rows sum_(j in J) (mu_j(s) - a*_j(s))^2
//! dL/dmu_j = 2 coef(p) / n * (mu_j - a*_j)   (j in J; 0 elsewhere)
//! coef(p) = coef_end + (coef_start - coef_end) * p     (p: progress remaining, 1 -> 0)
//! ```
//!
//! `a*(s)` is the teacher's action in the env's action space, `n` the minibatch's rows,
//! `J` the slide and turn commands of the rods in `rods` (all four by default: a teacher
//! of the goalie and the defence alone leaves the midfield and the attack to the return).
//! The states are the learner's own, as in DAgger (Ross et al. 2011): the teacher says
//! what to do after the learner's own errors, not only along its own episodes. With the
//! coefficient falling to 0 the learner starts as the teacher's clone and is left to the
//! return alone by the end.
//!
//! Departures from the paper: its teachers are trained networks and its term the
//! cross-entropy between the teacher's and the learner's action distributions; ours are
//! deterministic controllers (the scripted kickers), so the term is the squared error of
//! the Gaussian's mean, the part of `-log pi(a*|s)` that does not involve the standard
//! deviation (the exploration stays PPO's own). Who labels is the run's business (the
//! training loop hands the labels in [`crate::Experience::teacher`]).
//!
//! With `keep` > 0 the labelled rows also join DAgger's aggregate (Ross et al. 2011),
//! the newest `keep` of them, and after each rollout's epochs `updates` steps of the same
//! term on `ppo.batch_size` rows drawn uniformly from it (logged as
//! `train/kickstart_aggregate_loss` and `_rows`): each step then sees states of many
//! rollouts, not of the last one alone.

use crate::config::{ConfigError, ensure};
use foosball_env::layout::{action_slide, action_turn};
use serde::{Deserialize, Serialize};

/// `[ppo.kickstart]`: off unless a `teacher` is named.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KickstartConfig {
    /// Who labels the learner's states (`None`: off): a built-in player (`shooter`,
    /// `dribbler`, `blocker`, `zero`) or a trained state policy, a run directory
    /// `DIR[@best|@last]` (issue 92: a state teacher for a pixel learner). The run turns
    /// the name into a labeller. It reads each state as the env hands it to a state
    /// learner (black's rods hidden where `env.observation` hides them); where the learner
    /// sees pictures, the state each picture was drawn from.
    pub teacher: Option<String>,
    /// Weight of the cloning term at the start of training.
    pub coef_start: f32,
    /// Weight at the end (linear in env steps between the two).
    pub coef_end: f32,
    /// The rods whose commands are cloned (0 goalie, 1 defence, 2 midfield, 3 attack).
    pub rods: Vec<usize>,
    /// Labelled rows kept as DAgger's aggregate, the newest first to stay (0: none, the
    /// rollout's labels alone). The aggregate goes into the checkpoint.
    pub keep: usize,
    /// Cloning steps on rows drawn from the aggregate after each rollout's epochs.
    pub updates: usize,
}

impl Default for KickstartConfig {
    fn default() -> Self {
        Self {
            teacher: None,
            coef_start: 1.0,
            coef_end: 0.0,
            rods: vec![0, 1, 2, 3],
            keep: 0,
            updates: 32,
        }
    }
}

impl KickstartConfig {
    /// Whether a teacher labels the rollouts.
    pub fn enabled(&self) -> bool {
        self.teacher.is_some()
    }

    /// The term's weight at `progress_remaining` (1 at the start, 0 at the end).
    pub fn coef_at(&self, progress_remaining: f64) -> f32 {
        let p = progress_remaining.clamp(0.0, 1.0) as f32;
        self.coef_end + (self.coef_start - self.coef_end) * p
    }

    /// Which of `action_dim` action values are cloned (the commands of `rods`).
    pub fn cloned_actions(&self, action_dim: usize) -> Vec<bool> {
        rod_actions(&self.rods, action_dim)
    }

    /// Rejects a negative or non-finite weight and rods that are not the table's four,
    /// naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_rods(&self.rods)?;
        ensure(
            self.keep == 0 || self.updates > 0,
            "updates",
            "must be at least 1 where rows are kept",
        )?;
        for (key, value) in [("coef_start", self.coef_start), ("coef_end", self.coef_end)] {
            ensure(
                value.is_finite() && value >= 0.0,
                key,
                "must be finite and >= 0",
            )?;
        }
        Ok(())
    }
}

/// Which of `action_dim` action values command the rods `rods` (0 goalie ... 3 attack):
/// their slides and turns.
pub fn rod_actions(rods: &[usize], action_dim: usize) -> Vec<bool> {
    let commands: Vec<usize> = (rods.iter())
        .flat_map(|&r| [action_slide(r), action_turn(r)])
        .collect();
    (0..action_dim).map(|j| commands.contains(&j)).collect()
}

/// Rejects an empty list of rods and rods that are not the table's four (or named
/// twice), under the key `rods`.
pub fn check_rods(rods: &[usize]) -> Result<(), ConfigError> {
    ensure(!rods.is_empty(), "rods", "name at least one rod (0-3)")?;
    for (i, &r) in rods.iter().enumerate() {
        ensure(
            r < 4 && !rods[..i].contains(&r),
            "rods",
            &format!("{r}: each of the rods 0 (goalie) to 3 (attack) at most once"),
        )?;
    }
    Ok(())
}

/// The cloning term of `means` towards the teacher's `labels` (both `[batch,
/// action_dim]`, `batch` rows) on the action values `cloned` marks (`[action_dim]`) with
/// weight `coef`, and its gradient with respect to the means:
/// `L = coef / batch * sum (mu - a*)^2`, `dL/dmu = 2 coef / batch * (mu - a*)` on the
/// cloned values, 0 on the others.
pub fn cloning_loss(
    means: &[f32],
    labels: &[f32],
    cloned: &[bool],
    batch: usize,
    coef: f32,
) -> (f32, Vec<f32>) {
    assert_eq!(means.len(), labels.len(), "one label per mean");
    let per_row = coef / batch as f32;
    let error: Vec<f32> = (means.iter().zip(labels).enumerate())
        .map(|(k, (m, a))| if cloned[k % cloned.len()] { m - a } else { 0.0 })
        .collect();
    let loss = per_row * error.iter().map(|e| e * e).sum::<f32>();
    (loss, error.iter().map(|e| 2.0 * per_row * e).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn squares(e: &[f32]) -> f32 {
        e.iter().map(|e| e * e).sum()
    }

    #[test]
    fn the_gradient_is_the_loss_s_slope() {
        let means = [0.3, -0.8, 1.4, 0.0, -0.2, 0.9];
        let labels = [1.0, -1.0, 0.5, 0.25, -0.2, 0.0];
        let all = [true, true];
        let (loss, grad) = cloning_loss(&means, &labels, &all, 3, 2.0);
        let error: Vec<f32> = means.iter().zip(&labels).map(|(m, a)| m - a).collect();
        assert!((loss - 2.0 / 3.0 * squares(&error)).abs() < 1e-6);
        for j in 0..means.len() {
            let h = 1e-3;
            let (mut up, mut down) = (means, means);
            up[j] += h;
            down[j] -= h;
            let slope = (cloning_loss(&up, &labels, &all, 3, 2.0).0
                - cloning_loss(&down, &labels, &all, 3, 2.0).0)
                / (2.0 * h);
            assert!(
                (slope - grad[j]).abs() < 1e-3,
                "{j}: {slope} vs {}",
                grad[j]
            );
        }
        assert_eq!(grad[4], 0.0, "a mean on its label feels no pull");
        // The second action value left out: no loss and no pull on it.
        let (loss, grad) = cloning_loss(&means, &labels, &[true, false], 3, 2.0);
        let kept = [error[0], error[2], error[4]];
        assert!((loss - 2.0 / 3.0 * squares(&kept)).abs() < 1e-6, "{loss}");
        assert_eq!([grad[1], grad[3], grad[5]], [0.0; 3]);
    }

    #[test]
    fn the_rods_named_are_the_actions_cloned() {
        let c = KickstartConfig {
            rods: vec![0, 1],
            ..KickstartConfig::default()
        };
        let cloned = c.cloned_actions(8);
        assert_eq!(cloned, [true, true, true, true, false, false, false, false]);
        assert!(
            KickstartConfig::default()
                .cloned_actions(8)
                .iter()
                .all(|&c| c)
        );
        for rods in [vec![], vec![4], vec![1, 1]] {
            let bad = KickstartConfig {
                rods,
                ..KickstartConfig::default()
            };
            assert!(bad.validate().unwrap_err().to_string().contains("rods"));
        }
    }

    #[test]
    fn the_weight_falls_from_start_to_end() {
        let c = KickstartConfig {
            teacher: Some("shooter".into()),
            coef_start: 4.0,
            coef_end: 1.0,
            ..KickstartConfig::default()
        };
        assert_eq!(c.coef_at(1.0), 4.0);
        assert_eq!(c.coef_at(0.0), 1.0);
        assert_eq!(c.coef_at(0.5), 2.5);
        assert!(!KickstartConfig::default().enabled());
        let bad = KickstartConfig {
            coef_end: -1.0,
            ..c
        };
        assert!(bad.validate().unwrap_err().to_string().contains("coef_end"));
    }
}
