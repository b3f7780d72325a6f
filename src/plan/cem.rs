//! The cross-entropy method over open-loop plans, with the simulator itself as the model.
//!
//! A plan is `segments` actions (8 values each), each held for `segment_steps` agent steps,
//! the last one to the episode's end. A candidate's value ([`Outcome::value`]: scoring
//! soon, or the return) is that of the episode it plays from the start (`reset(seed)` and the plan, on a table of the same config), or from a
//! state along an episode ([`PlanStart`]: the reset and the actions that led there): the
//! table is deterministic given its seed and actions (the opponent and the noise included),
//! so the value of a plan is exactly what playing it earns, and the search needs no
//! snapshot of a table in motion. Each iteration:
//!
//! ```text
//! candidates = [best so far] + (population - 1) x clip(mean + std * N(0, 1), -1, 1)
//! elites     = the `elites` candidates of highest value (`objective`)
//! mean, std  = their mean and standard deviation, per value (std >= min_std)
//! ```
//!
//! stopping early when a candidate scores (`stop_when_scored`). A search started from a
//! plan (`from`) may keep, instead of the best, the scoring candidate nearest that plan
//! (`keep = "nearest"`: least `sum (candidate - from)^2` over pieces and values).

use super::config::{Keep, Objective, PlannerConfig};
use foosball_algos::EpisodeLog;
use foosball_env::layout::ACTION_DIM;
use foosball_env::{EnvError, EnvRng, FoosballConfig, FoosballEnv, FoosballInfo, Transition};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

/// One action per segment of a plan.
pub type Plan = Vec<[f32; ACTION_DIM]>;

/// What a rollout of a plan earned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Undiscounted return.
    pub ret: f64,
    /// The ball entered black's goal.
    pub scored: bool,
    /// Agent steps played.
    pub steps: u32,
    /// Agent steps until the ball first entered black's goal (those played if never).
    pub steps_to_goal: u32,
    /// The ball's closest approach to the reward's goal point, cm.
    pub closest_distance: f32,
}

impl Default for Outcome {
    fn default() -> Self {
        Self {
            ret: 0.0,
            scored: false,
            steps: 0,
            steps_to_goal: 0,
            closest_distance: f32::INFINITY,
        }
    }
}

impl Outcome {
    /// Its worth under `objective` (higher is better).
    pub fn value(&self, objective: Objective) -> f64 {
        match objective {
            Objective::Return => self.ret,
            Objective::Score if self.scored => 1e6 - f64::from(self.steps_to_goal),
            Objective::Score => -f64::from(self.closest_distance),
        }
    }
}

impl EpisodeLog<FoosballEnv> for Outcome {
    fn record(&mut self, _: &[f32], t: &Transition<FoosballInfo>) {
        self.ret += f64::from(t.reward);
        self.steps += 1;
        if !self.scored {
            self.steps_to_goal = self.steps;
        }
        self.scored |= t.info.scored();
        self.closest_distance = self.closest_distance.min(t.info.goal_distance);
    }
}

/// The plan a search found for one episode and what it cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Search {
    /// The best plan found.
    pub plan: Plan,
    /// What it earns in the search's rollouts (capped at `max_rollout_steps`).
    pub outcome: Outcome,
    /// Rollouts played.
    pub rollouts: u32,
    /// Agent steps simulated over all rollouts.
    pub simulated_steps: u64,
}

/// Where a plan takes over: the episode reset from `seed`, then `prefix`'s actions played
/// (one row per agent step, in `[-1, 1]`; none: the episode's start). The table being
/// deterministic given its seed and actions, this reaches any state of an episode that
/// was played from `seed`, exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanStart<'a> {
    /// The episode's reset seed.
    pub seed: u64,
    /// The actions played before the plan.
    pub prefix: &'a [[f32; ACTION_DIM]],
}

impl PlanStart<'static> {
    /// The start of the episode reset from `seed`.
    pub fn reset(seed: u64) -> Self {
        Self { seed, prefix: &[] }
    }
}

/// Plays `plan` on `env` from `start`, `segment_steps` agent steps per action and the last
/// action to the end, logging each step of the plan (not the prefix's) into `log`; stops
/// at the episode's end or after `max_steps` agent steps of the plan. An episode that
/// ends within the prefix logs nothing.
pub fn follow<L: EpisodeLog<FoosballEnv>>(
    env: &mut FoosballEnv,
    start: PlanStart<'_>,
    plan: &[[f32; ACTION_DIM]],
    segment_steps: usize,
    max_steps: Option<u32>,
    log: &mut L,
) -> Result<(), EnvError> {
    if reach(env, start)? {
        follow_on(env, plan, segment_steps, max_steps, log)?;
    }
    Ok(())
}

/// Resets `env` from `start.seed` and plays `start.prefix`; false when the episode ended
/// within it.
fn reach(env: &mut FoosballEnv, start: PlanStart<'_>) -> Result<bool, EnvError> {
    use foosball_env::Env;
    let mut obs = vec![0.0; env.obs_dim()];
    env.reset_into(Some(start.seed), &mut obs);
    for action in start.prefix {
        if env.step_into(action, &mut obs)?.done() {
            return Ok(false);
        }
    }
    Ok(true)
}

/// [`follow`] from where `env` stands (an episode in progress).
fn follow_on<L: EpisodeLog<FoosballEnv>>(
    env: &mut FoosballEnv,
    plan: &[[f32; ACTION_DIM]],
    segment_steps: usize,
    max_steps: Option<u32>,
    log: &mut L,
) -> Result<(), EnvError> {
    use foosball_env::Env;
    let mut obs = vec![0.0; env.obs_dim()];
    for t in 0.. {
        if max_steps.is_some_and(|m| t >= m) {
            break;
        }
        let action = &plan[(t as usize / segment_steps).min(plan.len() - 1)];
        log.before_step(env);
        let transition = env.step_into(action, &mut obs)?;
        log.record(action, &transition);
        if transition.done() {
            break;
        }
    }
    Ok(())
}

/// Searches a plan for the episode of `env`'s config from `start` (its reset, or a state
/// along it); the search's own draws come from `search_seed`, so the same call finds the
/// same plan. It starts from `from` (a mean plan and its spread, e.g. a shared plan to
/// refine, or what a learner played from there) or, by default, from mean 0 and spread
/// `initial_std`.
pub fn search(
    env: &mut FoosballEnv,
    start: PlanStart<'_>,
    search_seed: u64,
    config: &PlannerConfig,
    from: Option<(&Plan, f32)>,
) -> Result<Search, EnvError> {
    let c = config;
    let mut rng = EnvRng::seed_from_u64(search_seed);
    let near = from
        .map(|(plan, _)| plan)
        .filter(|_| c.keep == Keep::Nearest);
    let (mut mean, mut std) = match from {
        Some((plan, spread)) => (plan.clone(), vec![[spread; ACTION_DIM]; plan.len()]),
        None => initial(c),
    };
    let mut rollouts = 0;
    let mut simulated_steps = 0;
    // From a state along an episode, each rollout starts on a snapshot of it rather than
    // replaying the episode's first steps (the same rollouts, to the bit: tested).
    let snapshot = match start.prefix {
        [] => None,
        _ if reach(env, start)? => env.snapshot(),
        _ => None,
    };
    let mut rollout = |plan: &Plan| -> Result<Outcome, EnvError> {
        let mut outcome = Outcome::default();
        let cap = Some(c.max_rollout_steps);
        match snapshot.as_ref().and_then(FoosballEnv::snapshot) {
            Some(mut table) => follow_on(&mut table, plan, c.segment_steps, cap, &mut outcome)?,
            None => follow(env, start, plan, c.segment_steps, cap, &mut outcome)?,
        }
        rollouts += 1;
        simulated_steps += u64::from(outcome.steps);
        Ok(outcome)
    };
    let mut best = Search {
        outcome: rollout(&mean)?,
        plan: mean.clone(),
        rollouts: 0,
        simulated_steps: 0,
    };
    for _ in 0..c.iterations {
        if c.stop_when_scored && best.outcome.scored {
            break;
        }
        let mut scored: Vec<(Outcome, Plan)> = vec![(best.outcome, best.plan.clone())];
        for _ in 1..c.population {
            let plan = sample_plan(&mean, &std, &mut rng);
            scored.push((rollout(&plan)?, plan));
        }
        // Highest value first; ties keep the earlier candidate (the best so far first).
        let worth = |o: &Outcome| o.value(c.objective);
        scored.sort_by(|a, b| worth(&b.0).total_cmp(&worth(&a.0)));
        let elites: Vec<&Plan> = scored[..c.elites].iter().map(|(_, p)| p).collect();
        refit(&elites, c.min_std, &mut mean, &mut std);
        let kept = near
            .and_then(|from| nearest_scoring(&scored, from))
            .unwrap_or(0);
        let (outcome, plan) = &scored[kept];
        best.outcome = *outcome;
        best.plan.clone_from(plan);
    }
    best.rollouts = rollouts;
    best.simulated_steps = simulated_steps;
    Ok(best)
}

/// Index of the scoring candidate nearest `from` (least sum of squared differences; the
/// first of equals), `None` where none scores.
fn nearest_scoring(candidates: &[(Outcome, Plan)], from: &Plan) -> Option<usize> {
    let distance = |plan: &Plan| -> f32 {
        plan.iter()
            .zip(from)
            .flat_map(|(p, f)| p.iter().zip(f).map(|(p, f)| (p - f).powi(2)))
            .sum()
    };
    (candidates.iter().enumerate())
        .filter(|(_, (outcome, _))| outcome.scored)
        .map(|(k, (_, plan))| (k, distance(plan)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// The first iteration's sampling: mean 0, spread `initial_std`, per segment and value.
fn initial(c: &PlannerConfig) -> (Plan, Plan) {
    (
        vec![[0.0; ACTION_DIM]; c.segments],
        vec![[c.initial_std; ACTION_DIM]; c.segments],
    )
}

/// A candidate `clip(mean + std * N(0, 1), -1, 1)`.
fn sample_plan(mean: &Plan, std: &Plan, rng: &mut EnvRng) -> Plan {
    mean.iter()
        .zip(std)
        .map(|(m, s)| {
            core::array::from_fn(|i| {
                let z: f32 = rng.sample(StandardNormal);
                (m[i] + s[i] * z).clamp(-1.0, 1.0)
            })
        })
        .collect()
}

/// Refits `mean` and `std` (at least `min_std`) to the `elites`, per segment and value.
fn refit(elites: &[&Plan], min_std: f32, mean: &mut Plan, std: &mut Plan) {
    let n = elites.len() as f32;
    for k in 0..mean.len() {
        for i in 0..ACTION_DIM {
            let m = elites.iter().map(|p| p[k][i]).sum::<f32>() / n;
            let var = elites.iter().map(|p| (p[k][i] - m).powi(2)).sum::<f32>() / n;
            mean[k][i] = m;
            std[k][i] = var.sqrt().max(min_std);
        }
    }
}

/// One plan for many starts, and what it earned on them.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedSearch {
    /// The best plan found.
    pub plan: Plan,
    /// Share of the search's starts on which it scores.
    pub score_rate: f64,
    /// Rollouts played (candidates times starts).
    pub rollouts: u64,
    /// Agent steps simulated over all rollouts.
    pub simulated_steps: u64,
}

/// Searches one open-loop plan for all of `starts` (reset seeds of `env`): a candidate is
/// worth the mean of its [`Outcome::value`]s over the starts, so with the `score`
/// objective the plan that scores from the most starts, then sooner. Candidates are
/// played in parallel (rayon), each on a table of its own thread; the result does not
/// depend on the thread count. The search's draws come from `search_seed`;
/// `stop_when_scored` stops once a candidate scores from every start.
pub fn search_shared(
    env: &FoosballConfig,
    starts: &[u64],
    search_seed: u64,
    config: &PlannerConfig,
) -> Result<SharedSearch, String> {
    use rayon::prelude::*;
    let c = config;
    let mut rng = EnvRng::seed_from_u64(search_seed);
    let (mut mean, mut std) = initial(c);
    let evaluate = |plans: &[Plan]| -> Result<Vec<(f64, f64, u64)>, String> {
        plans
            .par_iter()
            .map_init(
                || FoosballEnv::new(env.clone()),
                |table, plan| {
                    let table = table.as_mut().map_err(|e| e.to_string())?;
                    let (mut value, mut goals, mut steps) = (0.0, 0.0, 0);
                    for &seed in starts {
                        let mut outcome = Outcome::default();
                        let cap = Some(c.max_rollout_steps);
                        follow(
                            table,
                            PlanStart::reset(seed),
                            plan,
                            c.segment_steps,
                            cap,
                            &mut outcome,
                        )
                        .map_err(|e| e.to_string())?;
                        value += outcome.value(c.objective);
                        goals += f64::from(u8::from(outcome.scored));
                        steps += u64::from(outcome.steps);
                    }
                    let n = starts.len() as f64;
                    Ok((value / n, goals / n, steps))
                },
            )
            .collect()
    };
    let mut best = (mean.clone(), evaluate(std::slice::from_ref(&mean))?[0]);
    let (mut rollouts, mut simulated_steps) = (starts.len() as u64, best.1.2);
    for _ in 0..c.iterations {
        if c.stop_when_scored && best.1.1 == 1.0 {
            break;
        }
        let mut plans = vec![best.0.clone()];
        plans.extend((1..c.population).map(|_| sample_plan(&mean, &std, &mut rng)));
        let worth = evaluate(&plans)?;
        rollouts += (plans.len() * starts.len()) as u64;
        simulated_steps += worth.iter().map(|w| w.2).sum::<u64>();
        let mut order: Vec<usize> = (0..plans.len()).collect();
        // Highest value first; ties keep the earlier candidate (the best so far first).
        order.sort_by(|&a, &b| worth[b].0.total_cmp(&worth[a].0));
        let elites: Vec<&Plan> = order[..c.elites].iter().map(|&k| &plans[k]).collect();
        refit(&elites, c.min_std, &mut mean, &mut std);
        best = (plans[order[0]].clone(), worth[order[0]]);
    }
    Ok(SharedSearch {
        plan: best.0,
        score_rate: best.1.1,
        rollouts,
        simulated_steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearest_scoring_candidate_is_kept_and_misses_are_passed_over() {
        let plan = |x: f32| -> Plan { vec![[x; ACTION_DIM]; 3] };
        let outcome = |scored| Outcome {
            scored,
            ..Outcome::default()
        };
        let from = plan(0.1);
        // By value first: a far goal, a miss right on `from`, a nearer goal, a nearer one.
        let candidates = vec![
            (outcome(true), plan(0.9)),
            (outcome(false), plan(0.1)),
            (outcome(true), plan(-0.4)),
            (outcome(true), plan(0.3)),
        ];
        assert_eq!(nearest_scoring(&candidates, &from), Some(3));
        let misses = vec![(outcome(false), plan(0.1)), (outcome(false), plan(0.2))];
        assert_eq!(nearest_scoring(&misses, &from), None);
    }
}
