//! TP1: the camera and the sphere. One blue sphere, seen by the ray-cast integrator (no
//! light yet: the colour times the cosine to the eye), from the session's five cameras.

use super::*;

/// The blue sphere of centre (0,0,3) and radius 1, seen from `camera`.
pub(super) fn sphere(name: &str, camera: CameraDesc, summary: &str) -> SceneDescription {
    let mut d = SceneDescription::new(name, camera);
    d.summary = summary.to_string();
    d.materials.push(("BlueColor".into(), Material::Color(BLUE)));
    d.objects.push(ObjectDesc {
        name: "Sphere1".into(),
        shape: ShapeDesc::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0)),
        material: Some("BlueColor".into()),
    });
    d.integrator = Integrator::RayCast;
    d.spp = 4;
    d
}
