//! The Gymnasium-style environment interface the learners see.

/// Why a step was refused. The environment is left exactly as it was.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EnvError {
    /// The action has the wrong length.
    #[error("action has {got} values, expected {expected}")]
    ActionDim { expected: usize, got: usize },
    /// An action value is NaN or infinite.
    #[error("action[{index}] is not finite ({value})")]
    NonFiniteAction { index: usize, value: f32 },
    /// `step` was called before `reset`, or after the episode ended.
    #[error("the episode is over (or never started): call reset first")]
    NeedsReset,
    /// A reset option is out of its range (the environment is left as it was).
    #[error("reset option `{key}`: {reason}")]
    ResetOption { key: &'static str, reason: String },
}

/// What one step returns besides the observation.
#[derive(Debug, Clone, PartialEq)]
pub struct Transition<I> {
    /// Reward for this step.
    pub reward: f32,
    /// The episode reached a terminal state (no bootstrapping past it).
    pub terminated: bool,
    /// The episode was cut short (time limit, physics fault): bootstrap from the final
    /// observation.
    pub truncated: bool,
    /// Environment-specific details.
    pub info: I,
}

impl<I> Transition<I> {
    /// The episode is over, either way.
    pub fn done(&self) -> bool {
        self.terminated || self.truncated
    }
}

/// What an environment's per-step details say to a learner.
pub trait StepInfo {
    /// The step reached an absorbing state: one that, left alone, pays this step's reward
    /// at every later step (foosball: the ball lying in a goal). Read only on a
    /// terminated step; learners may value such an end as that reward forever
    /// (`off_policy.absorbing_ends`). Default: no state is absorbing.
    fn absorbing(&self) -> bool {
        false
    }
}

impl StepInfo for () {}

/// A reinforcement-learning environment with flat `f32` observations and actions.
///
/// Observations are written into caller-owned slices of length [`Env::obs_dim`] so that
/// batched callers can avoid allocation; [`Env::reset`] and [`Env::step`] are the
/// allocating conveniences.
pub trait Env: Send {
    /// Per-step details (e.g. goals scored); `Default` is the value after a reset.
    type Info: StepInfo + Clone + Default + Send + Sync + core::fmt::Debug;

    /// Length of an observation.
    fn obs_dim(&self) -> usize;

    /// Length of an action; every action value lies in [-1, 1] (larger values are clipped).
    fn action_dim(&self) -> usize;

    /// Starts a new episode and writes its first observation into `obs`. With a seed the
    /// environment's RNG is re-seeded first (so the episode depends on the seed alone);
    /// without one it continues its current random stream.
    fn reset_into(&mut self, seed: Option<u64>, obs: &mut [f32]);

    /// Applies `action` for one agent step and writes the next observation into `obs`.
    /// A refused action ([`EnvError`]) leaves the environment and `obs` unchanged.
    fn step_into(
        &mut self,
        action: &[f32],
        obs: &mut [f32],
    ) -> Result<Transition<Self::Info>, EnvError>;

    /// What a privileged teacher reads of the observation last written, where that
    /// differs from the observation itself (issue 92: the 38-value state behind an image
    /// observation, in the env's ball frame); `None`, the default, where the observation
    /// is what a teacher reads.
    fn teacher_view(&self) -> Option<&[f32]> {
        None
    }

    /// [`Env::reset_into`] returning a fresh vector.
    fn reset(&mut self, seed: Option<u64>) -> Vec<f32> {
        let mut obs = vec![0.0; self.obs_dim()];
        self.reset_into(seed, &mut obs);
        obs
    }

    /// [`Env::step_into`] returning a fresh observation vector.
    fn step(&mut self, action: &[f32]) -> Result<(Vec<f32>, Transition<Self::Info>), EnvError> {
        let mut obs = vec![0.0; self.obs_dim()];
        let t = self.step_into(action, &mut obs)?;
        Ok((obs, t))
    }
}

/// Checks an action's length and finiteness.
pub fn check_action(action: &[f32], expected: usize) -> Result<(), EnvError> {
    if action.len() != expected {
        return Err(EnvError::ActionDim {
            expected,
            got: action.len(),
        });
    }
    match action.iter().position(|a| !a.is_finite()) {
        Some(index) => Err(EnvError::NonFiniteAction {
            index,
            value: action[index],
        }),
        None => Ok(()),
    }
}
