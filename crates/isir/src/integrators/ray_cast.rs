//! The course's ray cast: flat colour of the material times `max(dot(n, -dir), 0)`.

use super::RayCounters;
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::scene::Scene;

/// The ray cast's `Li`.
pub(super) fn li(scene: &Scene, ray: &Ray, t_min: f32, t_max: f32, counters: &mut RayCounters) -> Color {
    counters.primary += 1;
    let Some(hit) = scene.intersect(ray, t_min, t_max) else {
        return scene.background;
    };
    scene.material(&hit).color_at(&hit) * hit.normal.dot(-ray.direction).max(0.0)
}
