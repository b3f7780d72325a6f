//! Image observations: shape, value range and exact bytes, the frame stack's order, the
//! picture matching the table's state, determinism in VecEnv whatever the thread count,
//! bad settings refused by key, a tiny run trained on pixels through a CNN end to end, and
//! a pixel learner taught by a state teacher (a run's networks reading the state behind
//! each picture).

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_rl::config::RunConfig;
use foosball_rl::env::foosball::in_ball_frame;
use foosball_rl::env::layout::ACTION_DIM;
use foosball_rl::env::observation::{channel_first, to_bytes};
use foosball_rl::env::render::Renderer;
use foosball_rl::env::{
    Env, FoosballConfig, FoosballEnv, ObservationConfig, ObservationKind, VecEnv,
};
use std::path::Path;
use std::process::Command;

fn image_config(width: u32, height: u32, grayscale: bool, frame_stack: u32) -> FoosballConfig {
    FoosballConfig {
        observation: ObservationConfig {
            kind: ObservationKind::Image,
            width,
            height,
            grayscale,
            frame_stack,
            hide_black_rods: false,
        },
        ..FoosballConfig::default()
    }
}

/// A fixed sequence of commands that moves every rod.
fn action(t: usize) -> [f32; ACTION_DIM] {
    std::array::from_fn(|k| ((t + k) as f32 * 0.7).sin())
}

#[test]
fn an_image_observation_is_the_stack_of_pictures_of_the_state() {
    let (w, h, stack) = (40, 60, 3);
    let mut env = FoosballEnv::new(image_config(w, h, true, stack)).unwrap();
    let frame = (w * h) as usize;
    assert_eq!(env.obs_dim(), stack as usize * frame);
    let renderer = Renderer::fit(w as usize, h as usize);
    let picture = |env: &FoosballEnv| channel_first(&renderer.draw(env.state().unwrap()), true);

    let first = env.reset(Some(7));
    assert_eq!(first.len(), env.obs_dim());
    let bytes = to_bytes(&first);
    assert!(
        first
            .iter()
            .zip(&bytes)
            .all(|(&v, &b)| v == f32::from(b) / 255.0)
    );
    // A reset fills every slot with the first picture.
    for k in 0..stack as usize {
        assert_eq!(&bytes[k * frame..(k + 1) * frame], &picture(&env)[..]);
    }
    let mut previous = bytes;
    let mut moved = false;
    for t in 0..6 {
        let (obs, tr) = env.step(&action(t)).unwrap();
        assert!(!tr.done());
        let now = to_bytes(&obs);
        // Oldest first: the stack shifts by one frame and the newest is the state's.
        assert_eq!(&now[..2 * frame], &previous[frame..]);
        assert_eq!(&now[2 * frame..], &picture(&env)[..]);
        moved |= now[2 * frame..] != previous[2 * frame..];
        previous = now;
    }
    assert!(moved, "six steps of moving rods changed no pixel");
}

#[test]
fn colour_frames_have_three_channels_and_repeat_from_a_seed() {
    let config = image_config(24, 36, false, 2);
    let mut a = FoosballEnv::new(config.clone()).unwrap();
    let mut b = FoosballEnv::new(config).unwrap();
    assert_eq!(a.obs_dim(), 2 * 3 * 24 * 36);
    assert_eq!(a.reset(Some(3)), b.reset(Some(3)));
    for t in 0..5 {
        assert_eq!(a.step(&action(t)).unwrap().0, b.step(&action(t)).unwrap().0);
    }
}

#[test]
fn image_batches_do_not_depend_on_the_thread_count() {
    let config = image_config(16, 24, true, 2);
    let run = |threads: usize| {
        let envs = (0..3)
            .map(|_| FoosballEnv::new(config.clone()).unwrap())
            .collect();
        let mut venv = VecEnv::new(envs, threads).unwrap();
        let mut out = venv.reset(11).to_vec();
        for t in 0..20 {
            let actions: Vec<f32> = (0..3).flat_map(|i| action(t + i)).collect();
            out.extend_from_slice(venv.step(&actions).unwrap().obs);
        }
        out
    };
    let one = run(1);
    assert_eq!(one.len(), 21 * 3 * 2 * 16 * 24);
    assert_eq!(run(2), one);
}

#[test]
fn bad_observation_settings_are_refused_by_key() {
    let e = FoosballEnv::new(image_config(0, 84, true, 4))
        .err()
        .unwrap();
    assert_eq!(e.key, "observation.width");
    let e = FoosballEnv::new(image_config(84, 84, true, 99))
        .err()
        .unwrap();
    assert_eq!(e.key, "observation.frame_stack");
    let e = toml::from_str::<FoosballConfig>("[observation]\nkind = \"pixels\"\n").unwrap_err();
    assert!(
        e.message().contains("unknown variant `pixels`"),
        "{}",
        e.message()
    );
}

#[test]
fn a_tiny_run_trains_on_pixels_and_records_states() {
    let dir = scratch("image-train");
    let config = dir.join("sac-image.toml");
    let image = "[env.observation]\nkind = \"image\"\nwidth = 12\nheight = 20\nframe_stack = 2\n";
    // SB3's NatureCNN needs at least 36 x 36 pixels: refused by key.
    std::fs::write(&config, tiny_config_text("sac", 1, 150) + image).unwrap();
    let e = RunConfig::load(&config).unwrap_err().to_string();
    assert!(
        e.contains("sac.net.cnn: convs[1]: a 4x4 kernel does not fit the 4x2 input of this layer (image 20x12)"),
        "{e}"
    );
    let small_cnn =
        "[sac.net.cnn]\nconvs = [{ channels = 4, kernel = 3, stride = 2 }]\nfeatures = 16\n";
    std::fs::write(&config, tiny_config_text("sac", 1, 150) + image + small_cnn).unwrap();
    let run = dir.join("run");
    let o = Command::new(env!("CARGO_BIN_EXE_train"))
        .args([
            "--config",
            config.to_str().unwrap(),
            "--out",
            run.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let saved = RunConfig::load_run(&run).unwrap();
    assert_eq!(saved.env.observation.dim(), 2 * 12 * 20);
    // The test's trajectories hold the table's 38-dim states, not the pixels.
    let episodes =
        foosball_rl::play::trajectories::read_trajectories(&run.join("test/trajectories.bin"))
            .unwrap();
    assert_eq!(episodes.len(), 3);
    for e in &episodes {
        assert_eq!(e.trajectory.obs.len(), 38 * e.trajectory.rewards.len());
    }
    // A scripted policy cannot read pixels: refused by key.
    let o = Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .args(["--policy", "shooter", "--config", config.to_str().unwrap()])
        .args(["--episodes", "1", "--out", dir.join("b").to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("env.observation.kind: shooter reads the 38-dim state"),
        "{err}"
    );
    assert!(!Path::new(&dir.join("b/metrics.json")).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A teacher reads, behind each picture, the state it was drawn from in the env's ball
/// frame; a state observation is already what a teacher reads.
#[test]
fn a_teacher_reads_the_state_behind_each_picture() {
    let config = image_config(24, 36, true, 2);
    let mut env = FoosballEnv::new(config.clone()).unwrap();
    assert_eq!(env.teacher_view(), None, "nothing drawn before a reset");
    env.reset(Some(3));
    for t in 0..5 {
        let state = env.state().unwrap();
        let view = in_ball_frame(state, config.ball_frame);
        assert_eq!(env.teacher_view(), Some(&view[..]), "step {t}");
        env.step(&action(t)).unwrap();
    }
    let mut state_env = FoosballEnv::new(FoosballConfig::default()).unwrap();
    state_env.reset(Some(3));
    assert_eq!(state_env.teacher_view(), None);
}

/// A pixel learner taught by a state teacher (issue 92): a tiny state run's networks
/// label, through `[ppo.kickstart]`, the states behind the pictures the learner acts on
/// (pixel rows would not even split into states); under the shooter's labels the cloning
/// term falls to half within 8,000 steps. Teachers that draw their actions or do not
/// exist are refused by key.
#[test]
fn a_pixel_learner_clones_a_state_teacher() {
    let dir = scratch("pixel-student");
    let teacher = dir.join("teacher");
    let state_config = dir.join("teacher.toml");
    std::fs::write(&state_config, tiny_config_text("ppo", 1, 128)).unwrap();
    let train = |config: &Path, out: &Path| {
        Command::new(env!("CARGO_BIN_EXE_train"))
            .args(["--config", config.to_str().unwrap()])
            .args(["--out", out.to_str().unwrap(), "--force"])
            .output()
            .unwrap()
    };
    let o = train(&state_config, &teacher);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let student = |teacher: &str, steps: u64| {
        tiny_config_text("ppo", 1, steps).replace(
            "n_epochs = 2\n",
            "n_epochs = 2\npg_coef = 0.0\nlog_std_init = -2.0\n",
        ) + "lr = { constant = 3e-3 }\n\
               [ppo.net.cnn]\nconvs = [{ channels = 4, kernel = 4, stride = 2 }]\nfeatures = 16\n\
               [env.observation]\nkind = \"image\"\nwidth = 16\nheight = 24\nframe_stack = 2\n\
               [ppo.kickstart]\ncoef_start = 1.0\ncoef_end = 1.0\nteacher = \""
            + teacher
            + "\"\n"
    };
    let config = dir.join("student.toml");
    let losses = |teacher: &str, steps: u64| -> Vec<f64> {
        let run = dir.join("student");
        std::fs::write(&config, student(teacher, steps)).unwrap();
        let o = train(&config, &run);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(run.join("test/metrics.json").is_file());
        let scalars = std::fs::read_to_string(run.join("scalars.csv")).unwrap();
        (scalars.lines())
            .filter(|l| l.contains(",train/kickstart_loss,"))
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    };
    assert_eq!(losses(teacher.to_str().unwrap(), 1000).len(), 1);
    let shooter = losses("shooter", 8000);
    assert_eq!(shooter.len(), 8);
    let (first, last) = (shooter[0], shooter[7]);
    assert!(
        last < 0.5 * first,
        "cloning term {first} -> {last}: {shooter:?}"
    );

    for (name, why) in [
        (
            format!("{}~sampled", teacher.display()),
            "draws its actions",
        ),
        ("no/such/run".to_string(), "has no config.toml"),
    ] {
        std::fs::write(&config, student(&name, 1000)).unwrap();
        let o = train(&config, &dir.join("refused"));
        assert_eq!(o.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("ppo.kickstart.teacher: ") && err.contains(why),
            "{name}: {err}"
        );
    }
}
