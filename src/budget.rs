//! What a run configuration will hold in memory, estimated before anything is allocated,
//! so that an impossible size is refused with a message instead of an allocator abort.

use crate::config::{Algo, RunConfig};
use foosball_env::layout::{ACTION_DIM, OBS_DIM};

/// Parameters of an MLP `input -> hidden... -> output` (weights and biases).
fn mlp_params(input: usize, hidden: &[usize], output: usize) -> f64 {
    let widths: Vec<f64> = std::iter::once(input)
        .chain(hidden.iter().copied())
        .chain(std::iter::once(output))
        .map(|w| w as f64)
        .collect();
    widths.windows(2).map(|w| w[0] * w[1] + w[1]).sum()
}

/// Estimated bytes the run's learner holds: f32 parameters of every network, and for each
/// trained one its gradient and two Adam moments, plus the replay buffer's rows.
pub fn learner_bytes(config: &RunConfig) -> f64 {
    let (o, a, h) = (OBS_DIM, ACTION_DIM, config.hidden());
    let q = mlp_params(o + a, h, 1);
    let (trained, targets, buffer) = match config.algo {
        Algo::Ppo => (mlp_params(o, h, a) + mlp_params(o, h, 1), 0.0, 0),
        Algo::Sac => (
            mlp_params(o, h, 2 * a) + 2.0 * q,
            2.0 * q,
            config.sac.as_ref().map_or(0, |c| c.off_policy.buffer_size),
        ),
        Algo::Td3 => {
            let actor = mlp_params(o, h, a);
            (
                actor + 2.0 * q,
                actor + 2.0 * q,
                config.td3.as_ref().map_or(0, |c| c.off_policy.buffer_size),
            )
        }
    };
    let row = (2 * o + a + 2) as f64;
    4.0 * (4.0 * trained + targets + buffer as f64 * row)
}

/// Memory this machine has available now, bytes (`MemAvailable` of /proc/meminfo), or
/// None where that is not known.
pub fn available_bytes() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// Refuses a configuration whose learner cannot fit in `available` bytes.
pub fn check(config: &RunConfig, available: Option<f64>) -> Result<(), String> {
    let need = learner_bytes(config);
    let gib = |b: f64| b / (1u64 << 30) as f64;
    match available {
        Some(have) if need > have => Err(format!(
            "{}.net.hidden = {:?} with its buffers needs about {:.1} GiB (parameters, \
             gradients, Adam moments, targets, replay buffer) but this machine has {:.1} GiB \
             available: choose smaller --hidden or buffer_size",
            config.algo,
            config.hidden(),
            gib(need),
            gib(have)
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mlp_parameters_count_weights_and_biases() {
        // 38 -> 64 -> 64 -> 8: 38*64+64 + 64*64+64 + 64*8+8.
        assert_eq!(mlp_params(38, &[64, 64], 8), 2496.0 + 4160.0 + 520.0);
    }

    #[test]
    fn impossible_sizes_are_refused_and_small_ones_pass() {
        let text = "algo = \"sac\"\n[sac.net]\nhidden = [100000000, 100000000]\n";
        let mut c = RunConfig::from_toml(text, std::path::Path::new("x.toml")).unwrap();
        let e = check(&c, Some(24.0 * (1u64 << 30) as f64)).unwrap_err();
        assert!(e.contains("sac.net.hidden = [100000000, 100000000]"), "{e}");
        assert!(e.contains("GiB available"), "{e}");
        c.set_hidden(vec![64, 64]);
        // 64x64 SAC: ~0.35 GB, nearly all of it the 1e6-row replay buffer.
        let need = learner_bytes(&c);
        assert!((0.3e9..0.4e9).contains(&need), "{need}");
        check(&c, Some(24.0 * (1u64 << 30) as f64)).unwrap();
        check(&c, None).unwrap();
    }
}
