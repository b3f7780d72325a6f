//! What crosses into Python: observation shapes, per-step info and episode metrics as
//! dicts, frames as arrays.

use foosball_env::render::{Frame, Renderer};
use foosball_env::{FoosballConfig, FoosballInfo, ObservationKind};
use numpy::{PyArray1, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::episode::EpisodeStats;

/// The shape of one observation: `[38]` for the state, `[channels, height, width]` for
/// stacked frames (values `byte / 255`).
pub fn obs_shape(config: &FoosballConfig) -> Vec<usize> {
    let o = &config.observation;
    match o.kind {
        ObservationKind::State => vec![o.dim()],
        ObservationKind::Image => vec![o.channels(), o.height as usize, o.width as usize],
    }
}

/// One step's details: `end` (the end reason's name, or None while the episode runs),
/// `goal_distance` (cm), `ball_speed` (cm/s), `steps`, `in_goal`, `in_own_goal`,
/// `scored` and `conceded` (so far in the episode), `spins` (yellow's and black's rods'
/// spins so far, `[2]`), `goals` (yellow's and black's goals so far, `[2]`), `serves`
/// (serves after the kick-off so far, `rules.serve_again`); `episode` (see [`stats_dict`]) on its last step.
pub fn info_dict<'py>(
    py: Python<'py>,
    info: &FoosballInfo,
    stats: Option<&EpisodeStats>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("end", info.end.map(|e| e.name()))?;
    d.set_item("goal_distance", info.goal_distance)?;
    d.set_item("ball_speed", info.ball_speed)?;
    d.set_item("steps", info.steps)?;
    d.set_item("in_goal", info.in_goal)?;
    d.set_item("in_own_goal", info.in_own_goal)?;
    d.set_item("scored", info.episode_scored)?;
    d.set_item("conceded", info.episode_conceded)?;
    d.set_item("spins", info.spins.to_vec())?;
    d.set_item("goals", info.goals.to_vec())?;
    d.set_item("serves", info.serves)?;
    if let Some(stats) = stats {
        d.set_item("episode", stats_dict(py, stats)?)?;
    }
    Ok(d)
}

/// A finished episode's metrics: `return`, `length` (agent steps), `scored`,
/// `mean_goal_distance` (cm), `mean_ball_speed` (cm/s), `final_goal_distance` (cm).
pub fn stats_dict<'py>(py: Python<'py>, s: &EpisodeStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("return", s.ret)?;
    d.set_item("length", s.length)?;
    d.set_item("scored", s.scored)?;
    d.set_item("mean_goal_distance", s.mean_goal_distance)?;
    d.set_item("mean_ball_speed", s.mean_ball_speed)?;
    d.set_item("final_goal_distance", s.final_goal_distance)?;
    Ok(d)
}

/// `values` as a numpy array of `shape` (a copy).
pub fn array<'py, T: numpy::Element + Copy>(
    py: Python<'py>,
    values: &[T],
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_slice(py, values)
        .reshape(shape.to_vec())?
        .into_any())
}

/// An RGB frame as a `[height, width, 3]` uint8 array.
pub fn frame_array<'py>(py: Python<'py>, frame: Frame) -> PyResult<Bound<'py, PyArray3<u8>>> {
    PyArray1::from_vec(py, frame.rgb).reshape([frame.height, frame.width, 3])
}

/// A renderer drawing `scale` pixels per cm, refused outside (0, 32].
pub fn renderer(scale: f32) -> PyResult<Renderer> {
    if scale.is_finite() && scale > 0.0 && scale <= 32.0 {
        Ok(Renderer::new(scale))
    } else {
        Err(pyo3::exceptions::PyValueError::new_err(format!(
            "render scale must be in (0, 32] pixels per cm, got {scale}"
        )))
    }
}
