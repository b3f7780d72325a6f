//! `render`: episodes as captioned animations (GIF, MP4 through ffmpeg, a PNG still of
//! the last step), drawn top-down
//! by `foosball_env::render`: recorded ones (a `trajectories.bin`, or a run's test) or
//! played live by a run's saved networks, a scripted policy, an ONNX file or a program.

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::RunConfig;
use foosball_rl::env::geometry::GOAL_LINE_Y;
use foosball_rl::env::render::Renderer;
use foosball_rl::play::animation::{Animation, Container, ffmpeg_available};
use foosball_rl::play::contestant::is_onnx;
use foosball_rl::play::player::{Player, PlayerArgs};
use foosball_rl::play::trajectories::{RecordedEpisode, by_return, read_trajectories};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Turn episodes into animations: recorded ones (`--trajectories FILE`, or `--run RUN`
/// for its test) or played live (`--run RUN --checkpoint best|last`, `--policy NAME`).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// A `trajectories.bin` (e.g. `RUN/test/trajectories.bin`).
    #[arg(long, conflicts_with_all = ["run", "policy"])]
    trajectories: Option<PathBuf>,
    #[command(flatten)]
    player: PlayerArgs,
    /// Live play (`--checkpoint` or `--policy`): test episodes to play and pick from.
    #[arg(long, default_value_t = 10)]
    play: u32,
    /// Episodes by index, e.g. `0,5,9`.
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["best", "worst"])]
    episodes: Option<Vec<usize>>,
    /// The N episodes of highest return.
    #[arg(long, value_name = "N", conflicts_with = "worst")]
    best: Option<usize>,
    /// The N episodes of lowest return.
    #[arg(long, value_name = "N", conflicts_with = "scored")]
    worst: Option<usize>,
    /// The first N episodes in which the ball entered black's goal.
    #[arg(long, value_name = "N", conflicts_with_all = ["episodes", "best"])]
    scored: Option<usize>,
    /// Pixels per cm.
    #[arg(long, default_value_t = 3.0)]
    scale: f32,
    /// Draw every Nth step.
    #[arg(long, default_value_t = 5)]
    every: usize,
    /// Delay between frames, hundredths of a second.
    #[arg(long, default_value_t = 4)]
    delay_cs: u16,
    /// Leave out the caption (step, reward, return, goal).
    #[arg(long)]
    no_caption: bool,
    /// A `.gif` or `.mp4` file, or a `.png` still of the last step (with several
    /// episodes, `<stem>-<index>.<ext>` each), or a folder of `episode-<index>.gif`.
    #[arg(long, default_value = "render")]
    out: PathBuf,
}

/// Recorded or played episodes, where they come from, and the goal line of their rules.
struct Source {
    episodes: Vec<RecordedEpisode>,
    name: String,
    goal_line_y: f32,
}

/// The episodes to pick from: a trajectories file (the rules of the run it lies in, if
/// any, else the paper's goal line), a run's test, or live play.
fn episodes(args: &Args) -> Result<Source, String> {
    let recorded = match (&args.trajectories, &args.player) {
        (Some(file), _) => Some(file.clone()),
        (
            None,
            PlayerArgs {
                run: Some(run),
                checkpoint: None,
                actions: None,
                stochastic: false,
                ..
            },
        ) if !is_onnx(run) => Some(run.join("test/trajectories.bin")),
        _ => None,
    };
    if let Some(file) = recorded {
        if !file.is_file() {
            return Err(format!(
                "{}: no recorded episodes (a run's test writes them; \
                 `--checkpoint last` plays new ones with its networks)",
                file.display()
            ));
        }
        let run = file.parent().and_then(Path::parent);
        let goal_line_y = match run.map(RunConfig::load_run) {
            Some(Ok(config)) => config.env.reward.goal_line_y,
            _ => GOAL_LINE_Y,
        };
        return Ok(Source {
            episodes: read_trajectories(&file)?,
            name: file.display().to_string(),
            goal_line_y,
        });
    }
    if args.play == 0 {
        return Err("--play must be positive".into());
    }
    let player = Player::from_args(&args.player)?;
    let played = player.play(args.play, true)?;
    let episodes = played
        .into_iter()
        .map(|e| RecordedEpisode {
            seed: e.seed,
            trajectory: e.trajectory.expect("recorded"),
        })
        .collect();
    Ok(Source {
        episodes,
        name: format!("{} test episodes of {}", args.play, player.describe()),
        goal_line_y: player.env().reward.goal_line_y,
    })
}

/// Indices of the episodes to draw.
fn pick(args: &Args, episodes: &[RecordedEpisode], goal_line_y: f32) -> Result<Vec<usize>, String> {
    let by_return = by_return(episodes);
    let picked = match (&args.episodes, args.best, args.worst, args.scored) {
        (Some(list), ..) => list.clone(),
        (None, Some(n), ..) => by_return.into_iter().take(n).collect(),
        (None, None, Some(n), _) => by_return.into_iter().rev().take(n).collect(),
        (None, None, None, Some(n)) => {
            let scored: Vec<usize> = (0..episodes.len())
                .filter(|&i| episodes[i].scored(goal_line_y))
                .take(n)
                .collect();
            if scored.is_empty() {
                return Err(format!("--scored: no episode of {} scored", episodes.len()));
            }
            scored
        }
        (None, None, None, None) => vec![0],
    };
    match picked.iter().find(|&&i| i >= episodes.len()) {
        Some(i) => Err(format!(
            "--episodes: episode {i} is out of range ({} episodes)",
            episodes.len()
        )),
        None => Ok(picked),
    }
}

/// Where episode `index` goes: `--out` itself for one episode into a file (`is_file`:
/// its extension names a [`Container`]), a numbered sibling for several, or
/// `episode-<index>.gif` in the `--out` folder.
fn target(out: &Path, is_file: bool, index: usize, several: bool) -> PathBuf {
    match (is_file, several) {
        (true, false) => out.to_path_buf(),
        (true, true) => {
            fn part(p: Option<&std::ffi::OsStr>) -> &str {
                p.and_then(|s| s.to_str()).unwrap_or("")
            }
            let (stem, ext) = (part(out.file_stem()), part(out.extension()));
            out.with_file_name(format!("{stem}-{index}.{ext}"))
        }
        (false, _) => out.join(format!("episode-{index}.gif")),
    }
}

fn run(args: &Args) -> Result<String, String> {
    if !(args.scale > 0.0 && args.scale <= 20.0) || args.every == 0 {
        return Err(format!(
            "--scale must be in (0, 20] and --every positive, got {} and {}",
            args.scale, args.every
        ));
    }
    let container = Container::of(&args.out).ok();
    let is_file = container.is_some();
    if container == Some(Container::Mp4) {
        ffmpeg_available()?;
    }
    let Source {
        episodes,
        name: source,
        goal_line_y,
    } = episodes(args)?;
    if episodes.is_empty() {
        return Err(format!("{source}: no episodes"));
    }
    let picked = pick(args, &episodes, goal_line_y)?;
    let folder = if is_file {
        args.out.parent().unwrap_or(Path::new("."))
    } else {
        &args.out
    };
    if !folder.as_os_str().is_empty() {
        std::fs::create_dir_all(folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    }
    let animation = Animation {
        renderer: Renderer::new(args.scale),
        every: args.every,
        delay_cs: args.delay_cs,
        caption: !args.no_caption,
        goal_line_y,
    };
    let mut written = vec![format!("from {source}:")];
    for &index in &picked {
        let t = &episodes[index].trajectory;
        let path = target(&args.out, is_file, index, picked.len() > 1);
        animation.write(&path, t)?;
        written.push(format!(
            "{} (episode {index}: {} steps, return {:.0}, seed {})",
            path.display(),
            t.rewards.len(),
            episodes[index].ret(),
            episodes[index].seed
        ));
    }
    Ok(written.join("\n"))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
