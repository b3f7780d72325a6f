//! Black in a self-play run's training environments: an opponent drawn from the pool at
//! every reset.

use std::sync::{Arc, Mutex, PoisonError};

use foosball_env::config::ActionMap;
use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::{EnvRng, Opponent};
use rand::Rng;

use super::pool::{Member, Pool};
use crate::play::matches::PolicyOpponent;

/// Who plays the episode in progress: this environment's own copy of a fixed opponent
/// (its index in the pool, which lists the anchors and rivals first), or a snapshot's
/// shared policy.
enum Playing {
    Anchor(usize),
    Snapshot(Arc<Mutex<PolicyOpponent>>),
}

/// One environment's black: at each reset it draws two uniforms from the environment's
/// stream; the opponent they pick is settled at the episode's first step, from the pool
/// as it stands then (the loop changes the pool only between vec-env steps, so the pick
/// is the same whether the reset came from an auto-reset or a restart at a checkpoint).
pub struct PoolOpponent {
    pool: Arc<Pool>,
    env: usize,
    anchors: Vec<Box<dyn Opponent>>,
    draw: Option<(f64, f64)>,
    current: Option<Playing>,
}

impl PoolOpponent {
    /// Black of environment `env` (its index in the vec-env) drawing from `pool`, with its
    /// own copies of the pool's fixed opponents, `anchors` in the pool's order.
    pub fn new(pool: Arc<Pool>, env: usize, anchors: Vec<Box<dyn Opponent>>) -> Self {
        debug_assert_eq!(anchors.len(), pool.config().fixed_opponents());
        Self {
            pool,
            env,
            anchors,
            draw: None,
            current: None,
        }
    }

    /// Chooses the opponent of this episode if not yet done.
    fn settle(&mut self) {
        if self.current.is_none() {
            let (u, v) = self.draw.take().unwrap_or((0.0, 0.0));
            let index = self.pool.choose(u, v);
            self.pool.play(self.env, index);
            self.current = Some(match self.pool.member(index) {
                Member::Anchor(_) => Playing::Anchor(index),
                Member::Snapshot { policy, .. } => {
                    Playing::Snapshot(policy.expect("the pool draws snapshots in play only"))
                }
            });
        }
    }
}

impl Opponent for PoolOpponent {
    fn act(&mut self, obs: &[f32; OBS_DIM], rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        self.act_in(ActionMap::default(), obs, rng)
    }

    fn act_in(
        &mut self,
        map: ActionMap,
        obs: &[f32; OBS_DIM],
        rng: &mut EnvRng,
    ) -> [f32; ACTION_DIM] {
        self.settle();
        match self.current.as_ref().expect("settled above") {
            Playing::Anchor(i) => self.anchors[*i].act_in(map, obs, rng),
            Playing::Snapshot(p) => p
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .act_in(map, obs, rng),
        }
    }

    fn reset(&mut self, rng: &mut EnvRng) {
        self.pool.reset_slot(self.env);
        self.draw = Some((rng.random::<f64>(), rng.random::<f64>()));
        self.current = None;
        for a in &mut self.anchors {
            a.reset(rng);
        }
    }
}
