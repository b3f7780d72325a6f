//! [`VecTable`]: N tables stepped in parallel by [`VecEnv`] with the GIL released
//! (`foosball_rl.FoosballVectorEnv` wraps it).
//!
//! Auto-reset is the Rust VecEnv's, Gymnasium's `SAME_STEP` mode: an env whose episode
//! ends on a step is reset within that step, its observation is the next episode's
//! first, and its last observation comes back as `final_obs`.

use std::path::PathBuf;
use std::sync::Mutex;

use foosball_env::layout::ACTION_DIM;
use foosball_env::{FoosballEnv, FoosballInfo, VecEnv};
use numpy::{PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::episode::{EpisodeStats, EpisodeTally};
use crate::errors::{ActionError, ConfigError, ResetNeeded, guarded, vec_env_error};
use crate::settings;
use crate::to_python::{array, frame_array, obs_shape, renderer};

/// One batched step's results, owned so that they can be filled with the GIL released.
#[derive(Default)]
struct Batch {
    obs: Vec<f32>,
    final_obs: Vec<f32>,
    rewards: Vec<f32>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    infos: Vec<FoosballInfo>,
    ended: Vec<Option<EpisodeStats>>,
}

/// N tables of one configuration; env `i` is seeded `derive_seed(seed, TRAIN_ENVS, i)`
/// as in a training run of the Rust framework.
#[pyclass(module = "foosball_rl._core")]
pub struct VecTable {
    /// In a mutex only to make the class `Sync`; stepping holds `&mut self` and reaches
    /// it without locking.
    vec: Mutex<VecEnv<FoosballEnv>>,
    shape: Vec<usize>,
    threads: usize,
    tallies: Vec<EpisodeTally>,
    batch: Batch,
}

#[pymethods]
impl VecTable {
    /// `num_envs` tables configured as `Table(preset, config, overrides)`, stepped on
    /// `threads` worker threads (default: one per core, at most one per table).
    #[new]
    #[pyo3(signature = (num_envs, threads=None, preset=None, config=None, overrides=None))]
    fn new(
        num_envs: usize,
        threads: Option<usize>,
        preset: Option<&str>,
        config: Option<PathBuf>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        guarded(|| {
            if num_envs == 0 {
                return Err(ConfigError::new_err("num_envs must be at least 1"));
            }
            let config = settings::resolve(preset, config.as_deref(), overrides)?;
            let shape = obs_shape(&config);
            let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            let threads = threads.unwrap_or(cores.min(num_envs));
            let envs = (0..num_envs)
                .map(|_| FoosballEnv::new(config.clone()))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| ConfigError::new_err(e.to_string()))?;
            let vec = VecEnv::new(envs, threads).map_err(|e| vec_env_error(&e))?;
            let od = vec.obs_dim();
            Ok(Self {
                vec: Mutex::new(vec),
                shape,
                threads,
                tallies: vec![EpisodeTally::default(); num_envs],
                batch: Batch {
                    obs: vec![0.0; num_envs * od],
                    final_obs: vec![0.0; num_envs * od],
                    rewards: vec![0.0; num_envs],
                    terminated: vec![false; num_envs],
                    truncated: vec![false; num_envs],
                    infos: vec![FoosballInfo::default(); num_envs],
                    ended: vec![None; num_envs],
                },
            })
        })
    }

    /// Number of tables.
    #[getter]
    fn num_envs(&self) -> usize {
        self.tallies.len()
    }

    /// Worker threads stepping them.
    #[getter]
    fn threads(&self) -> usize {
        self.threads
    }

    /// The shape of one table's observation.
    #[getter]
    fn obs_shape(&self) -> Vec<usize> {
        self.shape.clone()
    }

    /// The tables' configuration, every value pinned, as TOML.
    #[getter]
    fn config_toml(&self) -> PyResult<String> {
        let vec = self.vec.lock().unwrap_or_else(|p| p.into_inner());
        toml::to_string(vec.envs()[0].config())
            .map_err(|e| ConfigError::new_err(format!("config does not serialise: {e}")))
    }

    /// Starts an episode on every table: with a seed, table `i` restarts from
    /// `derive_seed(seed, TRAIN_ENVS, i)`; without, each goes on with its own stream.
    /// Returns the `[num_envs, *obs_shape]` first observations.
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(&mut self, py: Python<'py>, seed: Option<u64>) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let Self { vec, batch, .. } = self;
            let vec = vec.get_mut().unwrap_or_else(|p| p.into_inner());
            py.detach(|| {
                let obs = match seed {
                    Some(seed) => vec.reset(seed),
                    None => vec.reset_unseeded(),
                };
                batch.obs.copy_from_slice(obs);
            });
            self.tallies.fill(EpisodeTally::default());
            array(py, &self.batch.obs, &self.batch_shape())
        })
    }

    /// Steps every table with its row of `actions` (float32 `[num_envs, 8]`), the GIL
    /// released. Returns `(obs, rewards, terminated, truncated, infos, ended)`: `infos` a
    /// dict of `[num_envs]` arrays (`goal_distance`, `ball_speed`, `steps`, `in_goal`,
    /// `in_own_goal`, `scored`, `conceded`; `spins` `[num_envs, 2]`); `ended` None, or where an episode ended on
    /// this step a dict with `done` (mask), `end` (reason names, None where running),
    /// `final_obs` (zeros where running) and the episode metrics as arrays (`return`, `length`, `scored`,
    /// `mean_goal_distance`, `mean_ball_speed`, `final_goal_distance`; 0 where running).
    /// A refused row (NaN, infinite, wrong shape) raises `ActionError` naming it; no
    /// table moves.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<(
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyDict>,
        Option<Bound<'py, PyDict>>,
    )> {
        guarded(|| {
            let actions = actions
                .as_slice()
                .map_err(|e| ActionError::new_err(format!("actions: {e}")))?;
            self.step_rows(py, actions)?;
            let n = self.tallies.len();
            let b = &self.batch;
            let infos = PyDict::new(py);
            let column =
                |f: fn(&FoosballInfo) -> f32| -> Vec<f32> { b.infos.iter().map(f).collect() };
            let flag =
                |f: fn(&FoosballInfo) -> bool| -> Vec<bool> { b.infos.iter().map(f).collect() };
            infos.set_item(
                "goal_distance",
                array(py, &column(|i| i.goal_distance), &[n])?,
            )?;
            infos.set_item("ball_speed", array(py, &column(|i| i.ball_speed), &[n])?)?;
            let steps: Vec<u32> = b.infos.iter().map(|i| i.steps).collect();
            infos.set_item("steps", array(py, &steps, &[n])?)?;
            infos.set_item("in_goal", array(py, &flag(|i| i.in_goal), &[n])?)?;
            infos.set_item("in_own_goal", array(py, &flag(|i| i.in_own_goal), &[n])?)?;
            infos.set_item("scored", array(py, &flag(|i| i.episode_scored), &[n])?)?;
            infos.set_item("conceded", array(py, &flag(|i| i.episode_conceded), &[n])?)?;
            let spins: Vec<u32> = b.infos.iter().flat_map(|i| i.spins).collect();
            infos.set_item("spins", array(py, &spins, &[n, 2])?)?;
            let goals: Vec<u32> = b.infos.iter().flat_map(|i| i.goals).collect();
            infos.set_item("goals", array(py, &goals, &[n, 2])?)?;
            let serves: Vec<u32> = b.infos.iter().map(|i| i.serves).collect();
            infos.set_item("serves", array(py, &serves, &[n])?)?;
            let ended = if b.ended.iter().any(Option::is_some) {
                Some(self.ended_dict(py)?)
            } else {
                None
            };
            let shape = self.batch_shape();
            Ok((
                array(py, &b.obs, &shape)?,
                array(py, &b.rewards, &[n])?,
                array(py, &b.terminated, &[n])?,
                array(py, &b.truncated, &[n])?,
                infos,
                ended,
            ))
        })
    }

    /// The Rust-native loop the Python overhead is measured against: steps the tables
    /// once per row of `actions` (float32 `[steps, num_envs, 8]`) exactly as
    /// [`VecTable::step`] does (auto-reset, metrics tallied, results copied out), without
    /// returning to Python between steps; returns the wall-clock seconds it took.
    fn step_native(&mut self, py: Python<'_>, actions: PyReadonlyArray3<'_, f32>) -> PyResult<f64> {
        guarded(|| {
            let shape = actions.shape().to_vec();
            if shape[1..] != [self.tallies.len(), ACTION_DIM] {
                return Err(ActionError::new_err(format!(
                    "actions have shape {shape:?}, expected [steps, {}, {ACTION_DIM}]",
                    self.tallies.len()
                )));
            }
            let actions = actions
                .as_slice()
                .map_err(|e| ActionError::new_err(format!("actions: {e}")))?;
            self.step_rows(py, actions)
        })
    }

    /// Every table's current state drawn at `scale` pixels per cm: a list of uint8
    /// `[height, width, 3]` frames. Raises `ResetNeeded` before the first reset.
    #[pyo3(signature = (scale=4.0))]
    fn render<'py>(&self, py: Python<'py>, scale: f32) -> PyResult<Vec<Bound<'py, PyArray3<u8>>>> {
        guarded(|| {
            let renderer = renderer(scale)?;
            let vec = self.vec.lock().unwrap_or_else(|p| p.into_inner());
            vec.envs()
                .iter()
                .map(|env| {
                    let frame = env
                        .render(&renderer)
                        .ok_or_else(|| ResetNeeded::new_err("render() before the first reset()"))?;
                    frame_array(py, frame)
                })
                .collect()
        })
    }
}

impl VecTable {
    /// Steps the tables once per `[num_envs * 8]` row of `actions` with the GIL released
    /// (the last row's results kept in the batch); returns the wall-clock seconds.
    fn step_rows(&mut self, py: Python<'_>, actions: &[f32]) -> PyResult<f64> {
        let Self {
            vec,
            batch,
            tallies,
            ..
        } = self;
        let vec = vec.get_mut().unwrap_or_else(|p| p.into_inner());
        let row = tallies.len() * ACTION_DIM;
        py.detach(|| {
            let start = std::time::Instant::now();
            for a in actions.chunks(row) {
                step_into_batch(vec, tallies, batch, a)?;
            }
            Ok(start.elapsed().as_secs_f64())
        })
        .map_err(|e| vec_env_error(&e))
    }

    /// `[num_envs, *obs_shape]`.
    fn batch_shape(&self) -> Vec<usize> {
        std::iter::once(self.tallies.len())
            .chain(self.shape.iter().copied())
            .collect()
    }

    /// The `ended` dict of [`VecTable::step`].
    fn ended_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let b = &self.batch;
        let n = b.ended.len();
        let d = PyDict::new(py);
        let done: Vec<bool> = b.ended.iter().map(Option::is_some).collect();
        d.set_item("done", array(py, &done, &[n])?)?;
        let ends: Vec<Option<&str>> = b.infos.iter().map(|i| i.end.map(|e| e.name())).collect();
        d.set_item("end", ends)?;
        d.set_item("final_obs", array(py, &b.final_obs, &self.batch_shape())?)?;
        let stat = |f: fn(&EpisodeStats) -> f64| -> Vec<f64> {
            b.ended.iter().map(|s| s.as_ref().map_or(0.0, f)).collect()
        };
        d.set_item("return", array(py, &stat(|s| s.ret), &[n])?)?;
        d.set_item("length", array(py, &stat(|s| f64::from(s.length)), &[n])?)?;
        d.set_item(
            "mean_goal_distance",
            array(py, &stat(|s| s.mean_goal_distance), &[n])?,
        )?;
        d.set_item(
            "mean_ball_speed",
            array(py, &stat(|s| s.mean_ball_speed), &[n])?,
        )?;
        d.set_item(
            "final_goal_distance",
            array(py, &stat(|s| s.final_goal_distance), &[n])?,
        )?;
        let scored: Vec<bool> = b
            .ended
            .iter()
            .map(|s| s.is_some_and(|s| s.scored))
            .collect();
        d.set_item("scored", array(py, &scored, &[n])?)?;
        Ok(d)
    }
}

/// One batched step, copied into `batch`, episode metrics tallied.
fn step_into_batch(
    vec: &mut VecEnv<FoosballEnv>,
    tallies: &mut [EpisodeTally],
    batch: &mut Batch,
    actions: &[f32],
) -> Result<(), foosball_env::VecEnvError> {
    let s = vec.step(actions)?;
    let od = batch.obs.len() / tallies.len();
    batch.obs.copy_from_slice(s.obs);
    batch.rewards.copy_from_slice(s.rewards);
    batch.terminated.copy_from_slice(s.terminated);
    batch.truncated.copy_from_slice(s.truncated);
    batch.infos.copy_from_slice(s.infos);
    for (i, tally) in tallies.iter_mut().enumerate() {
        let done = s.terminated[i] || s.truncated[i];
        batch.ended[i] = tally.add(s.rewards[i], &s.infos[i], done);
        let row = &mut batch.final_obs[i * od..(i + 1) * od];
        match s.final_observation(i) {
            Some(last) => row.copy_from_slice(last),
            None => row.fill(0.0),
        }
    }
    Ok(())
}
