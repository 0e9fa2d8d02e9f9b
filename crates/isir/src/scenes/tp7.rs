//! TP7: implicit surfaces, rendered by sphere tracing, in the TP6 room.

use super::*;

/// TP7: implicit surfaces, sphere traced, in the TP6 room (the Cornell planes without the
/// rear one) under its point light: a torus, a rounded box, a capsule, a sphere cut by a
/// box (intersection), and a smooth union of two spheres minus a box.
pub(super) fn tp7_implicit() -> SceneDescription {
    let mut d = SceneDescription::new("tp7-implicit", CameraDesc::new(Vec3::new(0.0, 2.0, -6.0), Vec3::new(0.0, 0.0, 79.0)));
    d.summary = "TP7: implicit surfaces by sphere tracing (torus, rounded box, capsule, CSG, smooth union) in the TP6 room".into();
    for (n, c) in [
        ("Red", RED),
        ("Green", GREEN),
        ("Blue", BLUE),
        ("Grey", GREY),
        ("Magenta", MAGENTA),
        ("Yellow", YELLOW),
        ("Cyan", CYAN),
        ("White", WHITE),
    ] {
        d.materials.push((n.to_string(), Material::Lambert(c)));
    }
    let planes = [
        ("PlaneGround", Vec3::new(0.0, -3.0, 0.0), Vec3::Y, "Grey"),
        ("PlaneLeft", Vec3::new(5.0, 0.0, 0.0), -Vec3::X, "Red"),
        ("PlaneCeiling", Vec3::new(0.0, 7.0, 0.0), -Vec3::Y, "Green"),
        ("PlaneRight", Vec3::new(-5.0, 0.0, 0.0), Vec3::X, "Blue"),
        ("PlaneFront", Vec3::new(0.0, 0.0, 10.0), -Vec3::Z, "Magenta"),
    ];
    for (n, p, normal, m) in planes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Plane(Plane::new(p, normal)), material: Some(m.to_string()) });
    }
    let tilt = |axis: Vec3, degrees: f32| Quat::from_axis_angle(axis.normalize(), degrees.to_radians());
    let blob = Sdf::sphere(Vec3::new(-0.55, 0.0, 0.0), 0.8)
        .smooth_union(Sdf::sphere(Vec3::new(0.6, 0.25, 0.0), 0.65), 0.6)
        .subtract(Sdf::Box { half: Vec3::new(1.5, 0.35, 0.35) }.translated(Vec3::new(0.0, 0.55, -0.7)));
    let shapes = [
        ("Torus", Sdf::Torus { major: 0.9, minor: 0.3 }.transformed(Vec3::new(3.0, -1.8, 4.6), tilt(Vec3::X, -60.0), 1.0), "Yellow"),
        (
            "RoundedBox",
            Sdf::RoundedBox { half: Vec3::splat(0.8), radius: 0.2 }.transformed(Vec3::new(-3.0, -2.2, 5.2), tilt(Vec3::Y, 30.0), 1.0),
            "Cyan",
        ),
        ("Capsule", Sdf::Capsule { a: Vec3::new(-0.9, -2.6, 7.0), b: Vec3::new(0.9, 0.4, 7.5), radius: 0.4 }, "White"),
        ("Blob", blob.translated(Vec3::new(0.7, -2.15, 3.0)), "Red"),
        (
            "CutSphere",
            Sdf::Sphere { radius: 0.75 }.intersection(Sdf::Box { half: Vec3::splat(0.58) }).transformed(
                Vec3::new(-1.45, -2.42, 2.9),
                tilt(Vec3::new(1.0, 1.0, 0.0), 25.0),
                1.0,
            ),
            "Green",
        ),
    ];
    for (n, sdf, m) in shapes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Implicit(sdf), material: Some(m.to_string()) });
    }
    d.lights.push(Light::Point { position: Vec3::new(0.0, 5.0, 0.0), color: WHITE, power: 100.0 });
    d.integrator = Integrator::DirectLighting { light_samples: 1 };
    d.spp = 4;
    d
}
