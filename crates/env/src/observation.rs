//! What the agent observes: the 38-dim state vector, or top-down pictures of the table
//! drawn by [`crate::render::Renderer`] and stacked over the last few steps.
//!
//! An image observation is `[frame_stack * channels, height, width]`, channel-first (the
//! layout of PyTorch and of SB3 after `VecTransposeImage`), oldest frame first, a
//! channel being luma (`grayscale`, ITU-R BT.601 weights) or R, G, B. Pixels are bytes;
//! the env hands them out as `f32` in `[0, 1]` (`byte / 255`, exactly invertible, so
//! buffers can store the bytes, see [`to_bytes`]). A reset fills the stack with the first
//! frame (as SB3's `VecFrameStack` after its zero fill is overwritten on the first step).

use serde::{Deserialize, Serialize};

use crate::config_error::ConfigError;
use crate::layout::{OBS_DIM, black_rod_inputs};
use crate::render::{Frame, Renderer};

/// The kind of observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObservationKind {
    /// The 38-dim state (positions cm, angles rad, velocities per s).
    #[default]
    State,
    /// Stacked top-down frames.
    Image,
}

/// `[env.observation]`: the kind and, for images, their size, colour and stack depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObservationConfig {
    /// `state` or `image`.
    pub kind: ObservationKind,
    /// Frame width, pixels (the table is stretched to fill the frame).
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// One luma channel instead of three colour channels.
    pub grayscale: bool,
    /// Frames stacked, oldest first.
    pub frame_stack: u32,
    /// State only: black's 16 rod values (slides, slide velocities, angles, angular
    /// velocities; [`crate::layout::black_rod_inputs`]) read 0, so the policy plays on the
    /// ball and its own rods and is never thrown by opponents' rods it did not train
    /// against. Opponents still see the whole table.
    pub hide_black_rods: bool,
}

impl Default for ObservationConfig {
    /// The state; image settings as SB3's Atari defaults (84 x 84, grey, 4 frames).
    fn default() -> Self {
        Self {
            kind: ObservationKind::State,
            width: 84,
            height: 84,
            grayscale: true,
            frame_stack: 4,
            hide_black_rods: false,
        }
    }
}

/// The largest frame side, pixels.
pub const MAX_SIDE: u32 = 512;
/// The deepest frame stack.
pub const MAX_STACK: u32 = 16;

impl ObservationConfig {
    /// Channels of one frame: 1 (grey) or 3 (RGB).
    pub fn frame_channels(&self) -> usize {
        if self.grayscale { 1 } else { 3 }
    }

    /// Channels of an image observation: `frame_stack * frame_channels`.
    pub fn channels(&self) -> usize {
        self.frame_stack as usize * self.frame_channels()
    }

    /// Length of one observation: 38, or `channels * height * width`.
    pub fn dim(&self) -> usize {
        match self.kind {
            ObservationKind::State => OBS_DIM,
            ObservationKind::Image => self.channels() * self.height as usize * self.width as usize,
        }
    }

    /// Hides from a state observation (38 values) what `hide_black_rods` hides: black's
    /// rod values set to 0; nothing otherwise.
    pub fn conceal(&self, state: &mut [f32]) {
        if self.hide_black_rods {
            black_rod_inputs().for_each(|i| state[i] = 0.0);
        }
    }

    /// Checks the image settings (also under `state`, so a file stays valid when its
    /// kind is switched); keys relative to the section.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (key, side) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_SIDE).contains(&side) {
                return Err(ConfigError::new(
                    key,
                    format!("must be 1 to {MAX_SIDE} pixels, got {side}"),
                ));
            }
        }
        if !(1..=MAX_STACK).contains(&self.frame_stack) {
            return Err(ConfigError::new(
                "frame_stack",
                format!("must be 1 to {MAX_STACK} frames, got {}", self.frame_stack),
            ));
        }
        if self.hide_black_rods && self.kind == ObservationKind::Image {
            return Err(ConfigError::new(
                "hide_black_rods",
                "hides values of the state observation; pictures show every rod",
            ));
        }
        Ok(())
    }
}

/// An image observation being built: the renderer and the last `frame_stack` frames as
/// channel-first bytes.
#[derive(Debug, Clone)]
pub struct FrameStack {
    config: ObservationConfig,
    renderer: Renderer,
    /// `[frame_stack][frame_channels * height * width]`, oldest first.
    frames: Vec<Vec<u8>>,
}

impl FrameStack {
    /// An empty stack for `config` (an image kind).
    pub fn new(config: ObservationConfig) -> Self {
        Self {
            config,
            renderer: Renderer::fit(config.width as usize, config.height as usize),
            frames: Vec::new(),
        }
    }

    /// The frame of `state` as channel-first bytes.
    pub fn picture(&self, state: &[f32; OBS_DIM]) -> Vec<u8> {
        channel_first(&self.renderer.draw(state), self.config.grayscale)
    }

    /// Starts an episode: every slot holds the picture of `state`.
    pub fn reset(&mut self, state: &[f32; OBS_DIM]) {
        let first = self.picture(state);
        self.frames = vec![first; self.config.frame_stack as usize];
    }

    /// Drops the oldest frame and adds the picture of `state`.
    pub fn push(&mut self, state: &[f32; OBS_DIM]) {
        let newest = self.picture(state);
        if !self.frames.is_empty() {
            self.frames.remove(0);
        }
        self.frames.push(newest);
    }

    /// Writes the stack into `out` (length [`ObservationConfig::dim`]) as `byte / 255`.
    pub fn write(&self, out: &mut [f32]) {
        // Frame by frame, so that each inner loop is a plain slice loop the compiler
        // vectorises (a flattened iterator was 30 us per 84 x 84 x 4 stack).
        let n = self.config.dim() / self.config.frame_stack as usize;
        for (out, frame) in out.chunks_exact_mut(n).zip(&self.frames) {
            for (o, &b) in out.iter_mut().zip(frame) {
                *o = byte_value(b);
            }
        }
    }
}

/// `frame`'s pixels channel-first: `[1, h, w]` luma or `[3, h, w]` RGB.
pub fn channel_first(frame: &Frame, grayscale: bool) -> Vec<u8> {
    let n = frame.width * frame.height;
    let pixels = frame.rgb.chunks_exact(3);
    if grayscale {
        pixels
            .map(|p| {
                let luma = 299 * u32::from(p[0]) + 587 * u32::from(p[1]) + 114 * u32::from(p[2]);
                ((luma + 500) / 1000) as u8
            })
            .collect()
    } else {
        let mut out = vec![0; 3 * n];
        for (i, p) in pixels.enumerate() {
            for c in 0..3 {
                out[c * n + i] = p[c];
            }
        }
        out
    }
}

/// The observation value of pixel byte `b`: `b / 255`.
pub fn byte_value(b: u8) -> f32 {
    f32::from(b) / 255.0
}

/// The byte behind an image observation value; exact for values [`byte_value`] made.
/// `v * 255` rounded half up (`+ 0.5`, then the saturating cast truncates), which is
/// branch-free and vectorises, unlike `f32::round`.
pub fn value_byte(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Image observation values (`byte / 255`) back to their bytes; exact for values the env
/// handed out.
pub fn to_bytes(obs: &[f32]) -> Vec<u8> {
    obs.iter().map(|&v| value_byte(v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_survives_the_trip_through_f32() {
        let bytes: Vec<u8> = (0..=255).collect();
        let values: Vec<f32> = bytes.iter().map(|&b| byte_value(b)).collect();
        assert_eq!(to_bytes(&values), bytes);
    }

    #[test]
    fn grey_and_colour_frames_are_channel_first() {
        let frame = Frame {
            width: 2,
            height: 1,
            rgb: vec![255, 0, 0, 10, 20, 30],
        };
        assert_eq!(channel_first(&frame, false), vec![255, 10, 0, 20, 0, 30]);
        // 0.299 * 255 = 76.2; 0.299 * 10 + 0.587 * 20 + 0.114 * 30 = 18.1.
        assert_eq!(channel_first(&frame, true), vec![76, 18]);
    }

    #[test]
    fn sizes_and_stacks_out_of_range_are_refused_by_key() {
        let ok = ObservationConfig::default();
        assert_eq!(ok.validate(), Ok(()));
        let e = ObservationConfig { width: 0, ..ok }.validate().unwrap_err();
        assert_eq!(e.key, "width");
        let e = ObservationConfig { height: 4096, ..ok }
            .validate()
            .unwrap_err();
        assert_eq!(
            (e.key.as_str(), e.message.as_str()),
            ("height", "must be 1 to 512 pixels, got 4096")
        );
        let e = ObservationConfig {
            frame_stack: 0,
            ..ok
        }
        .validate()
        .unwrap_err();
        assert_eq!(e.key, "frame_stack");
        let e = ObservationConfig {
            kind: ObservationKind::Image,
            hide_black_rods: true,
            ..ok
        }
        .validate()
        .unwrap_err();
        assert_eq!(e.key, "hide_black_rods");
    }
}
