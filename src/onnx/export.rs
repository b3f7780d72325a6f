//! A run's deterministic policy as an ONNX model: its agent's policy chain
//! ([`foosball_algos::Agent::policy_chain`]) behind the values its table hides, written by
//! [`super::graph`], with the run's configuration, source and commit as metadata.

use super::graph::policy_model;
use super::{COMMIT_KEY, CONFIG_KEY, SOURCE_KEY};
use crate::agents::load_agent;
use crate::config::RunConfig;
use crate::provenance::BUILD_COMMIT;
use foosball_env::ObservationKind;
use foosball_env::layout::{OBS_DIM, black_rod_inputs};
use std::path::Path;

/// The ONNX model of the networks in `networks` (a run's `best/` or `last/`) of the run
/// `config` describes, named `source` in the file; an error names what cannot be
/// exported (image observations, layer normalisation).
pub fn exported_policy(
    config: &RunConfig,
    networks: &Path,
    source: &str,
) -> Result<Vec<u8>, String> {
    if config.env.observation.kind != ObservationKind::State {
        return Err(format!(
            "{source}: the run observes images; export writes state policies (38 values in)"
        ));
    }
    let agent = load_agent(config, networks)?;
    let chain = agent
        .policy_chain()
        .map_err(|why| format!("{source}: {why}"))?;
    let hidden: Vec<usize> = match config.env.observation.hide_black_rods {
        true => black_rod_inputs().collect(),
        false => Vec::new(),
    };
    let doc = format!(
        "foosball-rl: the deterministic policy of {source} ({} {} networks): input \
         `observation` [batch, 38] (the table's state, ball_frame {:?}), output `action` \
         [batch, 8] (slide and turn of goalie, defence, midfield, attack; action_map {:?})",
        config.algo(),
        config.hidden_label(),
        config.env.ball_frame,
        config.env.action_map
    );
    let metadata = [
        (CONFIG_KEY, config.to_toml()),
        (SOURCE_KEY, source.to_string()),
        (COMMIT_KEY, BUILD_COMMIT.to_string()),
    ];
    policy_model(OBS_DIM, &hidden, &chain, &metadata, &doc)
        .map_err(|why| format!("{source}: {why}"))
}
