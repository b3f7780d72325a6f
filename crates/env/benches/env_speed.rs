//! Environment speed: `cargo bench -p foosball-env --bench env_speed`.
//!
//! Prints physics steps/s of the bare table, single-env agent steps/s at the default
//! frame_skip (random actions, auto-reset, resets included), and VecEnv agent steps/s on
//! 1 and 2 threads, and rendered frames/s (84 x 84 and 3 px/cm). Wall-clock figures: run on an idle machine. The figures also go to
//! `target/bench/env_speed.json` (`bare_physics_steps_per_s`, `env_loop_physics_steps_per_s`,
//! `env_steps_per_s_frame_skip_1`, `vec_env_speedup_2_threads`,
//! `render_frames_per_s_84x84`, ...); the figures ending in `_locked_axes` are those of
//! `rod_mount = "locked_axes"`; `env_steps_per_s_frame_skip_1_rigid_contacts` that of
//! `man_contacts = "rapier"` (the `reference_v3` game's), `..._sdf_contacts` that of
//! `man_contacts = "mujoco_sdf"` (the model's own contact search on the sampled field,
//! `reference_v5`'s) and `..._octree_contacts` that of `man_contacts = "mujoco_octree"`
//! (the same search on the plugin's own octree, `reference`'s).

use std::hint::black_box;
use std::time::{Duration, Instant};

use foosball_env::config::ManContacts;
use foosball_env::geometry::BALL_RADIUS;
use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::observation::{FrameStack, to_bytes};
use foosball_env::render::Renderer;
use foosball_env::table::{PhysicsParams, Table};
use foosball_env::{
    EndReason, Env, EnvRng, FoosballConfig, FoosballEnv, ObservationConfig, ObservationKind,
    RodMount, VecEnv,
};
use rand::{Rng, SeedableRng};

#[path = "../../../benches/figures.rs"]
mod figures;

const BUDGET: Duration = Duration::from_secs(3);

/// Runs `f` repeatedly for about BUDGET; returns calls per second.
fn rate(mut f: impl FnMut()) -> f64 {
    for _ in 0..100 {
        f(); // warm-up
    }
    let start = Instant::now();
    let mut n = 0u64;
    while start.elapsed() < BUDGET {
        for _ in 0..100 {
            f();
        }
        n += 100;
    }
    n as f64 / start.elapsed().as_secs_f64()
}

fn random_actions(rng: &mut EnvRng, n: usize) -> Vec<f32> {
    (0..n * ACTION_DIM)
        .map(|_| rng.random_range(-1.0..=1.0))
        .collect()
}

/// Physics steps/s of a bare table built with `params`: the ball rolling about, every
/// servo holding a target.
fn bare_physics(params: &PhysicsParams) -> f64 {
    let mut table = Table::new(params, [-0.5, -0.1]);
    table.set_ball([-30.0, -40.0, BALL_RADIUS], [0.0, 150.0, 0.0]);
    for i in 0..8 {
        table.set_target(i, 3.0, 0.5);
    }
    rate(|| table.step())
}

/// Env steps/s of one env under `config` with random actions, resets included; prints
/// the figure with the episodes' mean length and how many ended stagnant.
fn env_loop(config: FoosballConfig) -> f64 {
    let frame_skip = config.frame_skip;
    let mut env = FoosballEnv::new(config).unwrap();
    env.reset(Some(0));
    let mut rng = EnvRng::seed_from_u64(1);
    let (mut episodes, mut steps, mut stagnant) = (0u64, 0u64, 0u64);
    let per_s = rate(|| {
        let a = random_actions(&mut rng, 1);
        let (_, t) = env.step(&a).unwrap();
        steps += 1;
        if t.done() {
            env.reset(None);
            episodes += 1;
            stagnant += u64::from(t.info.end == Some(EndReason::Stagnant));
        }
    });
    println!(
        "env steps/s, frame_skip {frame_skip} (random actions, resets incl.): {per_s:>10.0}  ({:.0} physics steps/s, {:.1} steps/episode, {:.0}% of episodes end stagnant)",
        per_s * frame_skip as f64,
        steps as f64 / episodes.max(1) as f64,
        100.0 * stagnant as f64 / episodes.max(1) as f64
    );
    per_s
}

fn main() {
    let config = FoosballConfig::default();
    let params = PhysicsParams::nominal(&config);

    let mut out: Vec<(String, f64)> = Vec::new();
    let physics = bare_physics(&params);
    out.push(("bare_physics_steps_per_s".into(), physics));
    println!("physics steps/s (one table, 1 thread):            {physics:>10.0}");

    let build = rate(|| {
        black_box(Table::new(&params, [0.0, 0.0]));
    });
    println!("table builds/s (one reset's world construction):  {build:>10.0}");
    out.push(("table_builds_per_s".into(), build));

    // The default preset (`reference`) acts every physics step; the paper presets every 5.
    for frame_skip in [1, 2, 5, 10] {
        let c = FoosballConfig {
            frame_skip,
            ..config.clone()
        };
        let per_s = env_loop(c);
        out.push((format!("env_steps_per_s_frame_skip_{frame_skip}"), per_s));
        out.push((
            format!("env_loop_physics_steps_per_s_frame_skip_{frame_skip}"),
            per_s * frame_skip as f64,
        ));
        if frame_skip == config.frame_skip {
            out.push((
                "env_loop_physics_steps_per_s".into(),
                per_s * frame_skip as f64,
            ));
        }
    }

    // The other contact models at frame skip 1: rapier's (`reference_v3`) and the model's
    // own contact search on its man's sampled field and on its octree.
    for (man_contacts, name, figure) in [
        (ManContacts::Rapier, "rapier", "rigid_contacts"),
        (ManContacts::MujocoSdf, "mujoco_sdf", "sdf_contacts"),
        (
            ManContacts::MujocoOctree,
            "mujoco_octree",
            "octree_contacts",
        ),
    ] {
        print!("man_contacts {name}: ");
        let per_s = env_loop(FoosballConfig {
            man_contacts,
            ..config.clone()
        });
        out.push((format!("env_steps_per_s_frame_skip_1_{figure}"), per_s));
    }

    // The other rod mount: the bare table and the env loop at frame skips 1 and 5.
    let locked = FoosballConfig {
        rod_mount: RodMount::LockedAxes,
        ..config.clone()
    };
    let physics = bare_physics(&PhysicsParams::nominal(&locked));
    out.push(("bare_physics_steps_per_s_locked_axes".into(), physics));
    println!("physics steps/s, rod_mount locked_axes:           {physics:>10.0}");
    for frame_skip in [1, 5] {
        let c = FoosballConfig {
            frame_skip,
            ..locked.clone()
        };
        print!("rod_mount locked_axes: ");
        let per_s = env_loop(c);
        out.push((
            format!("env_steps_per_s_frame_skip_{frame_skip}_locked_axes"),
            per_s,
        ));
    }

    // Rendering: states from a random-action episode, drawn as 84 x 84 frames (image
    // observations' size) and at the GIFs' 3 px/cm.
    let mut env = FoosballEnv::new(config.clone()).unwrap();
    let mut rng = EnvRng::seed_from_u64(3);
    let mut states: Vec<[f32; OBS_DIM]> = vec![env.reset(Some(3)).try_into().unwrap()];
    while states.len() < 200 {
        let (obs, t) = env.step(&random_actions(&mut rng, 1)).unwrap();
        states.push(obs.try_into().unwrap());
        if t.done() {
            env.reset(None);
        }
    }
    for (name, renderer) in [
        ("render_frames_per_s_84x84", Renderer::fit(84, 84)),
        ("render_frames_per_s_3px_per_cm", Renderer::new(3.0)),
    ] {
        let mut k = 0;
        let per_s = rate(|| {
            black_box(renderer.draw(&states[k % states.len()]));
            k += 1;
        });
        let (w, h) = renderer.size();
        println!("rendered frames/s, {w} x {h} (1 thread):            {per_s:>10.0}");
        out.push((name.into(), per_s));
    }

    // Image observations (84 x 84 grey, 4 frames) against the state, default preset.
    let image = FoosballConfig {
        observation: ObservationConfig {
            kind: ObservationKind::Image,
            ..ObservationConfig::default()
        },
        ..config.clone()
    };
    // What handing out image observations as f32 costs: one stack of 84 x 84 x 4 bytes
    // written as `byte / 255` (the env's output), and read back to bytes (the replay
    // buffer's input), each against a plain byte copy of the same stack.
    let mut stack = FrameStack::new(image.observation);
    stack.reset(&states[0]);
    let mut floats = vec![0.0_f32; image.observation.dim()];
    let bytes = to_bytes(&floats);
    let mut copy = vec![0_u8; bytes.len()];
    for (name, per_s) in [
        (
            "frame_stack_writes_per_s_84x84x4_f32",
            rate(|| stack.write(black_box(&mut floats))),
        ),
        (
            "frame_stack_reads_per_s_84x84x4_to_bytes",
            rate(|| drop(black_box(to_bytes(&floats)))),
        ),
        (
            "frame_stack_copies_per_s_84x84x4_bytes",
            rate(|| copy.copy_from_slice(black_box(&bytes))),
        ),
    ] {
        println!("{name}: {per_s:>10.0} ({:.2} us each)", 1e6 / per_s);
        out.push((name.into(), per_s));
    }

    for (name, c) in [("state", config.clone()), ("image_84x84x4", image)] {
        let mut env = FoosballEnv::new(c).unwrap();
        let mut obs = vec![0.0; env.obs_dim()];
        env.reset_into(Some(0), &mut obs);
        let mut rng = EnvRng::seed_from_u64(4);
        let per_s = rate(|| {
            let a = random_actions(&mut rng, 1);
            if env.step_into(&a, &mut obs).unwrap().done() {
                env.reset_into(None, &mut obs);
            }
        });
        println!("env steps/s, {name} observations (1 thread):     {per_s:>10.0}");
        out.push((format!("env_steps_per_s_{name}_obs"), per_s));
    }

    let n = 16;
    let mut results = Vec::new();
    for threads in [1, 2] {
        let envs = (0..n)
            .map(|_| FoosballEnv::new(config.clone()).unwrap())
            .collect();
        let mut venv = VecEnv::new(envs, threads).unwrap();
        venv.reset(0);
        let mut rng = EnvRng::seed_from_u64(2);
        let batches = rate(|| {
            let a = random_actions(&mut rng, n);
            venv.step(&a).unwrap();
        });
        let per_s = batches * n as f64;
        results.push(per_s);
        println!("VecEnv ({n} envs) env steps/s, {threads} thread(s):       {per_s:>10.0}");
        out.push((format!("vec_env_steps_per_s_{threads}_threads"), per_s));
    }
    println!(
        "VecEnv speed-up 2 vs 1 threads:                   {:>10.2}x",
        results[1] / results[0]
    );
    out.push(("vec_env_speedup_2_threads".into(), results[1] / results[0]));
    println!(
        "figures in {}",
        figures::write_figures("env_speed", &out).display()
    );
}
