//! What the learners' unit tests share: a CPU device, made-up minibatches, an Adam whose
//! step shows a gradient's size, the gap between two updates of one network, and the
//! checks every learner on the host MLP path passes, and an agent that records what a
//! wrapper hands it.

use crate::agent::{ActMode, Agent, AgentError, Experience, Metrics};
use crate::config::NetConfig;
use crate::demonstrations::Demonstration;
use crate::off_policy::{OffPolicy, OffPolicyLearner};
use crate::replay::ReplayBatch;
use crate::tensors::standard_normal;
use foosball_nets::{Backend, Device, ObsShape, Snapshot, SnapshotError};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::sync::{Arc, Mutex};

/// The default CPU backend's (autodiff) device.
pub fn device() -> Device {
    Backend::default_cpu().unwrap().device().unwrap()
}

/// A minibatch of `n` rows of `o`-wide observations and `a`-wide actions in `(-1, 1)`,
/// the first `demos` rows demonstrations, every fourth row terminal.
pub fn batch(n: usize, o: usize, a: usize, demos: usize, seed: u64) -> ReplayBatch {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut uniform = |k: usize| -> Vec<f32> {
        standard_normal(k, 1, &mut rng)
            .iter()
            .map(|x| x.tanh())
            .collect()
    };
    ReplayBatch {
        obs: uniform(n * o),
        actions: uniform(n * a),
        rewards: uniform(n).iter().map(|r| 3.0 * r).collect(),
        next_obs: uniform(n * o),
        dones: (0..n).map(|i| f32::from(u8::from(i % 4 == 3))).collect(),
        demos,
    }
}

/// `net` with an Adam whose first step is close to a plain gradient step,
/// `lr g / (|g| + eps)` with `eps` = 10 and `lr` = 10: parameters after one step show the
/// gradient's size, not only its sign.
pub fn gradient_revealing(net: &mut NetConfig) {
    net.adam.eps = 10.0;
    net.lr = crate::LrSchedule::Constant(10.0);
}

/// The largest gap between `a` and `b`'s changes from `start`, over the largest change.
pub fn change_gap(start: &[f32], a: &[f32], b: &[f32]) -> f32 {
    let (mut gap, mut size) = (0.0f32, 0.0f32);
    for ((s, a), b) in start.iter().zip(a).zip(b) {
        gap = gap.max(((a - s) - (b - s)).abs());
        size = size.max((a - s).abs()).max((b - s).abs());
    }
    assert!(size > 0.0, "the step changed nothing");
    gap / size
}

/// The learner `make(false)` builds on the Burn path and `make(true)` on the host path,
/// trained on the same 50 minibatches of `(o, a)` rows: each step's metrics agree within
/// 1e-3, the parameters' changes (`flat`) within 1e-3 of their size, the actions (greedy
/// and explored with the same noise) within 1e-3; the host learner's files load into
/// either path as the same parameters.
pub fn host_follows_burn<L: OffPolicyLearner>(
    make: impl Fn(bool) -> OffPolicy<L>,
    flat: impl Fn(&L) -> Vec<f32>,
    (o, a): (usize, usize),
) {
    let (mut burn, mut host) = (make(false), make(true));
    let mut rng = (ChaCha8Rng::seed_from_u64(1), ChaCha8Rng::seed_from_u64(1));
    for k in 0..50 {
        let batch = batch(64, o, a, 0, 100 + k);
        let mb = burn.learner_mut().train_step(&batch, 3e-4, &mut rng.0);
        let mh = host.learner_mut().train_step(&batch, 3e-4, &mut rng.1);
        for ((name, b), (_, h)) in mb.0.into_iter().zip(mh.0) {
            let (b, h) = (b.read(), h.read());
            assert!(
                (b - h).abs() <= 1e-3 * b.abs().max(1.0) || (b.is_nan() && h.is_nan()),
                "step {k}: {name} {b} vs {h}"
            );
        }
    }
    let (pb, ph) = (flat(burn.learner()), flat(host.learner()));
    let start = flat(make(false).learner());
    assert!(change_gap(&start, &pb, &ph) < 1e-3);
    // Acting: the same actions from the same networks and noise.
    let obs = batch(4, o, a, 0, 7).obs;
    for mode in [ActMode::Deterministic, ActMode::Explore] {
        let mut rng = (ChaCha8Rng::seed_from_u64(2), ChaCha8Rng::seed_from_u64(2));
        let ab = burn.learner_mut().policy_act(&obs, mode, &mut rng.0);
        let ah = host.learner_mut().policy_act(&obs, mode, &mut rng.1);
        assert!(
            ab.iter().zip(&ah).all(|(x, y)| (x - y).abs() < 1e-3),
            "{mode:?}: {ab:?} {ah:?}"
        );
    }
    // Files: the host learner's networks load into a Burn learner and back.
    let dir = std::env::temp_dir().join(format!(
        "host-files-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    host.save(&dir).unwrap();
    let (mut loaded_burn, mut loaded_host) = (make(false), make(true));
    loaded_burn.load(&dir).unwrap();
    loaded_host.load(&dir).unwrap();
    assert_eq!(flat(loaded_burn.learner()), ph);
    assert_eq!(flat(loaded_host.learner()), ph);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `on_host(obs, critic_layer_norm)` (a fresh learner put on the host path) refuses
/// layer normalisation and image observations, naming them.
pub fn host_path_refusals(on_host: impl Fn(ObsShape, bool) -> Result<(), String>) {
    let err = on_host(ObsShape::Vector(5), true).unwrap_err();
    assert!(err.contains("layer normalisation"), "{err}");
    let image = ObsShape::Image {
        channels: 3,
        height: 36,
        width: 36,
    };
    let err = on_host(image, false).unwrap_err();
    assert!(err.contains("image"), "{err}");
}

/// One step on `batch` (lr 10, noise drawn from seed 4) of the learner `make(false)`
/// builds on the Burn path and `make(true)` on the host path: each changes its parameters
/// (`flat`) as `expected` (a reference step's from the same start) within 1e-4 of the
/// step's size.
pub fn steps_as_expected<L: OffPolicyLearner>(
    make: impl Fn(bool) -> OffPolicy<L>,
    flat: impl Fn(&L) -> Vec<f32>,
    batch: &ReplayBatch,
    expected: &[f32],
) {
    let start = flat(make(false).learner());
    for host_path in [false, true] {
        let mut agent = make(host_path);
        let learner = agent.learner_mut();
        learner.train_step(batch, 10.0, &mut ChaCha8Rng::seed_from_u64(4));
        let gap = change_gap(&start, &flat(learner), expected);
        assert!(
            gap < 1e-4,
            "host path {host_path}: {gap} of the step's size"
        );
    }
}

/// What a [`Recorder`] was given: per `observe` or demonstration, its observations and
/// rewards.
pub type Log = Arc<Mutex<Vec<(Vec<f32>, Vec<f32>)>>>;

/// An agent of `width`-wide observations that records what it observes and the inputs
/// it is asked to zero; acts with each observation's first value (one action).
pub struct Recorder {
    width: usize,
    log: Log,
    /// The input indices of every `zero_obs_inputs` call, in order.
    pub zeroed: Arc<Mutex<Vec<usize>>>,
}

impl Recorder {
    /// Records into `log`.
    pub fn new(width: usize, log: Log) -> Self {
        Self {
            width,
            log,
            zeroed: Arc::default(),
        }
    }
}

impl Agent for Recorder {
    fn obs_dim(&self) -> usize {
        self.width
    }
    fn action_dim(&self) -> usize {
        1
    }
    fn act(&mut self, obs: &[f32], _mode: ActMode) -> Vec<f32> {
        obs.chunks(self.width).map(|o| o[0]).collect()
    }
    fn seed_sampling(&mut self, _seed: u64) {}
    fn observe(&mut self, step: &Experience<'_>) {
        let mut log = self.log.lock().unwrap();
        log.push((step.obs.to_vec(), step.rewards.to_vec()));
    }
    fn update(&mut self, _p: f64) -> Option<Metrics> {
        None
    }
    fn env_steps(&self) -> u64 {
        0
    }
    fn gradient_steps(&self) -> u64 {
        0
    }
    fn save(&self, _dir: &Path) -> Result<(), AgentError> {
        Ok(())
    }
    fn load(&mut self, _dir: &Path) -> Result<(), AgentError> {
        Ok(())
    }
    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.zeroed.lock().unwrap().extend_from_slice(inputs);
        Ok(())
    }
    fn save_state<'a>(&'a self, _snap: &mut Snapshot<'a>) {}
    fn load_state(&mut self, _snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        Ok(())
    }
    fn set_demonstrations(&mut self, episodes: &[Demonstration<'_>]) -> Result<usize, String> {
        let mut log = self.log.lock().unwrap();
        for e in episodes {
            log.push((e.obs.to_vec(), e.rewards.to_vec()));
        }
        Ok(episodes.iter().map(|e| e.rewards.len()).sum())
    }
}

/// One explored step of `agent` on two envs (3 observation values each, fixed), env 0's
/// episode ending where `done`: its actions.
fn explore_step(agent: &mut impl Agent, done: bool) -> Vec<f32> {
    let obs = [0.1, -0.4, 0.7, 0.2, 0.0, -0.3];
    let actions = agent.act(&obs, ActMode::Explore);
    agent.observe(&Experience {
        obs: &obs,
        actions: &actions,
        rewards: &[0.0, 0.0],
        next_obs: &obs,
        final_obs: vec![None, None],
        terminated: &[done, false],
        truncated: &[false, false],
        absorbing: vec![false, false],
        teacher: None,
    });
    actions
}

/// Exploration noise correlated over steps, on agents `make(rho)` (3 -> 2 on two envs,
/// acting by their policy from the first step, the same networks and seed for every
/// `rho`): the first explored actions are white noise's (`rho` 0); with `rho` 0.95 the
/// first action moves step to step by less than half as much as with white noise; a
/// snapshot file taken mid-episode gives the same next actions after a load; once env
/// 0's episode ends its noise restarts from the fresh draw (as white noise draws it)
/// while env 1's goes on.
pub fn correlated_exploration_holds_restarts_and_resumes<A: Agent>(make: impl Fn(f32) -> A) {
    let (mut held, mut white) = (make(0.95), make(0.0));
    assert_eq!(
        explore_step(&mut held, false),
        explore_step(&mut white, false)
    );
    let travel = |agent: &mut A| -> f32 {
        let mut prev = explore_step(agent, false);
        (0..200)
            .map(|_| {
                let a = explore_step(agent, false);
                let d = (a[0] - prev[0]).abs();
                prev = a;
                d
            })
            .sum()
    };
    let (h, w) = (travel(&mut held), travel(&mut white));
    assert!(h < 0.5 * w, "held {h}, white {w}");
    let path = std::env::temp_dir().join(format!(
        "correlated-noise-{}-{:?}.bin",
        std::process::id(),
        std::thread::current().id()
    ));
    let mut written = Snapshot::new();
    held.save_state(&mut written);
    written.write(&path).unwrap();
    let snap = Snapshot::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    let (mut resumed, mut fresh) = (make(0.95), make(0.0));
    resumed.load_state(&snap).unwrap();
    fresh.load_state(&snap).unwrap();
    for done in [false, true] {
        assert_eq!(
            explore_step(&mut held, done),
            explore_step(&mut resumed, done)
        );
        explore_step(&mut fresh, done);
    }
    let (r, f) = (
        explore_step(&mut resumed, false),
        explore_step(&mut fresh, false),
    );
    assert_eq!(r[..2], f[..2], "env 0 restarts from the fresh draw");
    assert_ne!(r[2..], f[2..], "env 1 goes on with its process");
}
