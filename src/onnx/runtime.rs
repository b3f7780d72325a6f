//! An ONNX policy file played in pure Rust by tract: loaded once, its shapes checked
//! against the table's (input 0 `[batch, obs_dim]`, output 0 `[batch, action_dim]`, the
//! batch free), then run on batches of observations; and the file's metadata (what
//! `export` wrote into it, [`super::CONFIG_KEY`]), read without building the model.

use prost::Message;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tract_onnx::pb;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::dims;

/// A loaded ONNX policy.
#[derive(Clone)]
pub struct OnnxPolicy {
    path: PathBuf,
    plan: Arc<TypedRunnableModel>,
    obs_dim: usize,
    action_dim: usize,
}

impl std::fmt::Debug for OnnxPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "OnnxPolicy({})", self.path.display())
    }
}

impl OnnxPolicy {
    /// The policy in the ONNX file at `path`, mapping `[batch, obs_dim]` observations to
    /// `[batch, action_dim]` actions; an error (one line, naming the file) for a file
    /// that is not ONNX, whose operators tract does not run, or whose shapes differ, and
    /// for one whose actions on the zero observation are not finite.
    pub fn load(path: &Path, obs_dim: usize, action_dim: usize) -> Result<Self, String> {
        let at = |why: String| format!("{}: {why}", path.display());
        let proto = read_proto(path)?;
        let inputs = proto.graph.as_ref().map_or(0, real_inputs);
        if inputs != 1 {
            return Err(at(format!(
                "{inputs} inputs; a policy reads one, the [batch, {obs_dim}] observation"
            )));
        }
        let model = tract_onnx::onnx()
            .model_for_proto_model(&proto)
            .map_err(|e| at(format!("{e:#}")))?;
        let batch = model.sym("batch");
        let plan = model
            .with_input_fact(0, f32::fact(dims!(batch, obs_dim)).into())
            .and_then(|m| m.into_optimized())
            .and_then(|m| m.into_runnable())
            .map_err(|e| {
                at(format!(
                    "cannot run it on [batch, {obs_dim}] f32 observations: {e:#}"
                ))
            })?;
        let policy = Self {
            path: path.to_path_buf(),
            plan,
            obs_dim,
            action_dim,
        };
        policy.act(&vec![0.0; obs_dim])?;
        Ok(policy)
    }

    /// Actions `[n, action_dim]` for observations `[n, obs_dim]`; an error names the file
    /// and what went wrong (a runtime error, the output's shape, the first non-finite
    /// action value).
    pub fn act(&self, obs: &[f32]) -> Result<Vec<f32>, String> {
        let at = |why: String| format!("{}: {why}", self.path.display());
        let n = obs.len() / self.obs_dim;
        let input =
            Tensor::from_shape(&[n, self.obs_dim], obs).map_err(|e| at(format!("{e:#}")))?;
        let outputs = self
            .plan
            .run(tvec!(input.into()))
            .map_err(|e| at(format!("{e:#}")))?;
        let output = outputs.first().ok_or_else(|| at("no output".into()))?;
        if output.shape() != [n, self.action_dim] {
            return Err(at(format!(
                "output 0 has shape {:?} for {n} observations; a policy answers [{n}, {}] \
                 (the first output is the action)",
                output.shape(),
                self.action_dim
            )));
        }
        let actions: Vec<f32> = output
            .cast_to::<f32>()
            .and_then(|t| Ok(t.to_plain_array_view::<f32>()?.iter().copied().collect()))
            .map_err(|e| at(format!("{e:#}")))?;
        if let Some(i) = actions.iter().position(|a| !a.is_finite()) {
            return Err(at(format!(
                "action value {} of observation {} is {}",
                i % self.action_dim,
                i / self.action_dim,
                actions[i]
            )));
        }
        Ok(actions)
    }
}

/// The model in the file at `path`; an error names the file.
fn read_proto(path: &Path) -> Result<pb::ModelProto, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    pb::ModelProto::decode(bytes.as_slice())
        .map_err(|e| format!("{}: not an ONNX model ({e})", path.display()))
}

fn metadata(proto: &pb::ModelProto, key: &str) -> Option<String> {
    proto
        .metadata_props
        .iter()
        .find(|p| p.key == key)
        .map(|p| p.value.clone())
}

/// The value of metadata `key` in the ONNX file at `path` (read without building the
/// model); `None` where the file has none, an error where it is not ONNX.
pub fn read_metadata(path: &Path, key: &str) -> Result<Option<String>, String> {
    Ok(metadata(&read_proto(path)?, key))
}

/// The graph's inputs that are not initializers (older exporters list the constants
/// among the inputs too).
fn real_inputs(graph: &pb::GraphProto) -> usize {
    graph
        .input
        .iter()
        .filter(|i| !graph.initializer.iter().any(|t| t.name == i.name))
        .count()
}
