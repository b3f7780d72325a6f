//! Gymnasium's `Pendulum-v1` with its exact dynamics, for validating learners.
//!
//! State (θ, θ'), θ = 0 upright. Torque u = clip(2 a, -2, 2) for an action a in [-1, 1]
//! (Gymnasium's action space is [-2, 2]; the [`Env`] contract is [-1, 1]).
//! `θ'' = 3 g / (2 l) sin θ + 3 / (m l²) u`, integrated with semi-implicit Euler at
//! dt = 0.05 s, θ' clipped to [-8, 8]; reward `-(norm(θ)² + 0.1 θ'² + 0.001 u²)` on the
//! state *before* the step; observation `[cos θ, sin θ, θ']`; truncated after 200 steps.
//! Arithmetic follows Gymnasium's (float64 state, float32 torque terms).

use rand::{Rng, SeedableRng};

use crate::EnvRng;
use crate::env::{Env, EnvError, Transition, check_action};

/// Largest |θ'|, rad/s.
pub const MAX_SPEED: f64 = 8.0;
/// Largest |u|, N m.
pub const MAX_TORQUE: f32 = 2.0;
/// Time step, s.
pub const DT: f64 = 0.05;
/// Gravity, m/s².
pub const G: f64 = 10.0;
/// Episode length (Gymnasium's TimeLimit).
pub const MAX_EPISODE_STEPS: u32 = 200;

/// Observation length: cos θ, sin θ, θ'.
pub const OBS_DIM: usize = 3;

/// The pendulum (see the module docs).
#[derive(Debug, Clone)]
pub struct Pendulum {
    theta: f64,
    theta_dot: f64,
    steps: u32,
    rng: EnvRng,
}

impl Default for Pendulum {
    fn default() -> Self {
        Self {
            theta: 0.0,
            theta_dot: 0.0,
            steps: 0,
            rng: EnvRng::seed_from_u64(0),
        }
    }
}

/// `x` wrapped into [-π, π), as Gymnasium's `angle_normalize`.
fn angle_normalize(x: f64) -> f64 {
    (x + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

impl Pendulum {
    /// A pendulum at rest upright; call [`Env::reset`] to start an episode.
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts an episode from a given state (θ rad, θ' rad/s) and returns its observation.
    pub fn reset_to(&mut self, theta: f64, theta_dot: f64) -> [f32; OBS_DIM] {
        self.theta = theta;
        self.theta_dot = theta_dot;
        self.steps = 0;
        self.observation()
    }

    fn observation(&self) -> [f32; OBS_DIM] {
        [
            self.theta.cos() as f32,
            self.theta.sin() as f32,
            self.theta_dot as f32,
        ]
    }

    /// Applies torque `u` (N m, clipped to ±2) for one step: (observation, reward,
    /// truncated).
    pub fn step_torque(&mut self, u: f32) -> ([f32; OBS_DIM], f32, bool) {
        let u = u.clamp(-MAX_TORQUE, MAX_TORQUE);
        let (th, thdot) = (self.theta, self.theta_dot);
        let cost =
            angle_normalize(th).powi(2) + 0.1 * thdot * thdot + f64::from(0.001_f32 * (u * u));
        let accel = 3.0 * G / 2.0 * th.sin() + f64::from(3.0_f32 * u);
        let new_thdot = (thdot + accel * DT).clamp(-MAX_SPEED, MAX_SPEED);
        self.theta = th + new_thdot * DT;
        self.theta_dot = new_thdot;
        self.steps += 1;
        (
            self.observation(),
            -cost as f32,
            self.steps >= MAX_EPISODE_STEPS,
        )
    }
}

impl Env for Pendulum {
    type Info = ();

    fn obs_dim(&self) -> usize {
        OBS_DIM
    }

    fn action_dim(&self) -> usize {
        1
    }

    /// θ ~ U(-π, π), θ' ~ U(-1, 1), as Gymnasium's default reset.
    fn reset_into(&mut self, seed: Option<u64>, obs: &mut [f32]) {
        if let Some(seed) = seed {
            self.rng = EnvRng::seed_from_u64(seed);
        }
        let theta = self
            .rng
            .random_range(-std::f64::consts::PI..=std::f64::consts::PI);
        let theta_dot = self.rng.random_range(-1.0..=1.0);
        obs.copy_from_slice(&self.reset_to(theta, theta_dot));
    }

    fn step_into(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Transition<()>, EnvError> {
        check_action(action, 1)?;
        if self.steps >= MAX_EPISODE_STEPS {
            return Err(EnvError::NeedsReset);
        }
        let (o, reward, truncated) = self.step_torque(action[0].clamp(-1.0, 1.0) * MAX_TORQUE);
        obs.copy_from_slice(&o);
        Ok(Transition {
            reward,
            terminated: false,
            truncated,
            info: (),
        })
    }
}
