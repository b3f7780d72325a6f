//! Issue 49's interactive teacher (`[dagger]`; Ross, Gordon and Bagnell's DAgger, 2011):
//! the planner labels states the learner itself reaches, so that cloning teaches what to
//! do after the learner's own small errors, not only along the planner's episodes.
//!
//! Every `every` env steps of training a round runs: the learner plays `episodes`
//! episodes of its own (networks only, deterministic or sampled actions), from starts of
//! stream [`DAGGER`]; in each, one step `t` is drawn uniformly and the planner searches
//! (the round's searches side by side on rayon's threads, each on a table of its own)
//! from the state reached there ([`PlanStart`]: the episode's seed and the learner's first
//! `t` actions: the table is deterministic, so the state is the learner's exactly), its
//! first sampling centred on what the learner played from `t` on. Where a plan scores,
//! the states from `t` on with the planner's actions and rewards (as the run's agent
//! observes them) join the aggregate, which with the files of `protocol.demonstrations`
//! is handed to the agent as its demonstrations after every round that adds to it. The
//! aggregate is part of the checkpoint ([`DaggerState`]), so a resumed run goes on with
//! the same demonstrations and the same rounds.

use super::demonstrations::{DemoEpisode, as_observed, file_demonstrations};
use crate::config::{DaggerConfig, RunConfig};
use crate::plan::{Plan, PlanStart, follow, search};
use crate::play::evaluation::{Episodes, play_agent};
use crate::play::trajectories::Trajectory;
use foosball_algos::{Agent, Demonstration, EpisodeLog, Metrics};
use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::seeding::{DAGGER, derive_seed};
use foosball_env::{FoosballEnv, FoosballInfo, StepInfo, Transition};
use foosball_nets::{Snapshot, SnapshotError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The teacher of a run with `[dagger]`: the demonstrations of the run's files and the
/// labels aggregated so far.
pub struct Dagger {
    config: DaggerConfig,
    run: RunConfig,
    files: Vec<DemoEpisode>,
    state: DaggerState,
}

/// One query of a round: the learner's episode it starts from (its seed and actions)
/// and the step drawn.
struct Query {
    seed: u64,
    actions: Vec<[f32; ACTION_DIM]>,
    at: usize,
    search_seed: u64,
}

/// What one query found: the agent steps its search simulated and, where a plan
/// scored, the labelled episode.
type Answer = (u64, Option<DemoEpisode>);

/// What a checkpoint keeps of the teacher: the rounds played and every label.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DaggerState {
    /// Rounds played.
    pub rounds: u64,
    /// The planner's labelled episodes, in the order they were found.
    pub labels: Vec<DemoEpisode>,
}

impl DaggerState {
    /// Stores the state under `dagger.*`.
    pub fn save(&self, snap: &mut Snapshot<'_>) {
        let cat = |f: fn(&DemoEpisode) -> &[f32]| -> Vec<f32> {
            self.labels
                .iter()
                .flat_map(|l| f(l).iter().copied())
                .collect()
        };
        snap.put_u64("dagger.rounds", self.rounds);
        snap.put_u64s(
            "dagger.steps",
            self.labels
                .iter()
                .map(|l| l.rewards.len() as u64)
                .collect::<Vec<_>>(),
        );
        snap.put_f32("dagger.obs", cat(|l| &l.obs));
        snap.put_f32("dagger.actions", cat(|l| &l.actions));
        snap.put_f32("dagger.rewards", cat(|l| &l.rewards));
        let flags =
            |f: fn(&DemoEpisode) -> bool| -> Vec<bool> { self.labels.iter().map(f).collect() };
        snap.put_bools("dagger.terminated", &flags(|l| l.terminated));
        snap.put_bools("dagger.absorbing", &flags(|l| l.absorbing));
    }

    /// The state [`DaggerState::save`] stored, `None` when the snapshot holds none (a run
    /// without `[dagger]`).
    pub fn load(snap: &Snapshot<'_>) -> Result<Option<Self>, SnapshotError> {
        if !snap.contains("dagger.rounds") {
            return Ok(None);
        }
        let steps = snap.u64s("dagger.steps")?;
        let (n, rows) = (steps.len(), steps.iter().sum::<u64>() as usize);
        let obs = snap.f32s_of_len("dagger.obs", rows * OBS_DIM)?;
        let actions = snap.f32s_of_len("dagger.actions", rows * ACTION_DIM)?;
        let rewards = snap.f32s_of_len("dagger.rewards", rows)?;
        let terminated = snap.bools_of_len("dagger.terminated", n)?;
        let absorbing = snap.bools_of_len("dagger.absorbing", n)?;
        let mut at = 0;
        let labels = steps
            .iter()
            .zip(terminated.iter().zip(&absorbing))
            .map(|(&n, (&terminated, &absorbing))| {
                let rows = at..at + n as usize;
                at += n as usize;
                DemoEpisode {
                    obs: obs[rows.start * OBS_DIM..rows.end * OBS_DIM].to_vec(),
                    actions: actions[rows.start * ACTION_DIM..rows.end * ACTION_DIM].to_vec(),
                    rewards: rewards[rows].to_vec(),
                    terminated,
                    absorbing,
                }
            })
            .collect();
        Ok(Some(Self {
            rounds: snap.u64("dagger.rounds")?,
            labels,
        }))
    }
}

/// What one round did (the `train/dagger_*` training scalars).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Round {
    /// States queried (one per learner episode).
    pub queries: u32,
    /// Queries whose search found a goal (each a new labelled episode).
    pub labelled: u32,
    /// Labelled rows added.
    pub rows: usize,
    /// Agent steps the learner's episodes took.
    pub learner_steps: u64,
    /// Agent steps the searches simulated after the queried states.
    pub simulated_steps: u64,
}

impl Round {
    /// As training scalars, with the aggregate's size.
    pub fn metrics(&self, aggregate_rows: usize) -> Metrics {
        Metrics(vec![
            ("dagger_queries", f64::from(self.queries).into()),
            (
                "dagger_labelled_share",
                (f64::from(self.labelled) / f64::from(self.queries.max(1))).into(),
            ),
            ("dagger_rows_added", (self.rows as f64).into()),
            ("dagger_aggregate_rows", (aggregate_rows as f64).into()),
            ("dagger_learner_steps", (self.learner_steps as f64).into()),
            (
                "dagger_simulated_steps",
                (self.simulated_steps as f64).into(),
            ),
        ])
    }
}

/// Records a labelled episode: the table's states, the plan's actions and rewards, and
/// how it ended.
#[derive(Default)]
struct Label {
    steps: Trajectory,
    terminated: bool,
    absorbing: bool,
}

impl EpisodeLog<FoosballEnv> for Label {
    fn before_step(&mut self, env: &FoosballEnv) {
        self.steps
            .obs
            .extend_from_slice(env.state().expect("a table in an episode"));
    }

    fn record(&mut self, action: &[f32], t: &Transition<FoosballInfo>) {
        self.steps.actions.extend_from_slice(action);
        self.steps.rewards.push(t.reward);
        self.terminated = t.terminated;
        self.absorbing = t.terminated && t.info.absorbing();
    }
}

impl Dagger {
    /// The teacher of `config` (`None` without `[dagger]`), from a checkpoint's `state`
    /// or from scratch. The files of `protocol.demonstrations` are read again here (a
    /// refusal names the key and the file).
    pub fn start(config: &RunConfig, state: Option<DaggerState>) -> Result<Option<Self>, String> {
        let Some(c) = &config.dagger else {
            return Ok(None);
        };
        Ok(Some(Self {
            config: c.clone(),
            run: config.clone(),
            files: file_demonstrations(config)?,
            state: state.unwrap_or_default(),
        }))
    }

    /// Env step of training at which the next round is due.
    pub fn next_round_at(&self) -> u64 {
        (self.state.rounds + 1) * self.config.every
    }

    /// What a checkpoint keeps.
    pub fn state(&self) -> &DaggerState {
        &self.state
    }

    /// Rows of the aggregate's labels.
    pub fn label_rows(&self) -> usize {
        self.state.labels.iter().map(|l| l.rewards.len()).sum()
    }

    /// Hands `agent` the run's files and every label as its demonstrations (nothing while
    /// both are empty) and returns the transitions it kept.
    pub fn hand(&self, agent: &mut dyn Agent) -> Result<usize, String> {
        let all: Vec<Demonstration<'_>> = self
            .files
            .iter()
            .chain(&self.state.labels)
            .map(DemoEpisode::view)
            .collect();
        if all.is_empty() {
            return Ok(0);
        }
        agent
            .set_demonstrations(&all)
            .map_err(|why| format!("dagger: {why}"))
    }

    /// Plays one round with `agent`'s networks (see the module's documentation), adds
    /// what it labelled to the aggregate and hands it to `agent`.
    pub fn round(&mut self, agent: &mut dyn Agent) -> Result<Round, String> {
        let c = &self.config;
        let seed = derive_seed(self.run.protocol.seed, DAGGER, self.state.rounds);
        let episodes = Episodes {
            env: &self.run.env,
            seed,
            stream: DAGGER,
            n: c.episodes,
            record: true,
        };
        let played = play_agent(agent, c.actions, &episodes).map_err(|e| e.to_string())?;
        // The steps are drawn in episode order; the searches then run side by side
        // (rayon), each on a table of its own, their answers kept in episode order: the
        // labels are the same whatever the thread count.
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut round = Round::default();
        let queries: Vec<Query> = (played.iter().enumerate())
            .map(|(k, episode)| {
                let steps = episode.trajectory.as_ref().expect("recorded episodes");
                let actions: Vec<[f32; ACTION_DIM]> = (steps.actions.chunks_exact(ACTION_DIM))
                    .map(|a| a.try_into().expect("a full row"))
                    .collect();
                round.learner_steps += actions.len() as u64;
                Query {
                    seed: episode.seed,
                    at: rng.random_range(0..actions.len()),
                    actions,
                    search_seed: derive_seed(seed, DAGGER, k as u64 + 1),
                }
            })
            .collect();
        let answers: Vec<Result<Answer, String>> = (queries.par_iter())
            .map_init(
                || FoosballEnv::new(self.run.env.clone()).map_err(|e| format!("env.{e}")),
                |table, q| match table {
                    Ok(table) => answer(table, &self.run, c, q),
                    Err(e) => Err(e.clone()),
                },
            )
            .collect();
        for answer in answers {
            let (simulated, label) = answer?;
            round.queries += 1;
            round.simulated_steps += simulated;
            if let Some(label) = label {
                round.labelled += 1;
                round.rows += label.rewards.len();
                self.state.labels.push(label);
            }
        }
        self.state.rounds += 1;
        if round.labelled > 0 {
            self.hand(agent)?;
        }
        Ok(round)
    }
}

/// The planner's answer to query `q` on `table` (a table of `run`'s game): it searches
/// from the queried step, its first sampling centred on what the learner played from
/// there; where a plan scores, the states from that step on with the plan's actions and
/// rewards, as the run's agent observes them.
fn answer(
    table: &mut FoosballEnv,
    run: &RunConfig,
    c: &DaggerConfig,
    q: &Query,
) -> Result<Answer, String> {
    let start = PlanStart {
        seed: q.seed,
        prefix: &q.actions[..q.at],
    };
    let warm = centred_on(
        &q.actions[q.at..],
        c.planner.segments,
        c.planner.segment_steps,
    );
    let from = Some((&warm, c.planner.initial_std));
    let found = search(table, start, q.search_seed, &c.planner, from)
        .map_err(|e| format!("dagger: {e}"))?;
    if !found.outcome.scored {
        return Ok((found.simulated_steps, None));
    }
    let mut label = Label::default();
    let cap = Some(c.planner.max_rollout_steps);
    follow(
        table,
        start,
        &found.plan,
        c.planner.segment_steps,
        cap,
        &mut label,
    )
    .map_err(|e| format!("dagger: {e}"))?;
    let episode = DemoEpisode {
        obs: as_observed(run, &label.steps.obs),
        actions: label.steps.actions,
        rewards: label.steps.rewards,
        terminated: label.terminated,
        absorbing: label.absorbing,
    };
    Ok((found.simulated_steps, Some(episode)))
}

/// A plan of `segments` pieces of `segment_steps` steps centred on `played` (the
/// learner's actions from the queried step on): each piece the action played at its
/// first step, the last action played where the episode ended sooner.
fn centred_on(played: &[[f32; ACTION_DIM]], segments: usize, segment_steps: usize) -> Plan {
    (0..segments)
        .map(|k| played[(k * segment_steps).min(played.len() - 1)])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_sampling_is_centred_on_the_learners_actions_held_past_its_end() {
        let played: Vec<[f32; ACTION_DIM]> = (0..7).map(|i| [i as f32; ACTION_DIM]).collect();
        let plan = centred_on(&played, 4, 3);
        let firsts: Vec<f32> = plan.iter().map(|a| a[0]).collect();
        assert_eq!(firsts, [0.0, 3.0, 6.0, 6.0]);
    }

    #[test]
    fn the_state_survives_a_snapshot_and_a_torn_one_is_refused() {
        let label = |n: usize, x: f32| DemoEpisode {
            obs: vec![x; n * OBS_DIM],
            actions: vec![-x; n * ACTION_DIM],
            rewards: vec![x; n],
            terminated: n.is_multiple_of(2),
            absorbing: n == 2,
        };
        let state = DaggerState {
            rounds: 7,
            labels: vec![label(2, 0.5), label(3, -0.25)],
        };
        let mut snap = Snapshot::new();
        state.save(&mut snap);
        assert_eq!(DaggerState::load(&snap).unwrap(), Some(state));
        assert_eq!(DaggerState::load(&Snapshot::new()).unwrap(), None);
        let mut torn = Snapshot::new();
        DaggerState {
            rounds: 1,
            labels: vec![label(2, 1.0)],
        }
        .save(&mut torn);
        torn.put_u64s("dagger.steps", vec![5]);
        assert!(DaggerState::load(&torn).is_err());
    }
}
