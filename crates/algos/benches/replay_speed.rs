//! The replay buffer with image observations (84 x 84 grey, 4 frames, foosball's default
//! image settings): transitions pushed and minibatches of 256 sampled per second, and the
//! bytes a row's observations hold.
//!
//! `cargo bench -p foosball-algos --bench replay_speed`; the figures also go to
//! `target/bench/replay_speed.json`.

use foosball_algos::ReplayBuffer;
use foosball_env::{Env, EnvRng, FoosballConfig, FoosballEnv, ObservationConfig, ObservationKind};
use foosball_nets::ObsShape;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};

#[path = "../../../benches/figures.rs"]
mod figures;

/// Transitions recorded from the table, and the buffer's rows.
const ROWS: usize = 2_000;
const ACT: usize = 8;

/// Calls of `f` per second over about two seconds.
fn rate(mut f: impl FnMut()) -> f64 {
    let start = Instant::now();
    let mut n = 0u64;
    while start.elapsed() < Duration::from_secs(2) {
        f();
        n += 1;
    }
    n as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    let observation = ObservationConfig {
        kind: ObservationKind::Image,
        ..ObservationConfig::default()
    };
    let mut env = FoosballEnv::new(FoosballConfig {
        observation,
        ..FoosballConfig::default()
    })
    .unwrap();
    let o = env.obs_dim();
    let mut rng = EnvRng::seed_from_u64(0);
    let mut obs = env.reset(Some(0));
    let mut steps: Vec<(Vec<f32>, Vec<f32>)> = Vec::with_capacity(ROWS);
    while steps.len() < ROWS {
        let action: Vec<f32> = (0..ACT).map(|_| rng.random_range(-1.0..=1.0)).collect();
        let (next, t) = env.step(&action).unwrap();
        steps.push((obs, next.clone()));
        obs = if t.done() { env.reset(None) } else { next };
    }
    let shape = ObsShape::Image {
        channels: observation.channels(),
        height: observation.height as usize,
        width: observation.width as usize,
    };
    let mut buffer = ReplayBuffer::for_obs(ROWS, shape, ACT);
    let action = [0.0_f32; ACT];
    let mut k = 0;
    let push_per_s = rate(|| {
        let (obs, next) = &steps[k % ROWS];
        buffer.push(obs, &action, 0.0, next, false, false);
        k += 1;
    });
    let mut sample_rng = ChaCha8Rng::seed_from_u64(1);
    let sample_per_s = rate(|| drop(std::hint::black_box(buffer.sample(256, &mut sample_rng))));
    let bytes_per_row = buffer.observation_bytes() as f64 / buffer.len() as f64;
    let figures = vec![
        ("replay_image_pushes_per_s_84x84x4".to_string(), push_per_s),
        (
            "replay_image_samples_per_s_256x84x84x4".to_string(),
            sample_per_s,
        ),
        (
            "replay_image_bytes_per_row_84x84x4".to_string(),
            bytes_per_row,
        ),
    ];
    for (name, value) in &figures {
        println!("{name}: {value:.1}");
    }
    println!("obs values per observation: {o}");
    println!(
        "figures: {}",
        figures::write_figures("replay_speed", &figures).display()
    );
}
