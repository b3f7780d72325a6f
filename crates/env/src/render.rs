//! A top-down picture of the table from its 38-dim state, in pure Rust: the field, the
//! walls and goal pockets, all eight rods with their men (a man's turn shown by his foot's
//! projection on the field, darker the flatter he lies) and the ball with a shadow that
//! moves off it as it rises. Frames are RGB, row-major `[height, width, 3]` (Gymnasium's
//! `rgb_array`), +y (black's goal) at the top.

use crate::geometry::{
    self, BALL_RADIUS, FIELD_HALF_LENGTH, FIELD_HALF_WIDTH, GOAL_HALF_WIDTH, GOAL_POCKET_BACK,
    NUM_RODS, ROD_HEIGHT, Team, foosman,
};
use crate::layout::{BALL_POS, OBS_DIM, ROD_ANGLE, ROD_SLIDE};

/// An RGB picture, `rgb` row-major `[height, width, 3]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// `height * width * 3` bytes.
    pub rgb: Vec<u8>,
}

impl Frame {
    /// The colour at column `x`, row `y`.
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// Colours of the picture.
pub mod colour {
    /// Playfield.
    pub const FIELD: [u8; 3] = [34, 120, 60];
    /// Walls and everything outside the field.
    pub const WALL: [u8; 3] = [70, 45, 30];
    /// Goal pockets.
    pub const GOAL: [u8; 3] = [150, 150, 150];
    /// Rods.
    pub const ROD: [u8; 3] = [200, 200, 210];
    /// Yellow's men (the agent).
    pub const YELLOW: [u8; 3] = [240, 200, 20];
    /// Black's men.
    pub const BLACK: [u8; 3] = [20, 20, 20];
    /// The ball.
    pub const BALL: [u8; 3] = [255, 255, 255];
    /// The ball's shadow.
    pub const SHADOW: [u8; 3] = [15, 60, 30];
}

/// Draws states at a fixed scale: `scale_x` pixels per cm across the table, `scale_y`
/// along it (equal unless the frame size is fixed, see [`Renderer::fit`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Renderer {
    /// Pixels per cm across the table (x).
    pub scale_x: f32,
    /// Pixels per cm along the table (y).
    pub scale_y: f32,
}

/// Half extents of the picture, cm: the table's frame around the goal pockets.
const HALF_X: f32 = FIELD_HALF_WIDTH + 2.0;
const HALF_Y: f32 = GOAL_POCKET_BACK + 1.0;

impl Renderer {
    /// A renderer drawing `scale` pixels per cm (> 0) both ways.
    pub fn new(scale: f32) -> Self {
        let scale = scale.max(0.01);
        Self {
            scale_x: scale,
            scale_y: scale,
        }
    }

    /// A renderer whose frames are `width x height` pixels (each >= 1), the whole table
    /// stretched to fill them (e.g. 84 x 84 image observations).
    pub fn fit(width: usize, height: usize) -> Self {
        Self {
            scale_x: width.max(1) as f32 / (2.0 * HALF_X),
            scale_y: height.max(1) as f32 / (2.0 * HALF_Y),
        }
    }

    /// Width and height of its frames, pixels.
    pub fn size(&self) -> (usize, usize) {
        let px = |cm: f32, scale: f32| ((2.0 * cm * scale).round() as usize).max(1);
        (px(HALF_X, self.scale_x), px(HALF_Y, self.scale_y))
    }

    /// Pixel coordinates (column, row) of the world point `(x, y)` cm.
    pub fn to_pixel(&self, x: f32, y: f32) -> (f32, f32) {
        ((x + HALF_X) * self.scale_x, (HALF_Y - y) * self.scale_y)
    }

    /// The picture of `state` (the 38-dim observation layout).
    pub fn draw(&self, state: &[f32; OBS_DIM]) -> Frame {
        let (width, height) = self.size();
        let mut canvas = Canvas {
            frame: Frame {
                width,
                height,
                rgb: colour::WALL.repeat(width * height),
            },
            renderer: *self,
        };
        let (w, l) = (FIELD_HALF_WIDTH, FIELD_HALF_LENGTH);
        canvas.rect(-w, -l, w, l, colour::FIELD);
        for sign in [-1.0, 1.0] {
            let (a, b) = (sign * l, sign * GOAL_POCKET_BACK);
            canvas.rect(
                -GOAL_HALF_WIDTH,
                a.min(b),
                GOAL_HALF_WIDTH,
                a.max(b),
                colour::GOAL,
            );
        }
        for rod in 0..NUM_RODS {
            let (team, spec) = geometry::rod_of(rod);
            let y = geometry::rod_y(rod);
            canvas.rect(-w, y - 0.4, w, y + 0.4, colour::ROD);
            let slide = state[ROD_SLIDE.start + rod];
            let angle = state[ROD_ANGLE.start + rod];
            // A positive turn swings the feet towards the goal the team attacks.
            let toward = team.sign();
            let reach = foosman::FOOT_BOTTOM * angle.sin() * toward;
            let lying = angle.sin().abs();
            let base = match team {
                Team::Yellow => colour::YELLOW,
                Team::Black => colour::BLACK,
            };
            let shade = base.map(|c| (f32::from(c) * (1.0 - 0.5 * lying)) as u8);
            for &m in spec.men_x {
                let x = team.sign() * (m + slide);
                let hx = foosman::TORSO_HALF_X;
                let hy = foosman::TORSO_HALF_Y;
                let (y0, y1) = (y, y + reach);
                let lx = foosman::LEG_HALF_X;
                canvas.rect(x - lx, y0.min(y1) - 0.3, x + lx, y0.max(y1) + 0.3, shade);
                canvas.rect(x - hx, y - hy, x + hx, y + hy, base);
            }
        }
        let [bx, by, bz] = [
            state[BALL_POS.start],
            state[BALL_POS.start + 1],
            state[BALL_POS.start + 2],
        ];
        // The shadow falls 0.5 cm aside per cm of height above rest; the rod height is the
        // scale of "high".
        let lift = (bz - BALL_RADIUS).max(0.0);
        canvas.disc(
            bx + 0.5 * lift,
            by - 0.5 * lift,
            BALL_RADIUS,
            colour::SHADOW,
        );
        let grow = 1.0 + 0.5 * (lift / ROD_HEIGHT).min(2.0);
        canvas.disc(bx, by, BALL_RADIUS * grow, colour::BALL);
        canvas.frame
    }
}

/// A frame being drawn in world coordinates.
struct Canvas {
    frame: Frame,
    renderer: Renderer,
}

impl Canvas {
    fn set(&mut self, col: usize, row: usize, c: [u8; 3]) {
        let i = 3 * (row * self.frame.width + col);
        self.frame.rgb[i..i + 3].copy_from_slice(&c);
    }

    /// Pixel index range covering world `[a, b]` along one axis (given in pixels).
    fn span(a: f32, b: f32, limit: usize) -> std::ops::Range<usize> {
        let lo = a.min(b).round().clamp(0.0, limit as f32) as usize;
        let hi = a.max(b).round().clamp(0.0, limit as f32) as usize;
        lo..hi
    }

    /// Fills the world rectangle `[x0, x1] x [y0, y1]`, cm.
    fn rect(&mut self, x0: f32, y0: f32, x1: f32, y1: f32, c: [u8; 3]) {
        let (c0, r0) = self.renderer.to_pixel(x0, y0);
        let (c1, r1) = self.renderer.to_pixel(x1, y1);
        for row in Self::span(r0, r1, self.frame.height) {
            for col in Self::span(c0, c1, self.frame.width) {
                self.set(col, row, c);
            }
        }
    }

    /// Fills the world disc of centre `(x, y)` and radius `r`, cm (pixel centres inside;
    /// an ellipse in pixels when the two scales differ). At least the pixel holding the
    /// centre, so that a small frame still shows the ball.
    fn disc(&mut self, x: f32, y: f32, r: f32, c: [u8; 3]) {
        let (cx, cy) = self.renderer.to_pixel(x, y);
        let (rx, ry) = (r * self.renderer.scale_x, r * self.renderer.scale_y);
        for row in Self::span(cy - ry, cy + ry + 1.0, self.frame.height) {
            for col in Self::span(cx - rx, cx + rx + 1.0, self.frame.width) {
                let (dx, dy) = ((col as f32 + 0.5 - cx) / rx, (row as f32 + 0.5 - cy) / ry);
                if dx * dx + dy * dy <= 1.0 {
                    self.set(col, row, c);
                }
            }
        }
        let (col, row) = (cx.floor(), cy.floor());
        if col >= 0.0
            && row >= 0.0
            && (col as usize) < self.frame.width
            && (row as usize) < self.frame.height
        {
            self.set(col as usize, row as usize, c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state_with_ball(x: f32, y: f32) -> [f32; OBS_DIM] {
        let mut s = [0.0; OBS_DIM];
        s[BALL_POS.start..BALL_POS.end].copy_from_slice(&[x, y, BALL_RADIUS]);
        s
    }

    #[test]
    fn the_ball_rods_and_men_are_where_the_state_puts_them() {
        let r = Renderer::new(4.0);
        assert_eq!(r.size(), (288, 553));
        let f = r.draw(&state_with_ball(10.0, 30.0));
        assert_eq!(f.rgb.len(), 288 * 553 * 3);
        let at = |x: f32, y: f32| {
            let (c, row) = r.to_pixel(x, y);
            f.pixel(c as usize, row as usize)
        };
        assert_eq!(at(10.0, 30.0), colour::BALL);
        assert_eq!(at(10.0 + BALL_RADIUS + 0.5, 30.0), colour::FIELD);
        // Yellow's midfield (y = -7.5) has a man at x = 0, black's attack (y = -22.5) too.
        assert_eq!(at(0.0, -7.5), colour::YELLOW);
        assert_eq!(at(0.0, -22.5), colour::BLACK);
        // Between the men: the rod.
        assert_eq!(at(6.0, -7.5), colour::ROD);
        assert_eq!(at(0.0, 64.0), colour::GOAL);
        assert_eq!(at(20.0, 64.0), colour::WALL);
    }

    #[test]
    fn a_fitted_frame_has_the_asked_size_and_shows_the_ball() {
        let r = Renderer::fit(84, 84);
        assert_eq!(r.size(), (84, 84));
        let f = r.draw(&state_with_ball(-20.0, 40.0));
        assert_eq!(f.rgb.len(), 84 * 84 * 3);
        let (c, row) = r.to_pixel(-20.0, 40.0);
        assert_eq!(f.pixel(c as usize, row as usize), colour::BALL);
        assert_eq!(f.pixel(42, 1), colour::GOAL);
        assert_eq!(f.pixel(0, 42), colour::WALL);
    }

    #[test]
    fn slides_move_men_and_turns_show_the_feet() {
        let r = Renderer::new(4.0);
        let mut s = state_with_ball(-30.0, 0.0);
        s[ROD_SLIDE.start + 2] = 5.0; // yellow midfield slid 5 cm
        s[ROD_ANGLE.start + 2] = 1.5; // feet swung towards +y
        let f = r.draw(&s);
        let at = |x: f32, y: f32| {
            let (c, row) = r.to_pixel(x, y);
            f.pixel(c as usize, row as usize)
        };
        assert_eq!(at(5.0, -7.5), colour::YELLOW);
        assert_ne!(at(0.0, -7.5), colour::YELLOW);
        // The foot lies about 7 cm towards black's goal, shaded.
        let foot = at(5.0, -7.5 + 5.0);
        assert!(foot != colour::FIELD && foot != colour::YELLOW, "{foot:?}");
    }
}
