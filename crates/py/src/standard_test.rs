//! The paper's standard test from Python: a policy's episodes from the test seeds of a
//! run seed (`derive_seed(seed, TEST_ENVS, k)`), [`EVAL_BATCH`] tables side by side and
//! refilled in seed order exactly as the framework's `evaluate` plays them, each episode
//! summed and the five metrics with their intervals computed by the same code
//! ([`foosball_env::test_metrics`]): the same policy and seed give the same numbers.

use std::path::PathBuf;

use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::seeding::{TEST_ENVS, derive_seed};
use foosball_env::test_metrics::{EVAL_BATCH, EpisodeSummary, TestMetrics};
use foosball_env::{Env, FoosballEnv, ObservationKind};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{ConfigError, env_error, guarded};
use crate::settings;

/// One table's episode in progress.
struct Slot {
    index: usize,
    obs: Vec<f32>,
    summary: EpisodeSummary,
}

/// Plays `episodes` test episodes of `policy` (called on float32 arrays `[n, 38]`,
/// answering float32 arrays `[n, 8]`) on the table of `preset`, `config` and `overrides`,
/// from the test seeds of `seed`; returns the metrics as JSON (what `evaluate` writes to
/// `metrics.json`). A policy's exception is raised as it is; an answer of another shape
/// raises `ValueError`, a non-finite action `ActionError`.
#[pyfunction]
#[pyo3(signature = (policy, episodes=1000, seed=0, preset=None, config=None, overrides=None))]
pub fn standard_test(
    policy: &Bound<'_, PyAny>,
    episodes: u32,
    seed: u64,
    preset: Option<&str>,
    config: Option<PathBuf>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let py = policy.py();
    let config = guarded(|| settings::resolve(preset, config.as_deref(), overrides))?;
    if config.observation.kind != ObservationKind::State {
        return Err(ConfigError::new_err(
            "observation.kind: the standard test hands a policy the 38 state values",
        ));
    }
    if episodes == 0 {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "episodes must be positive",
        ));
    }
    let seeds: Vec<u64> = (0..u64::from(episodes))
        .map(|k| derive_seed(seed, TEST_ENVS, k))
        .collect();
    let mut envs = (0..EVAL_BATCH.min(seeds.len()))
        .map(|_| FoosballEnv::new(config.clone()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| ConfigError::new_err(e.to_string()))?;
    let start = |env: &mut FoosballEnv, index: usize| Slot {
        index,
        obs: env.reset(Some(seeds[index])),
        summary: EpisodeSummary::default(),
    };
    let mut next = 0;
    let mut slots: Vec<Option<Slot>> = Vec::with_capacity(envs.len());
    for env in &mut envs {
        slots.push(Some(start(env, next)));
        next += 1;
    }
    let mut done: Vec<Option<EpisodeSummary>> = vec![None; seeds.len()];
    while slots.iter().any(Option::is_some) {
        let batch: Vec<f32> = slots
            .iter()
            .flatten()
            .flat_map(|s| s.obs.iter().copied())
            .collect();
        let rows = batch.len() / OBS_DIM;
        let obs = PyArray1::from_vec(py, batch).reshape([rows, OBS_DIM])?;
        let answer = policy.call1((obs,))?;
        let actions: PyReadonlyArray2<'_, f32> = answer.extract().map_err(|_| {
            pyo3::exceptions::PyValueError::new_err(
                "the policy must answer a float32 array of shape (n, 8)",
            )
        })?;
        if actions.shape() != [rows, ACTION_DIM] {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "the policy answered shape {:?} for {rows} observations; expected ({rows}, {ACTION_DIM})",
                actions.shape()
            )));
        }
        let actions = actions.as_array();
        let mut live = 0;
        for (env, slot) in envs.iter_mut().zip(slots.iter_mut()) {
            let Some(s) = slot.as_mut() else { continue };
            let action: Vec<f32> = actions.row(live).to_vec();
            live += 1;
            let (obs, t) = env.step(&action).map_err(|e| env_error(&e))?;
            s.summary.add(t.reward, &t.info);
            s.obs = obs;
            if t.done() {
                let s = slot.take().expect("live slot");
                done[s.index] = Some(s.summary);
                if next < seeds.len() {
                    *slot = Some(start(env, next));
                    next += 1;
                }
            }
        }
    }
    let summaries: Vec<EpisodeSummary> = done.into_iter().flatten().collect();
    let metrics = TestMetrics::from_episodes(&summaries);
    serde_json::to_string_pretty(&metrics)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
}
