//! "Block": a one-step foosball sub-task for learners that see pixels.
//!
//! The ball lies just in front of yellow's goalie rod at `x ~ U(-10, 10)` cm (the rod's
//! slide range); every rod stands at neutral. The agent slides the goalie, `slide =
//! 10 * action[0]` cm, which moves his middle man to `x = slide`, and earns `-|slide -
//! x| / 10` (0 when the man meets the ball, -2 at worst); the episode ends there. The
//! observation is the table drawn top-down by [`crate::render::Renderer`] as one grey
//! `width x height` frame (`byte / 255`, see [`crate::observation`]), so a policy has to
//! read the ball's position off the picture. No physics runs.

use rand::{Rng, SeedableRng};

use crate::EnvRng;
use crate::env::{Env, EnvError, Transition, check_action};
use crate::geometry::{self, BALL_RADIUS};
use crate::layout::{BALL_POS, OBS_DIM};
use crate::observation::{FrameStack, ObservationConfig, ObservationKind};

/// The goalie's slide range, cm: the ball's x range and the action's scale.
pub const RANGE: f32 = geometry::RODS[0].slide_range;

/// The Block task (see the module docs).
#[derive(Debug, Clone)]
pub struct Block {
    picture: FrameStack,
    obs_dim: usize,
    ball_x: f32,
    rng: EnvRng,
}

impl Block {
    /// A task drawing `width x height` grey frames (each side at least 1 pixel).
    pub fn new(width: usize, height: usize) -> Self {
        let config = ObservationConfig {
            kind: ObservationKind::Image,
            width: width.max(1) as u32,
            height: height.max(1) as u32,
            grayscale: true,
            frame_stack: 1,
            hide_black_rods: false,
        };
        Self {
            picture: FrameStack::new(config),
            obs_dim: config.dim(),
            ball_x: 0.0,
            rng: EnvRng::seed_from_u64(0),
        }
    }

    /// The ball's x in the current episode, cm.
    pub fn ball_x(&self) -> f32 {
        self.ball_x
    }

    /// The table's state: every rod neutral, the ball 3 cm in front of the goalie.
    pub fn state(&self) -> [f32; OBS_DIM] {
        let mut state = [0.0; OBS_DIM];
        state[BALL_POS].copy_from_slice(&[self.ball_x, geometry::rod_y(0) + 3.0, BALL_RADIUS]);
        state
    }

    fn observe(&mut self, obs: &mut [f32]) {
        self.picture.reset(&self.state());
        self.picture.write(obs);
    }
}

impl Env for Block {
    type Info = ();

    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    fn action_dim(&self) -> usize {
        1
    }

    fn reset_into(&mut self, seed: Option<u64>, obs: &mut [f32]) {
        if let Some(seed) = seed {
            self.rng = EnvRng::seed_from_u64(seed);
        }
        self.ball_x = self.rng.random_range(-RANGE..=RANGE);
        self.observe(obs);
    }

    fn step_into(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Transition<()>, EnvError> {
        check_action(action, 1)?;
        let slide = RANGE * action[0].clamp(-1.0, 1.0);
        self.observe(obs);
        Ok(Transition {
            reward: -(slide - self.ball_x).abs() / RANGE,
            terminated: true,
            truncated: false,
            info: (),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ball_is_drawn_where_it_lies_and_meeting_it_pays_zero() {
        let mut env = Block::new(36, 36);
        assert_eq!(env.obs_dim(), 36 * 36);
        let a = env.reset(Some(1));
        let x = env.ball_x();
        assert!((-RANGE..=RANGE).contains(&x));
        // Another ball position, another picture; the same seed, the same one.
        assert_eq!(env.reset(Some(1)), a);
        assert_ne!(env.reset(Some(2)), a);
        env.reset(Some(1));
        let (_, t) = env.step(&[x / RANGE]).unwrap();
        assert!(t.reward.abs() < 1e-6 && t.terminated);
        env.reset(Some(1));
        let (_, t) = env.step(&[if x > 0.0 { -1.0 } else { 1.0 }]).unwrap();
        assert!(
            (t.reward + (RANGE + x.abs()) / RANGE).abs() < 1e-5,
            "{}",
            t.reward
        );
    }
}
