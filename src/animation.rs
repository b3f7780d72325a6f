//! Episodes as animated GIFs, drawn by [`foosball_env::render::Renderer`].

use crate::evaluation::Trajectory;
use foosball_env::layout::OBS_DIM;
use foosball_env::render::{Frame, Renderer};
use foosball_nets::atomic_file::replace_file;
use std::path::Path;

/// Writes every `every`-th step of `trajectory` as a looping GIF to `path` (atomically),
/// `delay_cs` hundredths of a second per frame.
pub fn episode_gif(
    path: &Path,
    trajectory: &Trajectory,
    renderer: &Renderer,
    every: usize,
    delay_cs: u16,
) -> Result<(), String> {
    let frames: Vec<Frame> = trajectory
        .obs
        .chunks_exact(OBS_DIM)
        .step_by(every.max(1))
        .map(|row| renderer.draw(row.try_into().expect("chunks of OBS_DIM")))
        .collect();
    if frames.is_empty() {
        return Err(format!("{}: the episode has no steps", path.display()));
    }
    replace_file(path, |tmp| {
        let (w, h) = (frames[0].width as u16, frames[0].height as u16);
        let file = std::fs::File::create(tmp)?;
        let mut encoder = gif::Encoder::new(file, w, h, &[]).map_err(std::io::Error::other)?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(std::io::Error::other)?;
        for f in &frames {
            let mut frame = gif::Frame::from_rgb_speed(w, h, &f.rgb, 10);
            frame.delay = delay_cs;
            encoder.write_frame(&frame).map_err(std::io::Error::other)?;
        }
        Ok(())
    })
    .map_err(|e| format!("{}: {e}", path.display()))
}
