//! Where a run's networks start: fresh from the learner stream, or a run's saved networks
//! (`protocol.init_from = "DIR[@best|@last]"`) for fine-tuning, optionally blind to
//! black's rods (`protocol.init_blind_to_black`).

use crate::config::{RunConfig, TestActions};
use crate::play::contestant::{Contestant, fits};
use foosball_algos::Agent;
use foosball_env::layout::black_rod_inputs;

/// Loads the networks `config.protocol.init_from` names into `agent` (nothing when
/// unset). The saved run must have been trained with the same algorithm, hidden widths,
/// observation, ball frame and action map; a refusal names the key, the run and what
/// differs.
pub fn init_networks(config: &RunConfig, agent: &mut dyn Agent) -> Result<(), String> {
    let Some(spec) = &config.protocol.init_from else {
        return match config.protocol.init_blind_to_black {
            true => Err("protocol.init_blind_to_black: it blinds the networks that \
                 protocol.init_from (or --init-from) loads, and none is set"
                .into()),
            false => Ok(()),
        };
    };
    let refuse = |why: String| format!("protocol.init_from = \"{spec}\": {why}");
    let (dir, checkpoint) = match spec.parse::<Contestant>().map_err(refuse)? {
        Contestant::Run {
            dir,
            checkpoint,
            actions: TestActions::Deterministic,
        } => (dir, checkpoint),
        _ => return Err(refuse("not a run's networks, `DIR[@best|@last]`".into())),
    };
    let saved = RunConfig::load_run(&dir).map_err(|e| refuse(e.to_string()))?;
    if saved.algo() != config.algo() {
        return Err(refuse(format!(
            "it trained {}, this run trains {}",
            saved.algo(),
            config.algo()
        )));
    }
    if saved.hidden() != config.hidden() {
        return Err(refuse(format!(
            "its networks are {:?} wide, this run's {:?}",
            saved.hidden(),
            config.hidden()
        )));
    }
    // Hiding black's rods zeroes inputs of the same width: the networks carry over.
    let seen = foosball_env::ObservationConfig {
        hide_black_rods: config.env.observation.hide_black_rods,
        ..saved.env.observation
    };
    if seen != config.env.observation {
        return Err(refuse("it was trained on another observation".into()));
    }
    let reads = |c: &RunConfig| match c.normalize.as_ref().is_some_and(|n| n.obs) {
        true => "normalised",
        false => "raw",
    };
    if reads(&saved) != reads(config) {
        return Err(refuse(format!(
            "its networks read {} observations, this run's {} (normalize.obs)",
            reads(&saved),
            reads(config),
        )));
    }
    if saved.fourier != config.fourier {
        return Err(refuse(format!(
            "its networks read {}, this run's {} ([fourier])",
            features(&saved),
            features(config),
        )));
    }
    fits(&saved.env, &config.env).map_err(refuse)?;
    agent
        .load(&dir.join(checkpoint.name()))
        .map_err(|e| refuse(e.to_string()))?;
    if config.protocol.init_blind_to_black {
        let black: Vec<usize> = black_rod_inputs().collect();
        agent
            .zero_obs_inputs(&black)
            .map_err(|e| format!("protocol.init_blind_to_black: {e}"))?;
    }
    Ok(())
}

/// What a run's networks read under its `[fourier]`, in words.
fn features(config: &RunConfig) -> String {
    match &config.fourier {
        Some(f) => format!(
            "Fourier features ({} frequencies, scale {}, of values {})",
            f.frequencies,
            f.scale,
            match f.inputs.is_empty() {
                true => "all".to_string(),
                false => format!("{:?}", f.inputs),
            }
        ),
        None => "the observation values".into(),
    }
}
