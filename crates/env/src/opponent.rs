//! Who plays black. An [`Opponent`] sees the table from black's side
//! ([`crate::layout::mirror_observation`]) and answers with an action in black's own
//! frame, so a policy trained as yellow can be plugged in unchanged (self-play).

use rand::Rng;

use crate::EnvRng;
use crate::config::ActionMap;
use crate::geometry::RODS;
use crate::layout::{ACTION_DIM, BALL_POS, OBS_DIM, action_slide, action_turn};

/// A controller for black's four rods.
pub trait Opponent: Send {
    /// Black's action (8 values in [-1, 1], layout as yellow's) for black's view `obs`.
    /// `rng` is the environment's own stream, so random opponents stay reproducible.
    fn act(&mut self, obs: &[f32; OBS_DIM], rng: &mut EnvRng) -> [f32; ACTION_DIM];

    /// Called at every environment reset, after the start has been drawn from `rng` (the
    /// environment's own stream): an opponent that picks who plays the episode draws here.
    fn reset(&mut self, _rng: &mut EnvRng) {}

    /// A copy in its current state, for a snapshot of the table it plays on
    /// ([`crate::FoosballEnv::snapshot`]); `None` (the default) where it cannot be copied.
    fn fork(&self) -> Option<Box<dyn Opponent>> {
        None
    }

    /// Its actions are written for the linear map (a fraction of each joint's range), as
    /// hand-written controllers are: the env translates them into its own `action_map`
    /// ([`crate::config::ActionMap::from_linear`]). False (the default): they are in the
    /// env's own action space, as a random or a learned policy's.
    fn linear_actions(&self) -> bool {
        false
    }

    /// [`Opponent::act`] written in `map`'s terms: translated from the linear map where
    /// [`Opponent::linear_actions`] says so.
    fn act_in(
        &mut self,
        map: ActionMap,
        obs: &[f32; OBS_DIM],
        rng: &mut EnvRng,
    ) -> [f32; ACTION_DIM] {
        let action = self.act(obs, rng);
        if self.linear_actions() {
            map.from_linear(action)
        } else {
            action
        }
    }
}

/// Holds every rod at neutral: feet down, centred (the paper's opponent).
#[derive(Debug, Clone, Copy, Default)]
pub struct StaticOpponent;

impl Opponent for StaticOpponent {
    fn fork(&self) -> Option<Box<dyn Opponent>> {
        Some(Box::new(*self))
    }

    fn act(&mut self, _obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        [0.0; ACTION_DIM]
    }
}

/// Draws every command uniformly from [-1, 1] each step.
#[derive(Debug, Clone, Copy, Default)]
pub struct RandomOpponent;

impl Opponent for RandomOpponent {
    fn fork(&self) -> Option<Box<dyn Opponent>> {
        Some(Box::new(*self))
    }

    fn act(&mut self, _obs: &[f32; OBS_DIM], rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        core::array::from_fn(|_| rng.random_range(-1.0..=1.0))
    }
}

/// Keeps every foot down and slides each rod so that the man best placed to reach the
/// ball's x stands in its path: a goalkeeper-style blocker.
#[derive(Debug, Clone, Copy, Default)]
pub struct ScriptedOpponent;

impl ScriptedOpponent {
    /// Slide command in [-1, 1] that puts a man of `rod` (0..4) at `ball_x` (cm, in the
    /// rod's own frame), or as near as the rod's range allows.
    pub fn tracking_slide(rod: usize, ball_x: f32) -> f32 {
        man_at(rod, ball_x).0 / RODS[rod].slide_range
    }
}

impl Opponent for ScriptedOpponent {
    fn fork(&self) -> Option<Box<dyn Opponent>> {
        Some(Box::new(*self))
    }

    fn linear_actions(&self) -> bool {
        true
    }

    fn act(&mut self, obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        let mut action = [0.0; ACTION_DIM];
        for rod in 0..4 {
            action[action_slide(rod)] = Self::tracking_slide(rod, obs[BALL_POS.start]);
            action[action_turn(rod)] = 0.0;
        }
        action
    }
}

/// The slide (cm, within the rod's range) that puts the nearest man of `rod` (0..4) at
/// `x` (cm, in the rod's own frame), and how far (cm) he stays from it; of equally near
/// men, the one needing the smaller slide.
pub fn man_at(rod: usize, x: f32) -> (f32, f32) {
    let spec = &RODS[rod];
    spec.men_x
        .iter()
        .map(|&m| {
            let s = (x - m).clamp(-spec.slide_range, spec.slide_range);
            (s, (m + s - x).abs())
        })
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.abs().total_cmp(&b.0.abs())))
        .unwrap_or((0.0, f32::INFINITY))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracking_puts_a_man_on_the_ball() {
        // Goalie men at -20.676, 0, 20.676 with +-10 of slide: any |x| <= 30.676 is reachable.
        for x in [-25.0_f32, -8.0, 0.0, 3.0, 14.0, 30.0] {
            let s = ScriptedOpponent::tracking_slide(0, x) * RODS[0].slide_range;
            let miss = RODS[0]
                .men_x
                .iter()
                .map(|m| (m + s - x).abs())
                .fold(f32::INFINITY, f32::min);
            assert!(miss < 1e-4, "x = {x}: slide {s} misses by {miss}");
        }
        // Out of reach: the outermost man goes as far as he can.
        let s = ScriptedOpponent::tracking_slide(0, 33.0);
        assert_eq!(s, 1.0);
    }

    #[test]
    fn man_at_reaches_every_x_the_rod_covers() {
        let (s, miss) = man_at(3, 5.0);
        assert!(miss < 1e-5 && (s - 5.0).abs() < 1e-5, "{s} {miss}");
        // Midfield's outer man stands at 23.95: 6.05 of its 7 cm of slide reach x = 30.
        let (s, miss) = man_at(2, 30.0);
        assert!((s - 6.05).abs() < 1e-4 && miss < 1e-4, "{s} {miss}");
        // Beyond the range the nearest man goes as far as he can.
        let (s, miss) = man_at(2, 33.0);
        assert!(s == 7.0 && (miss - 2.05).abs() < 1e-4, "{s} {miss}");
    }
}
