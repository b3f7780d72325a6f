//! A collider's shape that only carries mass and takes room in the broad phase: in the
//! games whose ball-man contacts are MuJoCo's search on the man's field, nothing of the
//! table collides with a man's collider, which is there for the rod's mass alone.
//!
//! [`CarriedShape`] answers every query as the shape it wraps (bounds, mass, projections,
//! rays), so the rod's mass and the broad phase's boxes are the same bits, but calls itself
//! a custom shape. Rapier's continuous collision pass then treats it as a shape with no
//! closed-form sweep, which it computes only for a pair it would test (none here), where
//! it would otherwise find the wrapped convex hull's mass properties again for every man
//! of every fast rod at every step: a seventh of the default game's step in `perf`.

use rapier3d::parry::bounding_volume::{Aabb, BoundingSphere};
use rapier3d::parry::mass_properties::MassProperties;
use rapier3d::parry::query::{PointProjection, PointQuery, Ray, RayCast, RayIntersection};
use rapier3d::parry::shape::{FeatureId, Shape, ShapeType, SharedShape, TypedShape};
use rapier3d::prelude::{Pose, Real, Vector};

/// A shape answering as the one it wraps, typed as custom (see the module's docs).
#[derive(Clone)]
pub struct CarriedShape(pub SharedShape);

impl RayCast for CarriedShape {
    fn cast_local_ray_and_get_normal(
        &self,
        ray: &Ray,
        max_time_of_impact: Real,
        solid: bool,
    ) -> Option<RayIntersection> {
        self.0
            .cast_local_ray_and_get_normal(ray, max_time_of_impact, solid)
    }
}

impl PointQuery for CarriedShape {
    fn project_local_point(&self, pt: Vector, solid: bool) -> PointProjection {
        self.0.project_local_point(pt, solid)
    }

    fn project_local_point_and_get_feature(&self, pt: Vector) -> (PointProjection, FeatureId) {
        self.0.project_local_point_and_get_feature(pt)
    }
}

impl Shape for CarriedShape {
    fn compute_local_aabb(&self) -> Aabb {
        self.0.compute_local_aabb()
    }

    fn compute_local_bounding_sphere(&self) -> BoundingSphere {
        self.0.compute_local_bounding_sphere()
    }

    fn clone_dyn(&self) -> Box<dyn Shape> {
        Box::new(self.clone())
    }

    fn scale_dyn(&self, scale: Vector, num_subdivisions: u32) -> Option<Box<dyn Shape>> {
        let scaled = self.0.scale_dyn(scale, num_subdivisions)?;
        Some(Box::new(CarriedShape(SharedShape(scaled.into()))))
    }

    fn compute_aabb(&self, position: &Pose) -> Aabb {
        self.0.compute_aabb(position)
    }

    fn compute_bounding_sphere(&self, position: &Pose) -> BoundingSphere {
        self.0.compute_bounding_sphere(position)
    }

    fn mass_properties(&self, density: Real) -> MassProperties {
        self.0.mass_properties(density)
    }

    fn shape_type(&self) -> ShapeType {
        ShapeType::Custom
    }

    fn as_typed_shape(&self) -> TypedShape<'_> {
        TypedShape::Custom(self)
    }

    fn ccd_thickness(&self) -> Real {
        self.0.ccd_thickness()
    }

    fn ccd_angular_thickness(&self) -> Real {
        self.0.ccd_angular_thickness()
    }

    fn is_convex(&self) -> bool {
        self.0.is_convex()
    }

    fn compute_swept_aabb(&self, start_pos: &Pose, end_pos: &Pose) -> Aabb {
        self.0.compute_swept_aabb(start_pos, end_pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Everything rapier reads of a rod's collider is the wrapped shape's, bit for bit.
    #[test]
    fn it_answers_as_the_shape_it_wraps() {
        let hull = SharedShape::convex_hull(&[
            Vector::new(0.0, 0.0, 0.0),
            Vector::new(1.0, 0.2, 0.0),
            Vector::new(0.1, 1.3, 0.0),
            Vector::new(0.3, 0.4, 2.0),
        ])
        .expect("a tetrahedron");
        let carried = CarriedShape(hull.clone());
        let pose = Pose::from_parts(
            Vector::new(1.0, -2.0, 0.5),
            rapier3d::prelude::Rotation::from_rotation_x(0.7),
        );
        assert_eq!(carried.compute_aabb(&pose), hull.compute_aabb(&pose));
        assert_eq!(carried.mass_properties(0.3), hull.mass_properties(0.3));
        assert_eq!(carried.ccd_thickness(), hull.ccd_thickness());
        let p = Vector::new(2.0, 0.5, 0.5);
        let (a, b) = (
            carried.project_local_point(p, true),
            hull.project_local_point(p, true),
        );
        assert_eq!((a.point, a.is_inside), (b.point, b.is_inside));
        assert_eq!(carried.shape_type(), ShapeType::Custom);
    }
}
