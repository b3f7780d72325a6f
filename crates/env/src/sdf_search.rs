//! MuJoCo 3.3.2's contact search between a sphere and a signed distance field
//! (`engine_collision_sdf.c`, `mjc_SDF`), as the reference model finds the ball's
//! contacts with a man ([`crate::man_field`]): a patch of up to `initpoints` contacts,
//! where an exact sphere-mesh query finds one.
//!
//! With `A` the man's distance and `B` the ball's (`|x - c| - r`), each of `initpoints`
//! starting points (Halton points in the intersection of the two bounding boxes, the
//! ball's frame being the world's axes at its centre) descends `iterations` backtracking
//! gradient steps on `A + B + |max(A, B)|`, then one on `max(A, B)`; where that is at most
//! zero, the point is a contact (unless an earlier point ended on the same spot) at depth
//! `max(A, B)`, its normal the midsurface's: `∇A/|∇A| - ∇B/|∇B|`, normalised.

pub use rapier3d::glamx::{DQuat, DVec3};

use crate::man_field::ManField;
use crate::man_octree::{LANES, LastLeaf};

/// One contact of a patch, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SdfContact {
    /// Signed distance, cm (at most 0: the surfaces overlap).
    pub dist: f64,
    /// Midpoint between the surfaces, cm.
    pub point: DVec3,
    /// Unit normal from the man towards the ball.
    pub normal: DVec3,
}

/// The search's settings (the model's `<option sdf_initpoints sdf_iterations>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SdfSearch {
    /// Starting points per pair.
    pub initpoints: usize,
    /// Gradient steps from each.
    pub iterations: usize,
}

/// What the descent minimises (MuJoCo's `mjtSDFType`).
#[derive(Clone, Copy)]
enum Objective {
    /// `A + B + |max(A, B)|`: low where both are negative, the overlap's deepest point.
    Collision,
    /// `max(A, B)`: the overlap's own distance.
    Intersection,
}

/// A man's field placed in the world and the ball: the two distances of a point of the
/// field's frame.
struct Pair<'a> {
    field: &'a ManField,
    /// The field's frame in the world: `world = rotation * x + position`.
    rotation: DQuat,
    position: DVec3,
    centre: DVec3,
    radius: f64,
    /// The octree's leaf of the last point sampled (the descents' points cluster).
    last: LastLeaf,
}

impl Pair<'_> {
    /// The ball's centre to `x` (the field's frame), in the world.
    fn ball_to(&self, x: DVec3) -> DVec3 {
        self.rotation * x + self.position - self.centre
    }

    /// The man's distance and gradient, the ball's, at `x` (the field's frame).
    fn distances(&mut self, x: DVec3) -> ((f64, DVec3), (f64, DVec3)) {
        let man = self.field.sample_near(x, &mut self.last);
        let from_centre = self.ball_to(x);
        let norm = from_centre.length();
        let ball = (
            norm - self.radius,
            self.rotation.inverse() * (from_centre / norm),
        );
        (man, ball)
    }

    /// The objective of the man's distance `a` and the ball's `b`.
    fn combine(objective: Objective, a: f64, b: f64) -> f64 {
        match objective {
            Objective::Collision => a + b + a.max(b).abs(),
            Objective::Intersection => a.max(b),
        }
    }

    /// The objective at [`LANES`] points (the line search's trials), each the same bits
    /// as [`Pair::value_and_gradient`]'s value there without the gradients' work (the
    /// man's distances summed side by side, [`ManField::distances_near`]).
    fn values(&mut self, objective: Objective, xs: &[DVec3; LANES]) -> [f64; LANES] {
        let a = self.field.distances_near(xs, &mut self.last);
        core::array::from_fn(|l| {
            let b = self.ball_to(xs[l]).length() - self.radius;
            Self::combine(objective, a[l], b)
        })
    }

    /// The objective at `x` and its gradient, from one sample of each distance.
    fn value_and_gradient(&mut self, objective: Objective, x: DVec3) -> (f64, DVec3) {
        let ((a, ga), (b, gb)) = self.distances(x);
        let larger = if a > b { ga } else { gb };
        let gradient = match objective {
            Objective::Collision => ga + gb + larger * if a.max(b) > 0.0 { 1.0 } else { -1.0 },
            Objective::Intersection => larger,
        };
        (Self::combine(objective, a, b), gradient)
    }

    /// MuJoCo's `stepGradient`: `steps` steps of backtracking line search (Armijo,
    /// `c = 0.1`, halving from 2 down to 1e-4), stopping early where a step does not
    /// improve (and keeping that step, as MuJoCo does). Returns the last value.
    ///
    /// The line search's trial points are known before any is valued (`start - alpha
    /// gradient`, `alpha` halving), and half of its searches try eight or more, so they are
    /// valued [`LANES`] at a time ([`Pair::values`]) and read in MuJoCo's order: the step
    /// taken and its value are MuJoCo's; the trials past it are wasted work.
    fn descend(&mut self, objective: Objective, x: &mut DVec3, steps: usize) -> f64 {
        let mut value = f64::MAX;
        for _ in 0..steps {
            let (start_value, gradient) = self.value_and_gradient(objective, *x);
            if !gradient.is_finite() {
                return f64::MAX;
            }
            let start = *x;
            let (mut alpha, mut wolfe) = (2.0, -0.1 * 2.0 * gradient.length_squared());
            'search: loop {
                let trials: [(f64, f64); LANES] = core::array::from_fn(|_| {
                    alpha *= 0.5;
                    wolfe *= 0.5;
                    (alpha, wolfe)
                });
                let points = trials.map(|(alpha, _)| start - alpha * gradient);
                let values = self.values(objective, &points);
                for ((trial_alpha, trial_wolfe), (point, trial_value)) in
                    trials.into_iter().zip(points.into_iter().zip(values))
                {
                    *x = point;
                    value = trial_value;
                    if !(trial_alpha > 1e-4 && value - start_value > trial_wolfe) {
                        break 'search;
                    }
                }
            }
            if start_value < value {
                return value;
            }
        }
        value
    }
}

impl SdfSearch {
    /// The reference model's: 40 starting points, 20 steps.
    pub const REFERENCE: SdfSearch = SdfSearch {
        initpoints: 40,
        iterations: 20,
    };

    /// The contacts between a ball of `radius` at `centre` (world, cm) and a man whose
    /// frame is at `man_rotation`, `man_position` in the world.
    pub fn contacts(
        &self,
        field: &ManField,
        man_rotation: DQuat,
        man_position: DVec3,
        centre: DVec3,
        radius: f64,
    ) -> Vec<SdfContact> {
        let mut pair = Pair {
            field,
            rotation: man_rotation * field.rotation,
            position: man_rotation * field.translation + man_position,
            centre,
            radius,
            last: LastLeaf::default(),
        };
        // The man's box seen from the ball (the world's axes at its centre), cut by the
        // ball's own.
        let (mut lo, mut hi) = (DVec3::splat(-radius), DVec3::splat(radius));
        let (mut man_lo, mut man_hi) = (DVec3::MAX, DVec3::MIN);
        for corner in field.box_corners {
            let p = pair.rotation * corner + pair.position - centre;
            man_lo = man_lo.min(p);
            man_hi = man_hi.max(p);
        }
        lo = lo.max(man_lo);
        hi = hi.min(man_hi);
        if hi.cmplt(lo).any()
            || field.clear_of(pair.rotation.inverse() * (centre - pair.position), radius)
        {
            return Vec::new();
        }
        let mut found: Vec<(DVec3, SdfContact)> = Vec::new();
        for j in 0..self.initpoints {
            let start = lo + (hi - lo) * DVec3::new(halton(j, 2), halton(j, 3), halton(j, 5));
            let mut x = pair.rotation.inverse() * (centre + start - pair.position);
            pair.descend(Objective::Collision, &mut x, self.iterations);
            let dist = pair.descend(Objective::Intersection, &mut x, 1);
            if dist > 0.0 || found.iter().any(|(seen, _)| seen.distance(x) < 1e-15) {
                continue;
            }
            let ((_, ga), (_, gb)) = pair.distances(x);
            let midsurface = (ga.normalize() - gb.normalize()).normalize();
            // MuJoCo's normal points from the ball to the man: -midsurface.
            let normal = pair.rotation * midsurface;
            let point = pair.rotation * x + pair.position + normal * dist / 2.0;
            if normal.is_finite() && point.is_finite() {
                found.push((
                    x,
                    SdfContact {
                        dist,
                        point,
                        normal,
                    },
                ));
            }
        }
        found.into_iter().map(|(_, c)| c).collect()
    }
}

/// MuJoCo's `mju_Halton`: the radical inverse of `index` in `base`.
fn halton(index: usize, base: usize) -> f64 {
    let (mut n, mut f, mut h) = (index, 1.0 / base as f64, 0.0);
    while n > 0 {
        h += f * (n % base) as f64;
        n /= base;
        f /= base as f64;
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::man_field::FieldForm;

    #[test]
    fn halton_is_the_radical_inverse() {
        assert_eq!(halton(0, 2), 0.0);
        assert_eq!(halton(1, 2), 0.5);
        assert_eq!(halton(3, 2), 0.75);
        assert!((halton(5, 3) - (2.0 / 3.0 + 1.0 / 9.0)).abs() < 1e-12);
    }

    /// A man at the origin, neutral, its frame the world's.
    fn contacts_with_ball_at(centre: DVec3) -> Vec<SdfContact> {
        SdfSearch::REFERENCE.contacts(
            ManField::reference(FieldForm::Octree),
            DQuat::IDENTITY,
            DVec3::ZERO,
            centre,
            1.733_55,
        )
    }

    #[test]
    fn a_ball_pressed_on_the_foot_makes_a_patch_pushing_it_away() {
        // The ball on the floor in front of a neutral man's foot (y forward, the rod 7.75
        // cm above the floor), 0.3 cm into it: many contacts, all overlapping, their
        // normals pushing the ball forward; away from the man, none.
        let field = ManField::reference(FieldForm::Octree);
        let touching = (0..60)
            .map(|i| DVec3::new(0.0, 3.5 - 0.05 * f64::from(i), 1.733_55 - 7.75))
            .find(|&c| {
                let (d, _) = field.sample(field.rotation.inverse() * (c - field.translation));
                d < 1.733_55 - 0.3
            })
            .expect("the ball meets the foot in front of the man");
        let patch = contacts_with_ball_at(touching);
        assert!(patch.len() >= 5, "{}", patch.len());
        for c in &patch {
            assert!(c.dist <= 0.0 && c.dist > -1.0, "{c:?}");
            assert!(c.normal.y > 0.5, "{c:?}");
            assert!((c.normal.length() - 1.0).abs() < 1e-9);
        }
        assert!(contacts_with_ball_at(touching + DVec3::Y * 3.0).is_empty());
    }

    /// Where the field says the man is clear of the ball, the full search finds nothing
    /// there (so skipping it keeps the contacts bit for bit), and the test clears most
    /// placements where the search finds nothing: 4,000 balls about a man turned every
    /// way, inside its box.
    #[test]
    fn a_ball_the_field_clears_has_no_contact() {
        let field = ManField::reference(FieldForm::Octree);
        let radius = 1.733_55;
        let (mut cleared, mut empty) = (0, 0);
        for n in 0..4_000 {
            let t = f64::from(n) * 0.618_033_988_75;
            let turn = DQuat::from_rotation_x(std::f64::consts::TAU * (t * 1.7).fract());
            let centre = DVec3::new(
                3.0 * ((t * 2.3).fract() - 0.5),
                12.0 * ((t * 3.1).fract() - 0.5),
                14.0 * ((t * 0.7).fract() - 0.5),
            );
            let search = SdfSearch::REFERENCE;
            let contacts = search.contacts(field, turn, DVec3::ZERO, centre, radius);
            let rotation = turn * field.rotation;
            let position = turn * field.translation;
            let clear = field.clear_of(rotation.inverse() * (centre - position), radius);
            if clear {
                cleared += 1;
                assert!(contacts.is_empty(), "at {centre:?}: {contacts:?}");
            }
            empty += usize::from(contacts.is_empty());
        }
        assert!(
            cleared > empty / 2,
            "{cleared} cleared of {empty} without contact"
        );
    }
}
