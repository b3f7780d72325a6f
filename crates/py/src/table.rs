//! [`Table`]: one foosball table for Python (`foosball_rl.FoosballEnv` wraps it).

use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};

use foosball_env::{Env, FoosballEnv, ResetOptions};
use numpy::{PyArray3, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::episode::EpisodeTally;
use crate::errors::{ActionError, ConfigError, ResetNeeded, env_error, guarded};
use crate::settings;
use crate::to_python::{array, frame_array, info_dict, obs_shape, renderer};

/// One table: yellow (the agent, 8 action values in [-1, 1]: slide then turn of goalie,
/// defence, midfield, attack) against black as the config's opponent.
#[pyclass(module = "foosball_rl._core")]
pub struct Table {
    /// In a mutex only to make the class `Sync` (an opponent need not be); every call
    /// that steps holds `&mut self` and reaches it without locking.
    env: Mutex<FoosballEnv>,
    obs: Vec<f32>,
    shape: Vec<usize>,
    tally: EpisodeTally,
}

#[pymethods]
impl Table {
    /// A table from `preset` (a name, default `reference`), then the TOML file `config`
    /// (a run config's `[env]`, or bare env keys), then `overrides` (a dict, nested or
    /// with dotted keys). Raises `ConfigError` naming the key at fault.
    #[new]
    #[pyo3(signature = (preset=None, config=None, overrides=None))]
    fn new(
        preset: Option<&str>,
        config: Option<PathBuf>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        guarded(|| {
            let config = settings::resolve(preset, config.as_deref(), overrides)?;
            let shape = obs_shape(&config);
            let env = FoosballEnv::new(config).map_err(|e| ConfigError::new_err(e.to_string()))?;
            Ok(Self {
                obs: vec![0.0; env.obs_dim()],
                env: Mutex::new(env),
                shape,
                tally: EpisodeTally::default(),
            })
        })
    }

    /// The whole configuration, every value pinned, as TOML (what a run's `[env]` holds).
    #[getter]
    fn config_toml(&self) -> PyResult<String> {
        toml::to_string(self.env().config())
            .map_err(|e| ConfigError::new_err(format!("config does not serialise: {e}")))
    }

    /// The shape of one observation: `[38]`, or `[channels, height, width]` for images.
    #[getter]
    fn obs_shape(&self) -> Vec<usize> {
        self.shape.clone()
    }

    /// Whether observations are images (values `byte / 255` in [0, 1]).
    #[getter]
    fn image_obs(&self) -> bool {
        self.shape.len() == 3
    }

    /// Length of an action (8).
    #[getter]
    fn action_dim(&self) -> usize {
        self.env().action_dim()
    }

    /// Seconds of play per agent step.
    #[getter]
    fn agent_dt(&self) -> f32 {
        self.env().config().agent_dt()
    }

    /// Agent steps after which an episode is truncated.
    #[getter]
    fn max_episode_steps(&self) -> u32 {
        self.env().config().max_episode_steps
    }

    /// Starts an episode; with a seed the table's random stream restarts from it, without
    /// one it goes on; `ball = (x, y)` (cm, the config's ball frame) places the ball at rest
    /// there instead of drawing it (ValueError off the playfield). Returns the first
    /// observation (float32, `obs_shape`).
    #[pyo3(signature = (seed=None, ball=None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<u64>,
        ball: Option<[f32; 2]>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let env = self.env.get_mut().unwrap_or_else(|p| p.into_inner());
            env.reset_with(seed, &ResetOptions { ball }, &mut self.obs)
                .map_err(|e| env_error(&e))?;
            self.tally = EpisodeTally::default();
            array(py, &self.obs, &self.shape)
        })
    }

    /// One agent step with `action` (float32, shape `[8]`): `(obs, reward, terminated,
    /// truncated, info)`. Raises `ActionError` for a NaN or infinite value (the table is
    /// left as it was) and `ResetNeeded` after the episode ended.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<(Bound<'py, PyAny>, f32, bool, bool, Bound<'py, PyDict>)> {
        guarded(|| {
            let action = action
                .as_slice()
                .map_err(|e| ActionError::new_err(format!("action: {e}")))?;
            let env = self.env.get_mut().unwrap_or_else(|p| p.into_inner());
            let t = env
                .step_into(action, &mut self.obs)
                .map_err(|e| env_error(&e))?;
            let stats = self.tally.add(t.reward, &t.info, t.done());
            let info = info_dict(py, &t.info, stats.as_ref())?;
            let obs = array(py, &self.obs, &self.shape)?;
            Ok((obs, t.reward, t.terminated, t.truncated, info))
        })
    }

    /// The current state drawn top-down at `scale` pixels per cm: uint8 `[height, width,
    /// 3]`, yellow attacking upwards. Raises `ResetNeeded` before the first reset.
    #[pyo3(signature = (scale=4.0))]
    fn render<'py>(&self, py: Python<'py>, scale: f32) -> PyResult<Bound<'py, PyArray3<u8>>> {
        guarded(|| {
            let frame = self
                .env()
                .render(&renderer(scale)?)
                .ok_or_else(|| ResetNeeded::new_err("render() before the first reset()"))?;
            frame_array(py, frame)
        })
    }

    /// The noise-free 38-dim state (float32), whatever the observation kind; None
    /// before the first reset.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.env()
            .state()
            .map(|s| array(py, s, &[s.len()]))
            .transpose()
    }
}

impl Table {
    fn env(&self) -> MutexGuard<'_, FoosballEnv> {
        // A panic while stepping is caught by `guarded` and poisons nothing we rely on.
        self.env.lock().unwrap_or_else(|p| p.into_inner())
    }
}
