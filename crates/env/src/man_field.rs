//! The man's signed distance field as the reference model has it, in one of two forms
//! ([`FieldForm`]): its `sdflib` plugin's own octree ([`crate::man_octree`], exact), or the
//! plugin's distance and gradient sampled every 0.1 cm over the plugin's box (trilinear
//! between the samples; the form of `reference_v5` and earlier), both shipped as data
//! (`crates/env/data/man_octree.bin` and `man_sdf.bin`, made by
//! `tools/sdf_contact_search.py octree` and `grid` from the model of the paper's code,
//! Foosball_CU, Apache-2.0; `crates/env/data/README.md`). [`crate::sdf_search`] finds
//! the ball's contacts with a man on it as MuJoCo does.
//!
//! The grid's file: the magic `FOOSSDF1`; the grid's point counts along x, y, z (three `u32`);
//! its first point (three `f32`, cm), spacing (cm) and distance unit (cm per count); the
//! pose of the field's frame in a man's frame (translation, cm, and unit quaternion
//! `x y z w`; a man's frame is its rod's body frame moved along the rod to the man); the
//! eight corners of the man's bounding box (the model's `geom_aabb`) in the field's frame
//! (24 `f32`, cm); then per grid point, x slowest and z fastest, four `i16`: the distance
//! in distance units and the gradient's three components in 1/32000ths. Little endian.

use std::sync::OnceLock;

use rapier3d::glamx::{DQuat, DVec3};

use crate::man_octree::{self, LANES, LastLeaf, Octree};

const MAGIC: &[u8; 8] = b"FOOSSDF1";
const GRADIENT_UNIT: f64 = 1.0 / 32000.0;
const HEADER_BYTES: usize = 8 + 12 + 20 + 28 + 96;
const OCTREE_HEADER_BYTES: usize = 8 + 8 + 16 + 28 + 96;

/// Which form of the reference man's field a table reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FieldForm {
    /// The plugin's own octree: the model's distance to float rounding, its gradient.
    #[default]
    Octree,
    /// Samples every 0.1 cm, trilinear between them (`reference_v5` and earlier).
    Grid,
}

/// The plugin's distance and gradient sampled on a grid.
#[derive(Debug, Clone, PartialEq)]
struct Grid {
    /// The grid's first point, cm.
    lo: DVec3,
    /// Grid spacing, cm.
    step: f64,
    /// Points along x, y, z.
    counts: [usize; 3],
    /// Per point (x slowest): distance (cm) and gradient.
    samples: Vec<[f32; 4]>,
}

/// How a field file holds the distance.
#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Grid(Grid),
    Octree(Octree),
}

/// A man's signed distance field (negative inside the man), cm, in the field's own frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ManField {
    shape: Shape,
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
    /// The reference model's man (every man of both teams is the same mesh) in `form`,
    /// read once.
    pub fn reference(form: FieldForm) -> &'static ManField {
        static OCTREE: OnceLock<ManField> = OnceLock::new();
        static GRID: OnceLock<ManField> = OnceLock::new();
        match form {
            FieldForm::Octree => OCTREE.get_or_init(|| {
                ManField::parse(include_bytes!("../data/man_octree.bin"))
                    .expect("the shipped man_octree.bin parses (checked by this module's tests)")
            }),
            FieldForm::Grid => GRID.get_or_init(|| {
                ManField::parse(include_bytes!("../data/man_sdf.bin"))
                    .expect("the shipped man_sdf.bin parses (checked by this module's tests)")
            }),
        }
    }

    /// Reads a field file: a grid (the format in the module's docs) or an octree
    /// ([`crate::man_octree`]'s).
    pub fn parse(bytes: &[u8]) -> Result<ManField, String> {
        let word = |i: usize| {
            let at = 8 + 4 * i;
            [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]
        };
        let float = |i: usize| f64::from(f32::from_le_bytes(word(i)));
        if bytes.len() >= OCTREE_HEADER_BYTES && &bytes[..8] == man_octree::MAGIC {
            let cells = u32::from_le_bytes(word(0));
            let corner = DVec3::new(float(2), float(3), float(4));
            let tree = Octree::parse(cells, corner, float(5), &bytes[OCTREE_HEADER_BYTES..])?;
            return Ok(ManField::placed(Shape::Octree(tree), |i| float(6 + i)));
        }
        if bytes.len() < HEADER_BYTES || &bytes[..8] != MAGIC {
            return Err("not a man field: no FOOSSDF1 or FOOSOCT1 header".into());
        }
        let counts = [0, 1, 2].map(|i| u32::from_le_bytes(word(i)) as usize);
        if counts.iter().any(|&n| n < 2) {
            return Err(format!("man field: grid counts {counts:?} below 2"));
        }
        let lo = DVec3::new(float(3), float(4), float(5));
        let (step, unit) = (float(6), float(7));
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
        let grid = Grid {
            lo,
            step,
            counts,
            samples,
        };
        Ok(ManField::placed(Shape::Grid(grid), |i| float(8 + i)))
    }

    /// The field of `shape` with the pose and box read from the header's 31 floats
    /// `header(0..31)` (translation, quaternion `x y z w`, eight corners).
    fn placed(shape: Shape, header: impl Fn(usize) -> f64) -> ManField {
        let translation = DVec3::new(header(0), header(1), header(2));
        let rotation = DQuat::from_xyzw(header(3), header(4), header(5), header(6)).normalize();
        let box_corners = core::array::from_fn(|c| {
            DVec3::new(header(7 + 3 * c), header(8 + 3 * c), header(9 + 3 * c))
        });
        let reach = box_corners
            .iter()
            .map(|&c| (rotation * c + translation).length())
            .fold(0.0, f64::max);
        ManField {
            shape,
            rotation,
            translation,
            box_corners,
            reach,
        }
    }

    /// The distance (cm) and its gradient at `point` (the field's frame, cm). Off the
    /// grid or the octree's cube, the value at the nearest point of it plus the distance
    /// to it, and the gradient there (the plugin's `boxProjection`).
    pub fn sample(&self, point: DVec3) -> (f64, DVec3) {
        self.sample_near(point, &mut LastLeaf::default())
    }

    /// [`ManField::sample`], the same bits, where `last` remembers the octree's leaf of
    /// the previous point (a search's points cluster; [`Octree::sample_near`]).
    pub fn sample_near(&self, point: DVec3, last: &mut LastLeaf) -> (f64, DVec3) {
        match &self.shape {
            Shape::Grid(grid) => grid.sample(point),
            Shape::Octree(tree) => tree.sample_near(point, last),
        }
    }

    /// [`ManField::sample_near`]'s distances (cm) at [`LANES`] points, each the same bits
    /// as alone, without the gradients' work (the octree sums them side by side,
    /// [`Octree::distances_near`]).
    pub fn distances_near(&self, points: &[DVec3; LANES], last: &mut LastLeaf) -> [f64; LANES] {
        match &self.shape {
            Shape::Grid(grid) => points.map(|p| grid.sample(p).0),
            Shape::Octree(tree) => tree.distances_near(points, last),
        }
    }

    /// Whether the man is surely clear of the ball of `radius` at `centre` (field frame,
    /// cm): every distance [`ManField::sample`] gives in the ball, grown by
    /// [`CLEARANCE_MARGIN`] against rounding, is above zero, so MuJoCo's search there finds
    /// no contact (its contacts lie where both distances are at most zero). The octree
    /// answers from its cells' floors; the grid never claims it.
    pub fn clear_of(&self, centre: DVec3, radius: f64) -> bool {
        match &self.shape {
            Shape::Grid(_) => false,
            Shape::Octree(tree) => {
                tree.is_above_in(centre, radius + CLEARANCE_MARGIN, CLEARANCE_MARGIN)
            }
        }
    }
}

/// What [`ManField::clear_of`] adds to the ball's box and asks of the distance there
/// (cm): far above the search's rounding (1e-12 cm), far below a contact's depth.
pub const CLEARANCE_MARGIN: f64 = 1e-4;

impl Grid {
    /// Trilinear between the grid's points; off the grid, see [`ManField::sample`].
    fn sample(&self, point: DVec3) -> (f64, DVec3) {
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
    fn the_shipped_fields_are_a_man() {
        for form in [FieldForm::Octree, FieldForm::Grid] {
            let field = ManField::reference(form);
            // Far from the man the distance grows as the distance to the field's box does.
            let far = field.box_corners[0] * 3.0;
            let (d_far, _) = field.sample(far);
            assert!(d_far > 5.0, "{form:?}: {d_far}");
            // A distance changes no faster than the point moves (the plugin's leaves meet
            // with small jumps deep inside the man, so a tenth more there); the gradient is
            // at most a unit vector (the grid's is shorter where the interpolation crosses a
            // crease), and where it is whole inside the man it points outwards: one step
            // along it raises the value.
            let mut inside_found = false;
            let mut last: Option<(DVec3, f64)> = None;
            for i in 0..200 {
                let t = f64::from(i) / 200.0;
                let p = field.box_corners[0].lerp(field.box_corners[7], t);
                let (d, g) = field.sample(p);
                if let Some((q, e)) = last {
                    let slack = if form == FieldForm::Octree { 1.1 } else { 1.02 };
                    assert!(
                        (d - e).abs() <= slack * p.distance(q),
                        "{form:?}: {d} {e} at {p:?}"
                    );
                }
                last = Some((p, d));
                assert!(g.length() < 1.001, "{form:?}: {g:?} at {p:?}");
                if d < -0.2 && g.length() > 0.95 {
                    inside_found = true;
                    assert!(field.sample(p + 0.02 * g).0 > d, "{form:?}: at {p:?}");
                }
            }
            assert!(inside_found, "{form:?}: the box's diagonal crosses the man");
        }
    }

    /// A ball the octree says is above a level has every sampled value above it, and a
    /// ball about a point inside the man is not.
    #[test]
    fn a_ball_the_octree_puts_above_a_level_samples_above_it() {
        let Shape::Octree(tree) = &ManField::reference(FieldForm::Octree).shape else {
            panic!("the octree's file holds an octree");
        };
        let mut above = 0;
        for n in 0..3_000 {
            let t = f64::from(n) * 0.618_033_988_75;
            let centre = DVec3::new(
                4.0 * ((t * 2.3).fract() - 0.5),
                10.0 * ((t * 3.1).fract() - 0.5),
                16.0 * ((t * 0.7).fract() - 0.5),
            );
            let radius = 0.5 + (t * 5.3).fract();
            let level = (t * 1.9).fract() - 0.5;
            if !tree.is_above_in(centre, radius, level) {
                continue;
            }
            above += 1;
            for m in 0..50 {
                let s = f64::from(m) * 0.754_877_666;
                let offset = DVec3::new((s * 1.1).fract(), (s * 2.7).fract(), (s * 0.3).fract());
                let p = centre + radius * (2.0 * offset - 1.0).clamp_length_max(1.0);
                assert!(tree.sample(p).0 > level, "{p:?} below {level}");
            }
        }
        assert!(above > 300, "{above}");
        let field = ManField::reference(FieldForm::Octree);
        let inside = (0..200)
            .map(|i| field.box_corners[0].lerp(field.box_corners[7], f64::from(i) / 200.0))
            .find(|&p| tree.sample(p).0 < -0.2)
            .expect("the box's diagonal crosses the man");
        assert!(!tree.is_above_in(inside, 0.1, 0.0));
    }

    /// The distances alone (four side by side), and a sample after a remembered leaf, are
    /// the fresh sample's bits, on and off the cube: along a walk of small and large steps
    /// (the leaf often the last one's), and on the octree's cells' faces, where the
    /// plugin's walk sends a place of exactly one half to the lower child (dyadic places
    /// down to the deepest cells, each after a point just inside the upper child, which
    /// the memory then holds).
    #[test]
    fn a_remembered_leaf_and_the_distances_alone_give_the_samples_bits() {
        let check = |field: &ManField, points: &mut dyn Iterator<Item = DVec3>| {
            let (mut last, mut last_lanes) = (LastLeaf::default(), LastLeaf::default());
            let mut hits = 0;
            let points: Vec<DVec3> = points.collect();
            for lanes in points.chunks_exact(LANES) {
                let lanes: &[DVec3; LANES] = lanes.try_into().expect("a chunk of LANES");
                let alone = field.distances_near(lanes, &mut last_lanes);
                for (&p, alone) in lanes.iter().zip(alone) {
                    let fresh = field.sample(p);
                    let before = last;
                    let near = field.sample_near(p, &mut last);
                    hits += usize::from(before == last && before != LastLeaf::default());
                    let bits = |(d, g): (f64, DVec3)| (d.to_bits(), g.to_array().map(f64::to_bits));
                    assert_eq!(bits(near), bits(fresh), "at {p:?}");
                    assert_eq!(alone.to_bits(), fresh.0.to_bits(), "at {p:?}");
                }
            }
            hits
        };
        let walk = |scale: f64| {
            (0..2_000).map(move |n| {
                let t = n as f64 * 0.618_033_988_75;
                DVec3::new(
                    scale * (t * 1.3).sin(),
                    scale * (t * 0.7).cos(),
                    1.5 * scale * (t * 0.31).sin(),
                )
            })
        };
        for form in [FieldForm::Octree, FieldForm::Grid] {
            let field = ManField::reference(form);
            check(field, &mut walk(8.0));
            let hits = check(field, &mut walk(0.01));
            if form == FieldForm::Octree {
                assert!(hits > 1_000, "{hits} of 2,000 small steps in the last leaf");
            }
        }
        let field = ManField::reference(FieldForm::Octree);
        let Shape::Octree(tree) = &field.shape else {
            panic!("the octree's file holds an octree");
        };
        // A point whose place in first cells is exactly `q` on each axis (`q` dyadic), found
        // among the float neighbours of `low + cell q`, where one has it.
        let (low, cell, cells) = tree.first_cells();
        let exactly = |low: f64, q: f64| {
            let mut p = low + cell * q;
            for _ in 0..8 {
                match ((p - low) / cell).total_cmp(&q) {
                    std::cmp::Ordering::Equal => return Some(p),
                    std::cmp::Ordering::Less => p = p.next_up(),
                    std::cmp::Ordering::Greater => p = p.next_down(),
                }
            }
            None
        };
        let mut ties = 0;
        let faces: Vec<DVec3> = (0..3_000_u32)
            .filter_map(|n| {
                let t = f64::from(n) * 0.618_033_988_75;
                let unit = f64::from(1_u32 << (1 + n % 6));
                let dyadic = |f: f64| ((f * unit * cells as f64).floor() + 0.5) / unit;
                let q = DVec3::new(dyadic((t * 1.7).fract()), dyadic((t * 2.9).fract()), 0.0);
                let face = DVec3::new(
                    exactly(low.x, q.x)?,
                    exactly(low.y, q.y)?,
                    low.z + cell * cells as f64 * (0.3 + 0.4 * (t * 0.9).fract()),
                );
                ties += 1;
                Some([face + DVec3::new(cell * 1e-6, cell * 1e-6, 0.0), face])
            })
            .flatten()
            .collect();
        assert!(ties > 1_000, "{ties} points on faces");
        check(field, &mut faces.into_iter());
    }

    /// Both files hold the plugin's field: at the grid's points the octree gives the
    /// grid's samples back, to their rounding (2e-4 cm counts, gradients in 1/32000ths).
    #[test]
    fn the_octree_gives_the_grids_samples_at_its_points() {
        let (Shape::Grid(grid), tree) = (
            &ManField::reference(FieldForm::Grid).shape,
            ManField::reference(FieldForm::Octree),
        ) else {
            panic!("the grid's file holds a grid");
        };
        let mut worst = (0.0_f64, 0.0_f64);
        for (n, sample) in grid.samples.iter().enumerate().step_by(97) {
            let [x, y, z] = [
                n / (grid.counts[1] * grid.counts[2]),
                n / grid.counts[2] % grid.counts[1],
                n % grid.counts[2],
            ];
            let p = grid.lo + grid.step * DVec3::new(x as f64, y as f64, z as f64);
            let (d, g) = tree.sample(p);
            worst.0 = worst.0.max((d - f64::from(sample[0])).abs());
            let stored = DVec3::new(sample[1].into(), sample[2].into(), sample[3].into());
            worst.1 = worst.1.max((g - stored).abs().max_element());
        }
        assert!(worst.0 < 2e-4, "distance {}", worst.0);
        assert!(worst.1 < 1e-3, "gradient {}", worst.1);
    }

    #[test]
    fn the_grid_is_trilinear_between_points_exact_at_them() {
        let Shape::Grid(grid) = &ManField::reference(FieldForm::Grid).shape else {
            panic!("the grid's file holds a grid");
        };
        let p = grid.lo + DVec3::new(20.0, 30.0, 60.0) * grid.step;
        let at = (20 * grid.counts[1] + 30) * grid.counts[2] + 60;
        let (d, g) = grid.sample(p);
        assert!((d - f64::from(grid.samples[at][0])).abs() < 1e-6);
        assert!((g.x - f64::from(grid.samples[at][1])).abs() < 1e-6);
        let next = grid.sample(p + DVec3::Z * grid.step).0;
        let half = grid.sample(p + DVec3::Z * 0.5 * grid.step).0;
        assert!((half - 0.5 * (d + next)).abs() < 1e-6);
    }

    #[test]
    fn a_bad_file_is_refused() {
        assert!(
            ManField::parse(b"nothing")
                .unwrap_err()
                .contains("FOOSSDF1")
        );
        let octree = include_bytes!("../data/man_octree.bin");
        assert!(
            ManField::parse(&octree[..octree.len() - 4])
                .unwrap_err()
                .contains("bytes of coefficients")
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
