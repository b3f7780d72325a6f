//! Episodes as animations: frames drawn by [`foosball_env::render::Renderer`], each with
//! an optional caption band (step, reward, return, "GOAL" while the ball is in black's
//! goal), written as a looping GIF, an H.264 MP4 through ffmpeg, or a PNG still of the
//! last step.

use super::trajectories::Trajectory;
use foosball_env::layout::{BALL_POS, OBS_DIM};
use foosball_env::render::{Frame, Renderer};
use foosball_nets::atomic_file::replace_file;
use plotters::prelude::*;
use std::io::{self, Write};
use std::path::Path;
use std::process::{Command, Stdio};

/// The file kinds an animation can be written as, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// `.gif`: looping, written in-process.
    Gif,
    /// `.mp4`: H.264 through the `ffmpeg` program.
    Mp4,
    /// `.png`: a still of the last step.
    Png,
}

impl Container {
    /// The container `path`'s extension names; the error names the path.
    pub fn of(path: &Path) -> Result<Self, String> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("gif") => Ok(Container::Gif),
            Some("mp4") => Ok(Container::Mp4),
            Some("png") => Ok(Container::Png),
            _ => Err(format!(
                "{}: an episode is written as .gif, .mp4 or .png (a still)",
                path.display()
            )),
        }
    }
}

/// Whether the `ffmpeg` program runs (MP4 output needs it); the error says how to get it.
pub fn ffmpeg_available() -> Result<(), String> {
    match Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(s) if s.success() => Ok(()),
        _ => Err("ffmpeg is not installed (e.g. `apt-get install ffmpeg`): \
                  MP4 needs it; write a .gif instead"
            .into()),
    }
}

/// How episodes are drawn and timed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Animation {
    /// Draws each state.
    pub renderer: Renderer,
    /// Draw every `every`-th step (0 counts as 1).
    pub every: usize,
    /// Hundredths of a second per frame.
    pub delay_cs: u16,
    /// A caption band above the table.
    pub caption: bool,
    /// The caption says "GOAL" while the ball's y is at or past this, cm (the rules'
    /// `reward.goal_line_y`).
    pub goal_line_y: f32,
}

impl Animation {
    /// The frames of `trajectory`: every `every`-th observation acted on, with the reward
    /// that step earned and the return up to it.
    pub fn frames(&self, trajectory: &Trajectory) -> Vec<Frame> {
        let mut ret = 0.0;
        let mut frames = Vec::new();
        for (step, (state, &reward)) in steps(trajectory).enumerate() {
            ret += f64::from(reward);
            if step % self.every.max(1) == 0 {
                frames.push(self.frame(state, step, reward, ret));
            }
        }
        frames
    }

    /// The picture of step `step`'s `state`, captioned with its reward and the return
    /// `ret` up to it when `caption` is set.
    fn frame(&self, state: &[f32; OBS_DIM], step: usize, reward: f32, ret: f64) -> Frame {
        let table = self.renderer.draw(state);
        if self.caption {
            let in_goal = state[BALL_POS.start + 1] >= self.goal_line_y;
            captioned(&table, step, reward, ret, in_goal)
        } else {
            table
        }
    }

    /// Writes `trajectory` to `path` (atomically) as the container its extension names
    /// (a PNG: the last step, whatever `every`).
    pub fn write(&self, path: &Path, trajectory: &Trajectory) -> Result<(), String> {
        let container = Container::of(path)?;
        let frames = match container {
            Container::Png => {
                let ret = trajectory.rewards.iter().map(|&r| f64::from(r)).sum();
                let last = steps(trajectory).enumerate().last();
                last.map(|(step, (state, &reward))| self.frame(state, step, reward, ret))
                    .into_iter()
                    .collect()
            }
            _ => self.frames(trajectory),
        };
        if frames.is_empty() {
            return Err(format!("{}: the episode has no steps", path.display()));
        }
        replace_file(path, |tmp| match container {
            Container::Gif => write_gif(tmp, &frames, self.delay_cs),
            Container::Mp4 => write_mp4(tmp, &frames, self.delay_cs),
            Container::Png => write_png(tmp, &frames[0]),
        })
        .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// `trajectory`'s steps: the 38-dim state acted on and the reward that followed.
fn steps(trajectory: &Trajectory) -> impl Iterator<Item = (&[f32; OBS_DIM], &f32)> {
    trajectory
        .obs
        .chunks_exact(OBS_DIM)
        .map(|row| row.try_into().expect("chunks of OBS_DIM"))
        .zip(&trajectory.rewards)
}

/// `table` below a black band with two lines of text.
fn captioned(table: &Frame, step: usize, reward: f32, ret: f64, in_goal: bool) -> Frame {
    crate::font::register();
    let size = (table.width / 16).clamp(9, 16);
    let band = 2 * size + 6;
    let (width, height) = (table.width, table.height + band);
    let mut rgb = vec![0; width * band * 3];
    rgb.extend_from_slice(&table.rgb);
    let goal = if in_goal { "   GOAL" } else { "" };
    let lines = [
        format!("step {step}   return {ret:.0}"),
        format!("reward {reward:.1}{goal}"),
    ];
    {
        let root =
            BitMapBackend::with_buffer(&mut rgb, (width as u32, height as u32)).into_drawing_area();
        let style = (crate::font::FAMILY, size as u32).into_font().color(&WHITE);
        for (k, line) in lines.iter().enumerate() {
            let at = (3, 2 + (k * (size + 2)) as i32);
            // Text past the right edge is clipped by the backend; nothing else can fail
            // on an in-memory buffer of the right size.
            root.draw(&Text::new(line.as_str(), at, style.clone()))
                .expect("text on an in-memory frame");
        }
        root.present().expect("an in-memory frame");
    }
    Frame { width, height, rgb }
}

fn write_gif(path: &Path, frames: &[Frame], delay_cs: u16) -> io::Result<()> {
    let (w, h) = (frames[0].width as u16, frames[0].height as u16);
    let file = std::fs::File::create(path)?;
    let mut encoder = gif::Encoder::new(file, w, h, &[]).map_err(io::Error::other)?;
    encoder
        .set_repeat(gif::Repeat::Infinite)
        .map_err(io::Error::other)?;
    for f in frames {
        let mut frame = gif::Frame::from_rgb_speed(w, h, &f.rgb, 10);
        frame.delay = delay_cs;
        encoder.write_frame(&frame).map_err(io::Error::other)?;
    }
    Ok(())
}

fn write_png(path: &Path, frame: &Frame) -> io::Result<()> {
    let file = io::BufWriter::new(std::fs::File::create(path)?);
    let mut encoder = png::Encoder::new(file, frame.width as u32, frame.height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(io::Error::other)?;
    writer
        .write_image_data(&frame.rgb)
        .map_err(io::Error::other)?;
    writer.finish().map_err(io::Error::other)
}

/// Pipes raw RGB frames into ffmpeg (odd sizes padded to even, as yuv420p needs).
fn write_mp4(path: &Path, frames: &[Frame], delay_cs: u16) -> io::Result<()> {
    let (w, h) = (frames[0].width, frames[0].height);
    let fps = format!("{}", 100.0 / f64::from(delay_cs.max(1)));
    let mut child = Command::new("ffmpeg")
        .args([
            "-y",
            "-loglevel",
            "error",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
        ])
        .args(["-s", &format!("{w}x{h}"), "-r", &fps, "-i", "-"])
        .args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
        ])
        .args(["-c:v", "libx264", "-f", "mp4"])
        .arg(path)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| io::Error::other(format!("cannot run ffmpeg: {e}")))?;
    let mut stdin = child.stdin.take().expect("piped stdin");
    let written = frames.iter().try_for_each(|f| stdin.write_all(&f.rgb));
    drop(stdin);
    let out = child.wait_with_output()?;
    if !out.status.success() {
        let why = String::from_utf8_lossy(&out.stderr);
        let last = why.lines().last().unwrap_or("no message");
        return Err(io::Error::other(format!("ffmpeg failed: {last}")));
    }
    written
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trajectory(ball_y: f32) -> Trajectory {
        let mut obs = vec![0.0; 3 * OBS_DIM];
        for row in obs.chunks_exact_mut(OBS_DIM) {
            row[BALL_POS.start + 1] = ball_y;
        }
        Trajectory {
            obs,
            actions: vec![0.0; 3 * 8],
            rewards: vec![1000.0, 1300.0, 1300.0],
        }
    }

    fn animation(caption: bool) -> Animation {
        Animation {
            renderer: Renderer::new(3.0),
            every: 2,
            delay_cs: 4,
            caption,
            goal_line_y: 64.0,
        }
    }

    #[test]
    fn captions_sit_in_a_band_above_the_unchanged_table() {
        let t = trajectory(0.0);
        let bare = animation(false).frames(&t);
        let captioned = animation(true).frames(&t);
        assert_eq!((bare.len(), captioned.len()), (2, 2));
        let (b, c) = (&bare[1], &captioned[1]);
        let band = c.height - b.height;
        assert_eq!(band, 2 * 13 + 6);
        assert_eq!(&c.rgb[band * c.width * 3..], &b.rgb[..]);
        let text = c.rgb[..band * c.width * 3]
            .iter()
            .filter(|&&v| v > 128)
            .count();
        assert!(text > 100, "{text} bright bytes in the band");
        // Step 2's return (3600) is not step 0's (1000): the captions differ.
        assert_ne!(
            captioned[0].rgb[..band * c.width * 3],
            c.rgb[..band * c.width * 3]
        );
    }

    #[test]
    fn the_caption_says_goal_while_the_ball_is_in_the_goal() {
        let band = |ball_y: f32| {
            let f = &animation(true).frames(&trajectory(ball_y))[0];
            f.rgb[..(2 * 13 + 6) * f.width * 3].to_vec()
        };
        assert_eq!(band(0.0), band(63.9));
        assert_ne!(band(0.0), band(64.0));
    }

    #[test]
    fn a_png_is_the_last_step() {
        let dir = std::env::temp_dir().join(format!("foosball-still-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("still.png");
        let t = trajectory(66.0);
        animation(true).write(&path, &t).unwrap();
        let decoder = png::Decoder::new(io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut rgb = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut rgb).unwrap();
        let last = Animation {
            every: 1,
            ..animation(true)
        }
        .frames(&t)
        .pop()
        .unwrap();
        assert_eq!(rgb, last.rgb);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_unknown_extension_is_refused_by_name() {
        let e = animation(true)
            .write(Path::new("x/out.bmp"), &trajectory(0.0))
            .unwrap_err();
        assert_eq!(
            e,
            "x/out.bmp: an episode is written as .gif, .mp4 or .png (a still)"
        );
    }
}
