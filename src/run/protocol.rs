//! The paper's protocol as a loop over any [`Agent`] on the table: collect (VecEnv) ->
//! store -> update; training scalars every [`LOG_EVERY`] env steps; an evaluation every
//! `eval_every` env steps (the best networks kept in `best/`); at each epoch end the
//! training envs restart, the last networks go to `last/` and a checkpoint is written;
//! then the test. What a run adds comes in as [`Hook`]s, called at fixed points of each
//! step; progress goes to a `report` callback as [`Progress`] events.

use super::checkpoint::{self, LoopState};
use super::error::TrainError;
use super::hooks::{Context, Hook, Hooks};
use super::interrupt;
use super::log::{RunLog, Speed};
use super::progress::{Event, Progress, TICK};
use crate::config::{BestBy, Checkpoint, RunConfig, TestActions};
use crate::files::RunFileError;
use crate::play::evaluation::{Episodes, play_agent, write_test};
use crate::play::metrics::TestMetrics;
use foosball_algos::{Agent, Collector};
use foosball_env::FoosballEnv;
use foosball_env::seeding::{EVAL_ENVS, TEST_ENVS, TRAIN_ENVS, derive_seed};
use foosball_nets::Snapshot;
use std::path::Path;
use std::time::Instant;

/// Env steps between rows of training scalars (metrics averaged over them).
pub const LOG_EVERY: u64 = 1_000;

/// Seeds of the training envs from the start of epoch `epoch` (0-based) on: env `i`
/// restarts from `derive_seed(seed, TRAIN_ENVS, epoch * n + i)` (epoch 0 is
/// `VecEnv::reset(seed)`).
pub fn restart_seeds(seed: u64, epoch: u64, n: usize) -> Vec<u64> {
    (0..n as u64)
        .map(|i| derive_seed(seed, TRAIN_ENVS, epoch * n as u64 + i))
        .collect()
}

/// One run going through the protocol: the learner, its training envs, its logs, its
/// hooks and where the loop stands.
pub struct Protocol<'a> {
    /// The run's settings (`protocol`, `env` for evaluations and the test).
    pub config: &'a RunConfig,
    /// The run directory.
    pub run_dir: &'a Path,
    /// The learner.
    pub agent: &'a mut dyn Agent,
    /// The training envs and their current observations.
    pub collector: Collector<FoosballEnv>,
    /// The run's logs.
    pub log: RunLog,
    /// What the run adds, called in this order.
    pub hooks: Hooks,
    /// Where the loop stands (a checkpoint's, or the start's).
    pub state: LoopState,
    /// Told of every window, evaluation, checkpoint and the test.
    pub report: &'a mut (dyn FnMut(&Progress) + Send),
}

impl Protocol<'_> {
    /// Trains from where `state` stands to the last epoch, then tests the final (or the
    /// best, `protocol.test_networks`) networks into `RUN/test/`.
    pub fn run(mut self) -> Result<TestMetrics, TrainError> {
        let clock = (
            Instant::now(),
            self.agent.env_steps(),
            self.agent.gradient_steps(),
        );
        self.tell(Event::Started);
        self.each_hook(|h, ctx| h.on_start(ctx))?;
        let mut last_tick = clock.0;
        for epoch in self.state.epoch + 1..=u64::from(self.config.protocol.epochs) {
            let end = epoch * self.config.protocol.steps_per_epoch;
            while self.agent.env_steps() < end {
                self.step(epoch, end)?;
                if last_tick.elapsed() >= TICK {
                    last_tick = Instant::now();
                    self.tick(clock);
                }
                self.log_and_evaluate()?;
                self.each_hook(|h, ctx| h.after_evaluation(ctx))?;
            }
            self.end_epoch(epoch)?;
        }
        self.test()
    }

    /// One vector step of the training envs and the agent's update; the epoch's last
    /// restarts the envs from the next epoch's seeds.
    fn step(&mut self, epoch: u64, end: u64) -> Result<(), TrainError> {
        let p = &self.config.protocol;
        let steps = self.agent.env_steps();
        let remaining = 1.0 - steps as f64 / p.total_env_steps() as f64;
        let (log, hooks) = (&mut self.log, &mut self.hooks);
        let on_episode = |i, e, info: &_| {
            log.episode(steps, e, info);
            for hook in hooks.iter_mut() {
                if let Some(m) = hook.on_episode(i, info) {
                    log.update(m);
                }
            }
        };
        let n = p.envs;
        let update = if steps + n as u64 >= end {
            let seeds = restart_seeds(p.seed, epoch, n);
            self.collector
                .step_then_restart(self.agent, remaining, &seeds, on_episode)
        } else {
            self.collector.step(self.agent, remaining, on_episode)
        }?;
        if let Some(m) = update {
            self.log.update(m);
        }
        self.each_hook(|h, ctx| h.on_step(ctx))?;
        if interrupt::requested() {
            return Err(interrupted(self.run_dir, self.agent.env_steps(), epoch - 1));
        }
        Ok(())
    }

    /// The window of training scalars and the evaluation, where due.
    fn log_and_evaluate(&mut self) -> Result<(), TrainError> {
        let steps = self.agent.env_steps();
        if steps >= self.state.next_log {
            self.state.next_log += LOG_EVERY;
            self.end_window()?;
        }
        if steps >= self.state.next_eval {
            self.state.next_eval += self.config.protocol.eval_every;
            self.evaluate()?;
        }
        Ok(())
    }

    /// Plays the evaluation episodes, logs their metrics and keeps the best networks.
    fn evaluate(&mut self) -> Result<(), TrainError> {
        let p = &self.config.protocol;
        let episodes = episodes(self.config, EVAL_ENVS, p.eval_episodes, false);
        let played = play_agent(self.agent, TestActions::Deterministic, &episodes)?;
        let m = TestMetrics::from_episodes(&played.iter().map(|e| e.summary).collect::<Vec<_>>());
        let steps = self.agent.env_steps();
        self.log.evaluation(steps, &m)?;
        let rank = best_key(p.best_by, &m);
        if rank > self.state.best {
            self.state.best = rank;
            save(self.agent, &self.run_dir.join(Checkpoint::Best.name()))?;
        }
        self.tell(Event::Evaluation {
            mean_return: m.mean_return.mean,
            score_rate: m.score_rate.mean,
        });
        Ok(())
    }

    /// The epoch's last window, the last networks, the checkpoint (the hooks' state in
    /// it), then the hooks' own files.
    fn end_epoch(&mut self, epoch: u64) -> Result<(), TrainError> {
        self.end_window()?;
        save(self.agent, &self.run_dir.join(Checkpoint::Last.name()))?;
        self.state.epoch = epoch;
        self.state.log_bytes = self.log.csv_bytes()?;
        let hooks = &self.hooks;
        let save_hooks = |snap: &mut Snapshot<'_>| hooks.iter().for_each(|h| h.save(snap));
        checkpoint::write(self.run_dir, self.agent, &self.state, save_hooks)?;
        let steps = self.agent.env_steps();
        for hook in &mut self.hooks {
            hook.on_checkpoint(steps)?;
        }
        self.tell(Event::Checkpoint(epoch));
        Ok(())
    }

    /// The test: `protocol.test_episodes` on the held-out starts, recorded.
    fn test(mut self) -> Result<TestMetrics, TrainError> {
        self.tell(Event::Test);
        let p = &self.config.protocol;
        if p.test_networks == Checkpoint::Best {
            self.agent
                .load(&self.run_dir.join(Checkpoint::Best.name()))?;
        }
        let episodes = episodes(self.config, TEST_ENVS, p.test_episodes, true);
        let played = play_agent(self.agent, p.test_actions, &episodes)?;
        Ok(write_test(&self.run_dir.join("test"), &played)?)
    }

    /// Writes the window of training scalars that ends now.
    fn end_window(&mut self) -> Result<(), TrainError> {
        let (steps, gradient_steps) = (self.agent.env_steps(), self.agent.gradient_steps());
        if let Some(speed) = self.log.end_window(steps, gradient_steps)? {
            self.tell(Event::Window(speed));
        }
        Ok(())
    }

    /// The speed since this process started training (`clock`: its start's instant, env
    /// steps and gradient steps), for progress displays only.
    fn tick(&mut self, clock: (Instant, u64, u64)) {
        let seconds = clock.0.elapsed().as_secs_f64();
        let speed = Speed {
            steps_per_second: (self.agent.env_steps() - clock.1) as f64 / seconds,
            updates_per_second: (self.agent.gradient_steps() - clock.2) as f64 / seconds,
        };
        self.tell(Event::Tick(speed));
    }

    /// Calls `f` on every hook in order, with the learner and the logs.
    fn each_hook(
        &mut self,
        mut f: impl FnMut(&mut dyn Hook, &mut Context<'_>) -> Result<(), TrainError>,
    ) -> Result<(), TrainError> {
        let mut ctx = Context {
            agent: &mut *self.agent,
            log: &mut self.log,
        };
        for hook in &mut self.hooks {
            f(hook.as_mut(), &mut ctx)?;
        }
        Ok(())
    }

    /// Reports `event` at the learner's env steps.
    fn tell(&mut self, event: Event) {
        (self.report)(&Progress {
            env_steps: self.agent.env_steps(),
            total_steps: self.config.protocol.total_env_steps(),
            event,
        });
    }
}

/// `n` episodes of the seed stream `stream` (evaluations' or the test's) on `config`'s
/// table, their steps recorded or not.
fn episodes(config: &RunConfig, stream: u64, n: u32, record: bool) -> Episodes<'_> {
    Episodes {
        env: &config.env,
        seed: config.protocol.seed,
        stream,
        n,
        record,
    }
}

/// The error of a run stopped by a signal at `env_steps`, `epochs` epochs checkpointed.
fn interrupted(run_dir: &Path, env_steps: u64, epochs: u64) -> TrainError {
    TrainError::Interrupted {
        dir: run_dir.to_path_buf(),
        env_steps,
        from: match epochs {
            0 => "the start (no epoch was checkpointed)".into(),
            k => format!("the checkpoint of epoch {k}"),
        },
    }
}

/// Writes `agent`'s networks into `dir`, made if missing.
fn save(agent: &dyn Agent, dir: &Path) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(RunFileError::at(dir))?;
    Ok(agent.save(dir)?)
}

/// An evaluation's rank under `by` (higher is better): the mean return, or the score rate
/// first and the mean return second, as `1e12 * score_rate + mean_return` (a step of the
/// score rate, at least 1e-4 for up to 10,000 episodes, outweighs any return of the
/// table: below 3e7 in magnitude).
fn best_key(by: BestBy, m: &TestMetrics) -> f64 {
    match by {
        BestBy::Return => m.mean_return.mean,
        BestBy::ScoreRate => 1e12 * m.score_rate.mean + m.mean_return.mean,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::play::metrics::EpisodeSummary;

    /// Metrics of one episode of return `ret`, scored or not.
    fn one(ret: f64, scored: bool) -> TestMetrics {
        let summary = EpisodeSummary {
            steps: 10,
            ret,
            scored,
            ..EpisodeSummary::default()
        };
        TestMetrics::from_episodes(&[summary])
    }

    #[test]
    fn the_best_evaluation_is_ranked_by_return_or_by_score_rate_first() {
        let (goal, long) = (one(9_000.0, true), one(2.5e7, false));
        assert!(best_key(BestBy::Return, &long) > best_key(BestBy::Return, &goal));
        assert!(best_key(BestBy::ScoreRate, &goal) > best_key(BestBy::ScoreRate, &long));
        let better_goal = one(9_500.0, true);
        assert!(best_key(BestBy::ScoreRate, &better_goal) > best_key(BestBy::ScoreRate, &goal));
    }
}
