//! The planner's test episodes: a plan searched for each episode ([`crate::plan`]), or one
//! plan for all (`shared_starts`), then played on a fresh table from the same seed as any
//! policy's test episode, and what the searches cost (`planner.json` beside the test
//! metrics).

use super::evaluation::{PlayError, PlayedEpisode, foosball_envs};
use crate::files::{RunFileError, write_atomic};
use crate::plan::{Plan, PlanStart, PlannerConfig, follow, search, search_shared};
use foosball_env::FoosballConfig;
use foosball_env::seeding::{PLANNER, derive_seed};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
use std::time::Instant;

/// What the searches of a test cost, and whether their plans replayed as predicted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanCost {
    /// The search budget.
    pub planner: PlannerConfig,
    /// Episodes planned.
    pub episodes: u32,
    /// Mean rollouts (candidate plans played) per episode.
    pub rollouts_per_episode: f64,
    /// Mean agent steps simulated by the search per episode.
    pub simulated_steps_per_episode: f64,
    /// Agent steps simulated per agent step played (the planner's decisions are its
    /// plans: one per episode, so this is the cost of each step it plays).
    pub simulated_steps_per_played_step: f64,
    /// Episodes whose played return equals the search's prediction (all of those that
    /// ended within `max_rollout_steps`, the table being deterministic; 0 for a shared
    /// plan, searched on other starts).
    pub replayed_exactly: u32,
    /// Episodes that ended within `max_rollout_steps` (those that can replay exactly; 0
    /// for a shared plan).
    pub within_rollout_cap: u32,
    /// Wall time of searching and playing all episodes, s.
    pub wall_s: f64,
    /// Threads that shared the episodes.
    pub threads: usize,
    /// The one plan of `shared_starts`, absent for per-episode plans.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shared: Option<SharedPlan>,
}

/// The plan searched once for `shared_starts` starts and played on every episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SharedPlan {
    /// Share of the search's own starts it scores from.
    pub search_score_rate: f64,
    /// Its actions, one per segment (`[segments][8]`, each held `segment_steps`).
    pub plan: Plan,
}

/// Plans and plays one episode from each of `seeds`, in seed order, the episodes shared
/// among rayon's threads (the same episodes whatever their number); a progress bar on a
/// terminal's stderr counts the episodes and the goals. With `shared_starts`, one plan
/// is searched first on starts `derive_seed(seed, PLANNER, k)` (`seed` the one the test
/// seeds derive from) and played on every episode, or with `refine_std` refined for each.
pub fn play_planned(
    env: &FoosballConfig,
    planner: &PlannerConfig,
    (seed, seeds): (u64, &[u64]),
    record: bool,
) -> Result<(Vec<PlayedEpisode>, PlanCost), PlayError> {
    planner.validate().map_err(PlayError::Env)?;
    let start = Instant::now();
    let shared = match planner.shared_starts {
        0 => None,
        n => {
            let starts: Vec<u64> = (0..n as u64)
                .map(|k| derive_seed(seed, PLANNER, k))
                .collect();
            let search_seed = derive_seed(seed, PLANNER, u64::MAX);
            Some(search_shared(env, &starts, search_seed, planner).map_err(PlayError::Env)?)
        }
    };
    // A shared plan plays unchanged (no search per episode) unless `refine_std` is set.
    let unchanged = shared.as_ref().filter(|_| planner.refine_std.is_none());
    let refine = shared
        .as_ref()
        .zip(planner.refine_std)
        .map(|(found, spread)| (&found.plan, spread));
    let bar = ProgressBar::new(seeds.len() as u64).with_style(
        ProgressStyle::with_template("planner {pos}/{len} episodes, {per_sec}, ETA {eta} {msg}")
            .expect("valid template"),
    );
    let goals = AtomicU32::new(0);
    let played: Vec<_> = seeds
        .par_iter()
        .map_init(
            || foosball_envs(env, 1).map(|mut v| v.remove(0)),
            |table, &seed| {
                let table = table.as_mut().map_err(|e| PlayError::Env(e.to_string()))?;
                let found = match unchanged {
                    Some(_) => None,
                    None => {
                        let search_seed = derive_seed(seed, PLANNER, 0);
                        Some(search(
                            table,
                            PlanStart::reset(seed),
                            search_seed,
                            planner,
                            refine,
                        )?)
                    }
                };
                let plan = (found.as_ref().map(|f| &f.plan))
                    .or(unchanged.map(|one| &one.plan))
                    .expect("an episode searches its plan or plays the shared one");
                let mut episode = PlayedEpisode::new(seed, record);
                let start = PlanStart::reset(seed);
                follow(
                    table,
                    start,
                    plan,
                    planner.segment_steps,
                    None,
                    &mut episode,
                )?;
                let scored = goals.fetch_add(u32::from(episode.summary.scored), Relaxed);
                bar.set_message(format!(
                    "({} scored)",
                    scored + u32::from(episode.summary.scored)
                ));
                bar.inc(1);
                Ok((episode, found))
            },
        )
        .collect::<Result<_, PlayError>>()?;
    bar.finish_and_clear();
    let n = played.len().max(1) as f64;
    let steps: u64 = played.iter().map(|(e, _)| e.summary.steps).sum();
    let (shared_rollouts, shared_steps) = shared
        .as_ref()
        .map_or((0, 0), |f| (f.rollouts, f.simulated_steps));
    // Episodes searched for themselves: those whose play can match their search.
    let searched = played
        .iter()
        .filter_map(|(e, s)| s.as_ref().map(|s| (e, s)));
    let simulated = shared_steps
        + searched
            .clone()
            .map(|(_, s)| s.simulated_steps)
            .sum::<u64>();
    let within = searched
        .clone()
        .filter(|(e, _)| e.summary.steps <= u64::from(planner.max_rollout_steps));
    let cost = PlanCost {
        planner: planner.clone(),
        episodes: played.len() as u32,
        rollouts_per_episode: (shared_rollouts as f64
            + searched.map(|(_, s)| f64::from(s.rollouts)).sum::<f64>())
            / n,
        simulated_steps_per_episode: simulated as f64 / n,
        simulated_steps_per_played_step: simulated as f64 / steps.max(1) as f64,
        replayed_exactly: within
            .clone()
            .filter(|(e, s)| e.summary.ret == s.outcome.ret && e.summary.scored == s.outcome.scored)
            .count() as u32,
        within_rollout_cap: within.count() as u32,
        wall_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
        shared: shared.map(|f| SharedPlan {
            search_score_rate: f.score_rate,
            plan: f.plan,
        }),
    };
    Ok((played.into_iter().map(|(e, _)| e).collect(), cost))
}

impl PlanCost {
    /// Writes `dir/planner.json`.
    pub fn write(&self, dir: &Path) -> Result<(), RunFileError> {
        let json = serde_json::to_string_pretty(self).expect("a plan cost serialises");
        write_atomic(&dir.join("planner.json"), json.as_bytes())
    }
}
