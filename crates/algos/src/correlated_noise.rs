//! Exploration noise correlated over an episode's steps: a first-order autoregressive
//! (AR(1), discrete Ornstein-Uhlenbeck) process with unit stationary variance,
//!
//! `x_0 = e_0`, `x_t = rho x_(t-1) + sqrt(1 - rho^2) e_t`, `e_t ~ N(0, 1)` i.i.d.,
//!
//! per env and action dimension, restarted at every episode's first step. Each `x_t` is
//! still a standard normal, so a policy that adds `std * x_t` to its mean keeps its
//! per-step density (PPO's log-probabilities are unchanged); what changes is that a
//! deviation lasts about `1 / (1 - rho)` steps instead of one. With 2 ms agent steps the
//! rods' servos filter white noise out; a held deviation moves a rod (gSDE's argument,
//! Raffin et al. 2021; colored noise, Eberhard et al. 2023). `rho = 0` is white noise:
//! the fresh draws pass through unchanged.

use foosball_nets::{Snapshot, SnapshotError};

/// The process's state: the last value per env and action dimension.
#[derive(Clone, Debug, Default)]
pub struct CorrelatedNoise {
    rho: f32,
    state: Vec<f32>,
}

impl CorrelatedNoise {
    /// A process with step correlation `rho` in `[0, 1)`.
    pub fn new(rho: f32) -> Self {
        Self {
            rho,
            state: Vec::new(),
        }
    }

    /// The next values, `[n_envs, action_dim]` like `fresh` (the step's standard normal
    /// draws): env `i` restarts from its fresh draw where `starts[i]` is non-zero (its
    /// episode's first step), or when the env count changed.
    pub fn next(&mut self, fresh: Vec<f32>, starts: &[f32]) -> Vec<f32> {
        if self.rho == 0.0 {
            return fresh;
        }
        let n = starts.len().max(1);
        let width = fresh.len() / n;
        if self.state.len() != fresh.len() {
            self.state = fresh;
            return self.state.clone();
        }
        let keep = (1.0 - self.rho * self.rho).sqrt();
        for (i, (x, e)) in self.state.iter_mut().zip(fresh).enumerate() {
            let start = starts.get(i / width).is_some_and(|&s| s != 0.0);
            *x = if start { e } else { self.rho * *x + keep * e };
        }
        self.state.clone()
    }

    /// Puts the state under `name` (nothing for white noise, which has none).
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, name: &str) {
        if self.rho != 0.0 {
            snap.put_f32(name, &self.state[..]);
        }
    }

    /// Reads the state back from `name`; white noise reads nothing.
    pub fn load_state(&mut self, snap: &Snapshot<'_>, name: &str) -> Result<(), SnapshotError> {
        if self.rho != 0.0 {
            self.state = snap.f32s(name)?.to_vec();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensors::standard_normal;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn white_noise_passes_the_draws_through() {
        let mut w = CorrelatedNoise::new(0.0);
        assert_eq!(w.next(vec![0.5, -1.0], &[0.0]), vec![0.5, -1.0]);
        assert_eq!(w.next(vec![2.0, 3.0], &[0.0]), vec![2.0, 3.0]);
    }

    #[test]
    fn the_process_follows_its_recursion_and_restarts_with_the_episode() {
        let rho = 0.8f32;
        let keep = (1.0 - rho * rho).sqrt();
        let mut c = CorrelatedNoise::new(rho);
        // Two envs, one action each.
        assert_eq!(c.next(vec![1.0, -2.0], &[1.0, 1.0]), vec![1.0, -2.0]);
        let x = c.next(vec![0.5, 0.5], &[0.0, 1.0]);
        assert!((x[0] - (rho + keep * 0.5)).abs() < 1e-6, "{x:?}");
        assert_eq!(x[1], 0.5, "env 1 began an episode");
    }

    #[test]
    fn each_value_is_a_standard_normal_and_neighbours_correlate_by_rho() {
        let rho = 0.9f32;
        let mut c = CorrelatedNoise::new(rho);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let xs: Vec<f32> = (0..200_000)
            .map(|_| c.next(standard_normal(1, 1, &mut rng), &[0.0])[0])
            .collect();
        let n = xs.len() as f32;
        let mean = xs.iter().sum::<f32>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / n;
        let lag1 = xs
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f32>()
            / (n - 1.0);
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!((var - 1.0).abs() < 0.05, "variance {var}");
        assert!(
            (lag1 / var - rho).abs() < 0.01,
            "lag-1 correlation {}",
            lag1 / var
        );
    }

    #[test]
    fn the_state_goes_through_a_snapshot() {
        let mut c = CorrelatedNoise::new(0.5);
        c.next(vec![1.0, 2.0], &[1.0]);
        let mut snap = Snapshot::new();
        c.save_state(&mut snap, "noise");
        let mut back = CorrelatedNoise::new(0.5);
        back.load_state(&snap, "noise").unwrap();
        assert_eq!(
            back.next(vec![0.0, 0.0], &[0.0]),
            c.next(vec![0.0, 0.0], &[0.0])
        );
        // White noise keeps nothing and reads nothing.
        let none = CorrelatedNoise::new(0.0);
        let mut white = Snapshot::new();
        none.save_state(&mut white, "noise");
        assert!(!white.contains("noise"));
        CorrelatedNoise::new(0.0)
            .load_state(&white, "noise")
            .unwrap();
    }
}
