//! TP2 and TP3: lights and shadows. The blue sphere above a red plane, under a point
//! light (TP2), then under a quad light whose samples give soft shadows (TP3).

use super::*;

/// The sphere (0,0,3) r 1 (blue) and the plane through (0,-2,0) facing +y (red), seen from
/// TP1's last camera, (0,0,-2) looking at (0,0,79).
fn sphere_on_plane(name: &str, summary: &str) -> SceneDescription {
    let mut d = SceneDescription::new(name, CameraDesc::new(Vec3::new(0.0, 0.0, -2.0), Vec3::new(0.0, 0.0, 79.0)));
    d.summary = summary.to_string();
    d.materials.push(("BlueColor".into(), Material::Color(BLUE)));
    d.materials.push(("RedColor".into(), Material::Color(RED)));
    d.objects.push(ObjectDesc {
        name: "Sphere1".into(),
        shape: ShapeDesc::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0)),
        material: Some("BlueColor".into()),
    });
    d.objects.push(ObjectDesc {
        name: "Plane1".into(),
        shape: ShapeDesc::Plane(Plane::new(Vec3::new(0.0, -2.0, 0.0), Vec3::Y)),
        material: Some("RedColor".into()),
    });
    d.spp = 4;
    d
}

/// TP2: `PointLight((1,10,1), WHITE, 100)`, hard shadows.
pub(super) fn plane_point(name: &str) -> SceneDescription {
    let mut d = sphere_on_plane(name, "TP2: a blue sphere on a red plane under a point light, hard shadow");
    d.lights.push(Light::Point { position: Vec3::new(1.0, 10.0, 1.0), color: WHITE, power: 100.0 });
    d.integrator = Integrator::DirectLighting { light_samples: 1 };
    d
}

/// TP3: `QuadLight((1,10,2), u = (-2,0,0), v = (0,0,2), WHITE, 40)`, 16 samples per
/// shading point: soft shadows.
pub(super) fn quad_soft(name: &str) -> SceneDescription {
    let mut d = sphere_on_plane(name, "TP3: the TP2 scene under a quad light, soft shadows (16 light samples)");
    d.lights.push(Light::Quad {
        corner: Vec3::new(1.0, 10.0, 2.0),
        u: Vec3::new(-2.0, 0.0, 0.0),
        v: Vec3::new(0.0, 0.0, 2.0),
        color: WHITE,
        power: 40.0,
    });
    d.integrator = Integrator::DirectLighting { light_samples: 16 };
    d
}
