//! TP4 (the handout in `seed/`): meshes in the room of six coloured planes, and the
//! conference room under a quad light.

use super::*;

/// TP4 Annex A: six coloured infinite planes, a cyan mesh, a point light.
pub(super) fn tp4_room(name: &str, model: &'static str, shading: Shading, camera: Vec3, summary: &str) -> SceneDescription {
    let mut d = SceneDescription::new(name, CameraDesc::new(camera, Vec3::new(0.0, 0.0, 79.0)));
    d.summary = summary.to_string();
    for (n, c) in [
        ("RedColor", RED),
        ("GreenColor", GREEN),
        ("BlueColor", BLUE),
        ("GreyColor", GREY),
        ("MagentaColor", MAGENTA),
        ("YellowColor", YELLOW),
        ("CyanColor", CYAN),
    ] {
        d.materials.push((n.to_string(), Material::Color(c)));
    }
    d.objects.push(ObjectDesc {
        name: format!("{model}_defaultobject"),
        shape: ShapeDesc::Mesh { source: MeshSource::Builtin(model), shading },
        material: Some("CyanColor".into()),
    });
    let planes = [
        ("PlaneGround", Vec3::new(0.0, -3.0, 0.0), Vec3::Y, "GreyColor"),
        ("PlaneLeft", Vec3::new(5.0, 0.0, 0.0), -Vec3::X, "RedColor"),
        ("PlaneCeiling", Vec3::new(0.0, 7.0, 0.0), -Vec3::Y, "GreenColor"),
        ("PlaneRight", Vec3::new(-5.0, 0.0, 0.0), Vec3::X, "BlueColor"),
        ("PlaneFront", Vec3::new(0.0, 0.0, 10.0), -Vec3::Z, "MagentaColor"),
        ("PlaneRear", Vec3::new(0.0, 0.0, -10.0), Vec3::Z, "YellowColor"),
    ];
    for (n, p, normal, m) in planes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Plane(Plane::new(p, normal)), material: Some(m.to_string()) });
    }
    d.lights.push(Light::Point { position: Vec3::new(0.0, 3.0, -5.0), color: WHITE, power: 100.0 });
    d.integrator = Integrator::DirectLighting { light_samples: 1 };
    d.spp = 4;
    d
}

/// TP4 figure 2: the conference room under a quad light.
pub(super) fn tp4_conference() -> SceneDescription {
    let mut d = SceneDescription::new("tp4-conference", CameraDesc::new(Vec3::new(-250.0, 500.0, 330.0), Vec3::new(0.0, 350.0, 100.0)));
    d.summary = "TP4 figure 2: conference.obj (331,179 triangles) under a quad light, soft shadows".into();
    d.objects.push(ObjectDesc {
        name: "conference".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::Builtin("conference"), shading: Shading::Smooth },
        material: None,
    });
    d.lights.push(Light::Quad {
        corner: Vec3::new(900.0, 600.0, -300.0),
        u: Vec3::new(-800.0, 0.0, 0.0),
        v: Vec3::new(0.0, 0.0, 300.0),
        color: WHITE,
        power: 20.0,
    });
    d.integrator = Integrator::DirectLighting { light_samples: 8 };
    d.spp = 4;
    d
}
