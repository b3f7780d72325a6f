//! What a run will cost, told before it starts: the memory it will hold, estimated from
//! its sizes before anything is allocated (an impossible size is refused with a message
//! instead of an allocator abort), and its wall time, from a few env steps and gradient
//! steps timed on a throwaway copy of the learner (a few seconds at most).

use super::error::TrainError;
use crate::agents::{build_agent, device};
use crate::config::{Algo, AlgoConfig, RunConfig};
use foosball_algos::plane_store::PlaneStore;
use foosball_algos::{ActMode, Experience, SacConfig, Td3Config};
use foosball_env::layout::ACTION_DIM;
use foosball_env::{Env, FoosballEnv, ObservationKind};
use std::time::{Duration, Instant};

/// Wall time a run is estimated to need, from timings on this machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeBudget {
    /// Seconds per env step of the table with the run's settings (one env, one thread).
    pub env_step_s: f64,
    /// Seconds per gradient step of the run's networks (one minibatch).
    pub gradient_step_s: f64,
    /// Gradient steps the algorithm takes per env step.
    pub gradient_steps_per_env_step: f64,
    /// Estimated seconds for all the run's env steps and gradient steps (evaluations and
    /// the test not included).
    pub total_s: f64,
}

/// Times the env and the learner of `config`: env steps for about 0.3 s, then gradient
/// steps on a throwaway learner built like the run's (seeded the same, so nothing of the
/// run's own random streams is used) fed with random transitions: the fastest of two to
/// ten gradient steps (more while those after the first take under about 3 s), as the
/// first ones warm GPU kernels up.
pub fn time_budget(config: &RunConfig) -> Result<TimeBudget, TrainError> {
    let mut env =
        FoosballEnv::new(config.env.clone()).map_err(|e| TrainError::Env(e.to_string()))?;
    let mut obs = env.reset(Some(0));
    let action = [0.5_f32; ACTION_DIM];
    let (mut env_steps, started) = (0u32, Instant::now());
    while started.elapsed() < Duration::from_millis(300) {
        let (next, t) = env.step(&action)?;
        obs = if t.done() { env.reset(None) } else { next };
        env_steps += 1;
    }
    let env_step_s = started.elapsed().as_secs_f64() / f64::from(env_steps);

    // One gradient step per update: PPO with a rollout of one minibatch and one epoch,
    // SAC/TD3 training from their first minibatch on, with a small replay buffer.
    let mut probe = config.clone();
    probe.protocol.envs = 1;
    let per_env_step = match &mut probe.algorithm {
        AlgoConfig::Ppo(c) => {
            let rollout = (c.n_steps * config.protocol.envs) as f64;
            let per = c.n_epochs as f64 * (rollout / c.batch_size as f64).ceil() / rollout;
            (c.n_steps, c.n_epochs) = (c.batch_size, 1);
            per
        }
        AlgoConfig::Sac(SacConfig { off_policy: c, .. })
        | AlgoConfig::Td3(Td3Config { off_policy: c, .. }) => {
            let per = c.gradient_steps as f64 / (c.train_freq * config.protocol.envs as u64) as f64;
            c.learning_starts = c.batch_size as u64;
            c.buffer_size = 2 * c.batch_size;
            (c.train_freq, c.gradient_steps) = (1, 1);
            per
        }
    };
    let device = device(config)?;
    let mut agent = build_agent(&probe, &device);
    // The first gradient steps also compile and tune GPU kernels (11 s, then 0.7 s on
    // wgpu, where later steps take 80 ms), so the estimate is the fastest of at least two
    // steps, up to ten while the steps after the first have taken under ~3 s.
    let (mut timed, mut fastest) = (0u32, f64::INFINITY);
    let mut after_first: Option<Instant> = None;
    let (zero, no) = ([0.0_f32], [false]);
    while timed < 2
        || (timed < 10 && after_first.is_none_or(|t| t.elapsed() < Duration::from_secs(3)))
    {
        let actions = agent.act(&obs, ActMode::Explore);
        agent.observe(&Experience {
            obs: &obs,
            actions: &actions,
            rewards: &zero,
            next_obs: &obs,
            final_obs: vec![None],
            terminated: &no,
            truncated: &no,
            absorbing: vec![false],
            // Labels for a run with a teacher: the probe times the update, whatever it learns.
            teacher: Some(&actions),
        });
        let before = (Instant::now(), agent.gradient_steps());
        agent.update(1.0);
        // A GPU update only queues its work (it reads nothing back): wait for it.
        device
            .sync()
            .map_err(|e| TrainError::Device(e.to_string()))?;
        let steps = agent.gradient_steps() - before.1;
        if steps > 0 {
            fastest = fastest.min(before.0.elapsed().as_secs_f64() / steps as f64);
            timed += 1;
            after_first.get_or_insert_with(Instant::now);
        }
    }
    let gradient_step_s = fastest;
    let steps = config.protocol.total_env_steps();
    Ok(TimeBudget {
        env_step_s,
        gradient_step_s,
        gradient_steps_per_env_step: per_env_step,
        total_s: steps as f64 * (env_step_s + per_env_step * gradient_step_s),
    })
}

/// The budget as one line, with a line for the interactive teacher's searches where the
/// run has one (a ceiling: they are not timed) and a warning line where the run needs more
/// than a day.
pub fn describe(config: &RunConfig, time: &TimeBudget, available: Option<f64>) -> String {
    let gib = |b: f64| b / (1u64 << 30) as f64;
    let have = available.map_or(String::new(), |a| {
        format!(" of {:.1} GiB available", gib(a))
    });
    let mut out = format!(
        "# budget: memory about {:.2} GiB{have}; {:.3} ms per env step + {:.2} gradient \
         steps of {:.3} ms each: about {} for the run's {} env steps on this machine",
        gib(learner_bytes(config)),
        1e3 * time.env_step_s,
        time.gradient_steps_per_env_step,
        1e3 * time.gradient_step_s,
        indicatif::HumanDuration(Duration::from_secs_f64(time.total_s.min(1e12))),
        config.protocol.total_env_steps(),
    );
    if let Some(d) = &config.dagger {
        let p = &d.planner;
        let queries = config.protocol.total_env_steps() / d.every * u64::from(d.episodes);
        let rollouts = 1 + p.iterations * (p.population - 1);
        let ceiling =
            queries as f64 * rollouts as f64 * f64::from(p.max_rollout_steps) * time.env_step_s;
        out += &format!(
            "\n# [dagger] adds {queries} searches of at most {rollouts} rollouts of at most {} \
             agent steps each (each stops at its first goal): at most {} more",
            p.max_rollout_steps,
            indicatif::HumanDuration(Duration::from_secs_f64(ceiling.min(1e12))),
        );
    }
    if time.total_s > 86_400.0 {
        out += &format!(
            "\n# that is more than a day: try --hidden 64,64 (the CPU path) or a GPU backend \
             (`backend = \"cuda\"` or \"wgpu\" under [protocol], see README); {}.net.hidden is {:?}",
            config.algo(),
            config.hidden()
        );
    }
    out
}

/// Parameters of an MLP `input -> hidden... -> output` (weights and biases).
fn mlp_params(input: usize, hidden: &[usize], output: usize) -> f64 {
    let widths: Vec<f64> = std::iter::once(input)
        .chain(hidden.iter().copied())
        .chain(std::iter::once(output))
        .map(|w| w as f64)
        .collect();
    widths.windows(2).map(|w| w[0] * w[1] + w[1]).sum()
}

/// Parameters of a network's observation encoder (none for the state, the CNN for an
/// image) and the width it hands the MLP.
fn encoder_params(config: &RunConfig) -> (f64, usize) {
    let o = &config.env.observation;
    if o.kind == ObservationKind::State {
        return (0.0, o.dim());
    }
    let cnn = &config.algorithm.net().cnn;
    let mut params = 0.0;
    let mut channels = o.channels();
    for l in &cnn.convs {
        params += (channels * l.kernel * l.kernel * l.channels + l.channels) as f64;
        channels = l.channels;
    }
    let flat = cnn
        .conv_features(o.channels(), o.height as usize, o.width as usize)
        .unwrap_or(0);
    (params + mlp_params(flat, &[], cnn.features), cnn.features)
}

/// Estimated bytes the run's learner holds: f32 parameters of every network (an image's
/// CNN per actor and per critic pair), and for each trained one its gradient and two Adam
/// moments, plus the replay buffer's rows or PPO's rollout. A replay row holds its
/// observation and next observation as f32, or for an image the ids of their planes and
/// about one new frame's planes with their bookkeeping ([`PlaneStore`]'s own sizes); an
/// episode's first row adds one more frame, not counted.
pub fn learner_bytes(config: &RunConfig) -> f64 {
    let (o, a, h) = (config.env.observation.dim(), ACTION_DIM, config.hidden());
    let (enc, f) = encoder_params(config);
    let twin = enc + 2.0 * mlp_params(f + a, h, 1);
    let actor = |out| enc + mlp_params(f, h, out);
    let (trained, targets) = match config.algo() {
        Algo::Ppo => (actor(a) + actor(1), 0.0),
        Algo::Sac => (actor(2 * a) + twin, twin),
        Algo::Td3 => (actor(a) + twin, actor(a) + twin),
    };
    let ob = &config.env.observation;
    let obs_pair_bytes = match ob.kind {
        ObservationKind::State => 2 * 4 * o,
        ObservationKind::Image => {
            let plane = (ob.height * ob.width) as usize;
            PlaneStore::row_bytes(ob.channels())
                + ob.frame_channels() * PlaneStore::slot_bytes(plane)
        }
    };
    let rows = match &config.algorithm {
        AlgoConfig::Ppo(p) => ((p.n_steps * config.protocol.envs) * 4 * (o + a + 6)) as f64,
        _ => {
            let buffer = config.algorithm.off_policy().map_or(0, |c| c.buffer_size);
            (buffer * (obs_pair_bytes + 4 * (a + 2))) as f64
        }
    };
    4.0 * (4.0 * trained + targets) + rows
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
             gradients, Adam moments, targets, replay buffer of {} observations of {} \
             values) but this machine has {:.1} GiB available: choose smaller --hidden, \
             buffer_size or env.observation",
            config.algo(),
            config.hidden(),
            gib(need),
            config.algorithm.off_policy().map_or(0, |c| c.buffer_size),
            config.env.observation.dim(),
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
        c.algorithm.net_mut().hidden = vec![64, 64];
        // 64x64 SAC: ~0.35 GB, nearly all of it the 1e6-row replay buffer.
        let need = learner_bytes(&c);
        assert!((0.3e9..0.4e9).contains(&need), "{need}");
        check(&c, Some(24.0 * (1u64 << 30) as f64)).unwrap();
        check(&c, None).unwrap();
    }

    #[test]
    fn image_observations_count_one_new_frame_per_replay_row() {
        let text = "algo = \"sac\"\n[sac.net]\nhidden = [64, 64]\n\
                    [env.observation]\nkind = \"image\"\n";
        let mut c = RunConfig::from_toml(text, std::path::Path::new("x.toml")).unwrap();
        // 1e6 rows of one new 84 x 84 grey frame (whole stacks would be 56 GB).
        let need = learner_bytes(&c);
        assert!((7.0e9..7.5e9).contains(&need), "{need}");
        check(&c, Some(24.0 * (1u64 << 30) as f64)).unwrap();
        let e = check(&c, Some(4.0 * (1u64 << 30) as f64)).unwrap_err();
        assert!(e.contains("1000000 observations of 28224 values"), "{e}");
        // Colour: three planes per frame.
        c.env.observation.grayscale = false;
        let colour = learner_bytes(&c);
        assert!((2.9..3.0).contains(&(colour / need)), "{colour} vs {need}");
        if let AlgoConfig::Sac(s) = &mut c.algorithm {
            s.off_policy.buffer_size = 100_000;
        }
        check(&c, Some(4.0 * (1u64 << 30) as f64)).unwrap();
    }
}
