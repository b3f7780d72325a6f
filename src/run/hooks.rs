//! Hooks: what a run adds to the protocol's loop ([`super::protocol`]), in the manner of
//! Stable-Baselines3's callbacks. The loop calls every hook at the same points, in the
//! order of its list; a hook that keeps state across a resume writes it into the epoch's
//! checkpoint ([`Hook::save`]) and reads it back where it is built.
//!
//! The capabilities of a run configuration live in their own files and plug in here:
//! self-play's pool ([`crate::self_play::SelfPlay`]: snapshots of the learner, records of
//! its training games), the planner as an interactive teacher ([`super::dagger::Dagger`]:
//! rounds of labels), a curriculum on success ([`super::curriculum::SuccessSchedule`]: how
//! far back the teacher's episodes begin). Wrappers do the rest: drills are the training
//! envs' ([`foosball_env::FoosballEnv::with_drills`]), a kickstart teacher the collector's
//! ([`super::kickstart`]), demonstrations the agent's ([`super::demonstrations`]).

use super::curriculum::SuccessSchedule;
use super::dagger::Dagger;
use super::error::TrainError;
use super::log::RunLog;
use crate::self_play::SelfPlay;
use foosball_algos::{Agent, Metrics};
use foosball_env::FoosballInfo;
use foosball_nets::Snapshot;

/// A run's hooks, in the order the loop calls them.
pub type Hooks = Vec<Box<dyn Hook>>;

/// What a hook may use when the loop calls it.
pub struct Context<'a> {
    /// The learner (its env steps say where the run stands).
    pub agent: &'a mut dyn Agent,
    /// The run's logs: metrics given to [`RunLog::update`] join the current window of
    /// training scalars.
    pub log: &'a mut RunLog,
}

/// A capability plugged into the protocol's loop. Every method has a default that does
/// nothing, so a hook writes only the points it needs.
pub trait Hook {
    /// Once before the first vector step (a resumed run's too), after the training envs
    /// have started.
    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        let _ = ctx;
        Ok(())
    }

    /// A training episode of env `env` ended (`info` of its last step); metrics returned
    /// are logged in the current window.
    fn on_episode(&mut self, env: usize, info: &FoosballInfo) -> Option<Metrics> {
        let _ = (env, info);
        None
    }

    /// After each vector step and the agent's update, before the loop's own logging and
    /// evaluation at that step.
    fn on_step(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        let _ = ctx;
        Ok(())
    }

    /// After each vector step's logging and evaluation (whether one was due or not).
    fn after_evaluation(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        let _ = ctx;
        Ok(())
    }

    /// Adds the hook's state to the checkpoint written at an epoch's end.
    fn save(&self, snap: &mut Snapshot<'_>) {
        let _ = snap;
    }

    /// After the checkpoint of an epoch was written, at `env_steps`.
    fn on_checkpoint(&mut self, env_steps: u64) -> Result<(), TrainError> {
        let _ = env_steps;
        Ok(())
    }
}

/// Self-play: a snapshot of the learner when one is due (and at the start), every
/// training game recorded against the opponent that played it, the records written at
/// each checkpoint.
impl Hook for SelfPlay {
    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        self.on_step(ctx)
    }

    fn on_episode(&mut self, env: usize, info: &FoosballInfo) -> Option<Metrics> {
        SelfPlay::on_episode(self, env, info);
        None
    }

    fn on_step(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        Ok(self.after_step(ctx.agent.env_steps(), ctx.agent)?)
    }

    fn save(&self, snap: &mut Snapshot<'_>) {
        self.state().save(snap);
    }

    fn on_checkpoint(&mut self, env_steps: u64) -> Result<(), TrainError> {
        Ok(self.write_records(env_steps)?)
    }
}

/// DAgger: the files and labels handed to the learner at the start, a round of the
/// planner's labels every `dagger.every` env steps (its metrics logged).
impl Hook for Dagger {
    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        self.hand(ctx.agent).map_err(TrainError::Init)?;
        Ok(())
    }

    fn after_evaluation(&mut self, ctx: &mut Context<'_>) -> Result<(), TrainError> {
        if ctx.agent.env_steps() >= self.next_round_at() {
            let round = self.round(ctx.agent).map_err(TrainError::Init)?;
            ctx.log.update(round.metrics(self.label_rows()));
        }
        Ok(())
    }

    fn save(&self, snap: &mut Snapshot<'_>) {
        self.state().save(snap);
    }
}

/// A curriculum on success: each episode begun on the teacher's counts towards moving
/// the starts back (its row of scalars logged).
impl Hook for SuccessSchedule {
    fn on_episode(&mut self, _env: usize, info: &FoosballInfo) -> Option<Metrics> {
        SuccessSchedule::on_episode(self, info)
    }

    fn save(&self, snap: &mut Snapshot<'_>) {
        self.state().save(snap);
    }
}
