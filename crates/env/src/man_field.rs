//! The man's signed distance field as the reference model has it: its `sdflib` plugin's
//! distance and gradient, sampled every 0.1 cm over the plugin's box and shipped as data
//! (`crates/env/data/man_sdf.bin`, made by `tools/sdf_contact_search.py grid` from the
//! model of the paper's code, Foosball_CU, Apache-2.0; `crates/env/data/README.md`).
//! [`crate::sdf_search`] finds the ball's contacts with a man on it as MuJoCo does.
//!
//! The file: the magic `FOOSSDF1`; the grid's point counts along x, y, z (three `u32`);
//! its first point (three `f32`, cm), spacing (cm) and distance unit (cm per count); the
//! pose of the field's frame in a man's frame (translation, cm, and unit quaternion
//! `x y z w`; a man's frame is its rod's body frame moved along the rod to the man); the
//! eight corners of the man's bounding box (the model's `geom_aabb`) in the field's frame
//! (24 `f32`, cm); then per grid point, x slowest and z fastest, four `i16`: the distance
//! in distance units and the gradient's three components in 1/32000ths. Little endian.

use std::sync::OnceLock;

use rapier3d::glamx::{DQuat, DVec3};

const MAGIC: &[u8; 8] = b"FOOSSDF1";
const GRADIENT_UNIT: f64 = 1.0 / 32000.0;
const HEADER_BYTES: usize = 8 + 12 + 20 + 28 + 96;

/// A man's signed distance field (negative inside the man), cm, in the field's own frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ManField {
    /// The grid's first point, cm.
    lo: DVec3,
    /// Grid spacing, cm.
    step: f64,
    /// Points along x, y, z.
    counts: [usize; 3],
    /// Per point (x slowest): distance (cm) and gradient.
    samples: Vec<[f32; 4]>,
    /// Rotation of the field's frame in a man's frame.
    pub rotation: DQuat,
    /// Origin of the field's frame in a man's frame, cm.
    pub translation: DVec3,
    /// The corners of the man's bounding box in the field's frame, cm.
    pub box_corners: [DVec3; 8],
    /// The farthest of those corners from the man's frame's origin, cm: no part of the
    /// man is farther.
    pub reach: f64,
}

impl ManField {
    /// The reference model's man (every man of both teams is the same mesh), read once.
    pub fn reference() -> &'static ManField {
        static FIELD: OnceLock<ManField> = OnceLock::new();
        FIELD.get_or_init(|| {
            ManField::parse(include_bytes!("../data/man_sdf.bin"))
                .expect("the shipped man_sdf.bin parses (checked by this module's tests)")
        })
    }

    /// Reads a field file (the format in the module's docs).
    pub fn parse(bytes: &[u8]) -> Result<ManField, String> {
        if bytes.len() < HEADER_BYTES || &bytes[..8] != MAGIC {
            return Err("not a man field: no FOOSSDF1 header".into());
        }
        let word = |i: usize| {
            let at = 8 + 4 * i;
            [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]
        };
        let float = |i: usize| f64::from(f32::from_le_bytes(word(i)));
        let counts = [0, 1, 2].map(|i| u32::from_le_bytes(word(i)) as usize);
        if counts.iter().any(|&n| n < 2) {
            return Err(format!("man field: grid counts {counts:?} below 2"));
        }
        let lo = DVec3::new(float(3), float(4), float(5));
        let (step, unit) = (float(6), float(7));
        let translation = DVec3::new(float(8), float(9), float(10));
        let rotation = DQuat::from_xyzw(float(11), float(12), float(13), float(14)).normalize();
        let box_corners = core::array::from_fn(|c| {
            DVec3::new(float(15 + 3 * c), float(16 + 3 * c), float(17 + 3 * c))
        });
        let points = counts.iter().product::<usize>();
        let body = &bytes[HEADER_BYTES..];
        if body.len() != 8 * points {
            return Err(format!(
                "man field: {} bytes of samples for {points} points (8 each)",
                body.len()
            ));
        }
        let samples = body
            .chunks_exact(8)
            .map(|p| {
                let value = |k: usize| f64::from(i16::from_le_bytes([p[2 * k], p[2 * k + 1]]));
                [
                    (value(0) * unit) as f32,
                    (value(1) * GRADIENT_UNIT) as f32,
                    (value(2) * GRADIENT_UNIT) as f32,
                    (value(3) * GRADIENT_UNIT) as f32,
                ]
            })
            .collect();
        let reach = box_corners
            .iter()
            .map(|&c| (rotation * c + translation).length())
            .fold(0.0, f64::max);
        Ok(ManField {
            reach,
            lo,
            step,
            counts,
            samples,
            rotation,
            translation,
            box_corners,
        })
    }

    /// The distance (cm) and its gradient at `point` (the field's frame, cm): both
    /// trilinear between the grid's points. Off the grid, the value at the nearest point
    /// of the grid plus the distance to it, and the gradient there (the plugin's
    /// `boxProjection`).
    pub fn sample(&self, point: DVec3) -> (f64, DVec3) {
        let top = self.lo + self.step * DVec3::from(self.counts.map(|n| (n - 1) as f64));
        let inside = point.clamp(self.lo, top);
        let outside = point.distance(inside);
        let u = (inside - self.lo) / self.step;
        let cell = [u.x, u.y, u.z];
        let index: [usize; 3] =
            core::array::from_fn(|k| (cell[k].floor().max(0.0) as usize).min(self.counts[k] - 2));
        let frac: [f64; 3] = core::array::from_fn(|k| cell[k] - index[k] as f64);
        let (mut value, mut gradient) = (0.0, DVec3::ZERO);
        for corner in 0..8 {
            let bit = |k: usize| (corner >> (2 - k)) & 1;
            let weight: f64 = (0..3)
                .map(|k| if bit(k) == 1 { frac[k] } else { 1.0 - frac[k] })
                .product();
            let at = ((index[0] + bit(0)) * self.counts[1] + index[1] + bit(1)) * self.counts[2]
                + index[2]
                + bit(2);
            let [d, gx, gy, gz] = self.samples[at].map(f64::from);
            value += weight * d;
            gradient += weight * DVec3::new(gx, gy, gz);
        }
        (value + outside, gradient)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_field_is_a_man() {
        let field = ManField::reference();
        // Far from the man the distance grows as the distance to the grid does.
        let far = field.box_corners[0] * 3.0;
        let (d_far, _) = field.sample(far);
        assert!(d_far > 5.0, "{d_far}");
        // A distance changes no faster than the point moves; the gradient is at most a
        // unit vector (shorter where the interpolation crosses a crease), and where it is
        // whole inside the man it points outwards: one step along it raises the value.
        let mut inside_found = false;
        let mut last: Option<(DVec3, f64)> = None;
        for i in 0..200 {
            let t = f64::from(i) / 200.0;
            let p = field.box_corners[0].lerp(field.box_corners[7], t);
            let (d, g) = field.sample(p);
            if let Some((q, e)) = last {
                assert!((d - e).abs() <= 1.02 * p.distance(q), "{d} {e} at {p:?}");
            }
            last = Some((p, d));
            assert!(g.length() < 1.001, "{g:?} at {p:?}");
            if d < -0.2 && g.length() > 0.95 {
                inside_found = true;
                assert!(field.sample(p + 0.02 * g).0 > d, "at {p:?}");
            }
        }
        assert!(inside_found, "the box's diagonal crosses the man");
    }

    #[test]
    fn trilinear_between_points_exact_at_them() {
        let field = ManField::reference();
        let p = field.lo + DVec3::new(20.0, 30.0, 60.0) * field.step;
        let at = (20 * field.counts[1] + 30) * field.counts[2] + 60;
        let (d, g) = field.sample(p);
        assert!((d - f64::from(field.samples[at][0])).abs() < 1e-6);
        assert!((g.x - f64::from(field.samples[at][1])).abs() < 1e-6);
        let next = field.sample(p + DVec3::Z * field.step).0;
        let half = field.sample(p + DVec3::Z * 0.5 * field.step).0;
        assert!((half - 0.5 * (d + next)).abs() < 1e-6);
    }

    #[test]
    fn a_bad_file_is_refused() {
        assert!(
            ManField::parse(b"nothing")
                .unwrap_err()
                .contains("FOOSSDF1")
        );
        let bytes = include_bytes!("../data/man_sdf.bin");
        let cut = &bytes[..bytes.len() - 8];
        assert!(
            ManField::parse(cut)
                .unwrap_err()
                .contains("bytes of samples")
        );
    }
}
