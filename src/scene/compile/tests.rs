//! Validation errors name the field; compilation builds what the scene says and nothing else.
use super::*;
use crate::scene::json::parse_scene;
use crate::scene::FieldError;

fn base() -> proto::Scene {
    parse_scene(
        r#"{
        "camera": {"position": {"z": 5}, "lookAt": {}, "verticalFovDeg": 40, "width": 16, "height": 12},
        "materials": [{"name": "m", "lambertian": {"albedo": {"constant": {"r": 0.5, "g": 0.5, "b": 0.5}}}}],
        "shapes": [{"name": "q", "material": "m", "quad": {"corner": {"x": -1, "y": -1}, "edgeU": {"x": 2}, "edgeV": {"y": 2}}}],
        "lights": [{"rect": {"corner": {"z": 2}, "edgeU": {"x": 1}, "edgeV": {"y": 1}, "radiance": {"r": 1, "g": 1, "b": 1}}}]
    }"#,
        "base",
    )
    .unwrap()
}

fn error_of(f: impl FnOnce(&mut proto::Scene)) -> FieldError {
    let mut s = base();
    f(&mut s);
    match compile(&s, &SceneLimits::default(), None) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

fn rect(s: &mut proto::Scene) -> &mut proto::RectLight {
    match s.lights[0].kind.as_mut() {
        Some(proto::light::Kind::Rect(r)) => r,
        _ => unreachable!(),
    }
}

#[test]
fn the_base_scene_compiles() {
    let s = compile(&base(), &SceneLimits::default(), None).unwrap();
    // Two triangles of the quad plus two of the light's own surface.
    assert_eq!(s.triangle_count(), 4);
    assert_eq!((s.default_camera.width, s.default_camera.height), (16, 12));
}

#[test]
fn a_gaussian_light_takes_its_sigma_or_the_authors_default() {
    let sigma_of = |sigma: f32| {
        let mut p = base();
        rect(&mut p).profile = proto::EmissionProfile::Gaussian as i32;
        rect(&mut p).gaussian_sigma = sigma;
        match &compile(&p, &SceneLimits::default(), None).unwrap().lights[0] {
            // The compiled scene is in internal units: sigma relative to the light's size.
            crate::render::light::Light::Rect(r) => r.sigma() / r.area.sqrt(),
            _ => unreachable!(),
        }
    };
    // The 1 x 1 light: sqrt(area)/2 by default; 1/8 is the narrowest accepted.
    for (given, expected) in [(0.0, 0.5), (0.125, 0.125), (3.0, 3.0)] {
        assert!((sigma_of(given) - expected).abs() < 1e-6 * expected, "{given}: {}", sigma_of(given));
    }
}

#[test]
fn errors_name_the_offending_field() {
    let cases: Vec<(FieldError, &str)> = vec![
        (error_of(|s| s.camera = None), "scene.camera"),
        (error_of(|s| s.camera.as_mut().unwrap().width = 0), "scene.camera.width"),
        (error_of(|s| s.camera.as_mut().unwrap().vertical_fov_deg = 180.0), "scene.camera.vertical_fov_deg"),
        (error_of(|s| s.camera.as_mut().unwrap().vertical_fov_deg = f32::NAN), "scene.camera.vertical_fov_deg"),
        (
            error_of(|s| s.camera.as_mut().unwrap().look_at = Some(proto::Vec3 { x: 0.0, y: 0.0, z: 5.0 })),
            "scene.camera.look_at",
        ),
        (error_of(|s| s.camera.as_mut().unwrap().up = Some(proto::Vec3 { x: 0.0, y: 0.0, z: 1.0 })), "scene.camera.up"),
        (error_of(|s| rect(s).edge_u = Some(proto::Vec3::default())), "scene.lights[0].rect.edge_u"),
        (error_of(|s| rect(s).edge_v = Some(proto::Vec3 { x: 3.0, y: 0.0, z: 0.0 })), "scene.lights[0].rect.edge_v"),
        (
            error_of(|s| rect(s).radiance = Some(proto::Rgb { r: f32::INFINITY, g: 0.0, b: 0.0 })),
            "scene.lights[0].rect.radiance.r",
        ),
        (error_of(|s| rect(s).profile = 7), "scene.lights[0].rect.profile"),
        // A sigma for a uniform light, too narrow for the rectangle (1 / 8 = 0.125), or not a number.
        (error_of(|s| rect(s).gaussian_sigma = 0.5), "scene.lights[0].rect.gaussian_sigma"),
        (
            error_of(|s| {
                rect(s).profile = proto::EmissionProfile::Gaussian as i32;
                rect(s).gaussian_sigma = 0.12;
            }),
            "scene.lights[0].rect.gaussian_sigma",
        ),
        (
            error_of(|s| {
                rect(s).profile = proto::EmissionProfile::Gaussian as i32;
                rect(s).gaussian_sigma = f32::NAN;
            }),
            "scene.lights[0].rect.gaussian_sigma",
        ),
        (
            error_of(|s| {
                rect(s).profile = proto::EmissionProfile::Gaussian as i32;
                rect(s).gaussian_sigma = -1.0;
            }),
            "scene.lights[0].rect.gaussian_sigma",
        ),
        (error_of(|s| s.lights.push(proto::Light::default())), "scene.lights[1]"),
        (error_of(|s| s.shapes[0].material = "nope".into()), "scene.shapes[0].material"),
        (error_of(|s| s.shapes[0].geometry = None), "scene.shapes[0]"),
        (
            error_of(|s| {
                s.shapes[0].geometry = Some(proto::shape::Geometry::Sphere(proto::Sphere {
                    center: Some(proto::Vec3::default()),
                    radius: -1.0,
                    subdivisions: 0,
                }))
            }),
            "scene.shapes[0].sphere.radius",
        ),
        (
            error_of(|s| {
                s.shapes[0].geometry = Some(proto::shape::Geometry::Mesh(proto::Mesh {
                    positions: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                    indices: vec![0, 1, 3],
                    ..Default::default()
                }))
            }),
            "scene.shapes[0].mesh.indices[2]",
        ),
        (
            error_of(|s| {
                s.shapes[0].geometry = Some(proto::shape::Geometry::Mesh(proto::Mesh {
                    positions: vec![0.0, 0.0, f32::NAN, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                    indices: vec![0, 1, 2],
                    ..Default::default()
                }))
            }),
            "scene.shapes[0].mesh.positions[2]",
        ),
        (
            error_of(|s| {
                s.shapes[0].geometry = Some(proto::shape::Geometry::Mesh(proto::Mesh {
                    path: "../../etc/passwd".into(),
                    ..Default::default()
                }))
            }),
            "scene.shapes[0].mesh.path",
        ),
        (
            error_of(|s| {
                s.shapes[0].geometry = Some(proto::shape::Geometry::Instance(proto::Instance { shape: "x".into() }))
            }),
            "scene.shapes[0].instance.shape",
        ),
        (error_of(|s| s.materials[0].name = String::new()), "scene.materials[0].name"),
        (error_of(|s| s.materials.push(s.materials[0].clone())), "scene.materials[1].name"),
        (
            error_of(|s| {
                s.materials[0].kind = Some(proto::material::Kind::Glossy(proto::Glossy {
                    diffuse: Some(proto::ColorTexture {
                        kind: Some(proto::color_texture::Kind::Constant(proto::Rgb { r: 0.6, g: 0.6, b: 0.6 })),
                    }),
                    specular: Some(proto::ColorTexture {
                        kind: Some(proto::color_texture::Kind::Constant(proto::Rgb { r: 0.6, g: 0.1, b: 0.1 })),
                    }),
                    exponent: Some(proto::ScalarTexture { kind: Some(proto::scalar_texture::Kind::Constant(10.0)) }),
                    model: 0,
                }))
            }),
            "scene.materials[0].glossy.specular",
        ),
    ];
    for (e, field) in cases {
        assert_eq!(e.field, field, "{e}");
        assert!(!e.message.is_empty());
    }
}

#[test]
fn limits_are_enforced_with_clear_messages() {
    let limits = SceneLimits { max_triangles: 3, ..SceneLimits::default() };
    let e = compile(&base(), &limits, None).unwrap_err();
    assert!(e.message.contains("limit of 3 triangles"), "{e}");
    let mut s = base();
    s.camera.as_mut().unwrap().width = 5000;
    s.camera.as_mut().unwrap().height = 5000;
    let e = compile(&s, &SceneLimits::default(), None).unwrap_err();
    assert_eq!(e.field, "scene.camera.width");
    assert!(e.message.contains("exceeds the limit"), "{e}");
}

#[test]
fn instances_copy_geometry_with_their_own_transform() {
    let mut s = base();
    s.shapes.push(proto::Shape {
        material: String::new(),
        transform: Some(proto::Transform {
            translate: Some(proto::Vec3 { x: 0.0, y: 0.0, z: -1.0 }),
            ..Default::default()
        }),
        geometry: Some(proto::shape::Geometry::Instance(proto::Instance { shape: "q".into() })),
        ..Default::default()
    });
    let c = compile(&s, &SceneLimits::default(), None).unwrap();
    assert_eq!(c.triangle_count(), 6);
    assert_eq!(c.objects, 3);
}

#[test]
fn mesh_files_resolve_inside_the_root_only() {
    let dir = std::env::temp_dir().join(format!("wedge-meshroot-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::write(dir.join("meshes/tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let limits = SceneLimits { mesh_root: Some(dir.clone()), ..SceneLimits::default() };
    let mut s = base();
    s.shapes[0].geometry =
        Some(proto::shape::Geometry::Mesh(proto::Mesh { path: "meshes/tri.obj".into(), ..Default::default() }));
    let c = compile(&s, &limits, Some(&dir)).unwrap();
    assert_eq!(c.triangle_count(), 3);
    // Escaping the root is refused even though the file exists.
    std::fs::write(dir.join("secret.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    s.shapes[0].geometry =
        Some(proto::shape::Geometry::Mesh(proto::Mesh { path: "../secret.obj".into(), ..Default::default() }));
    let inner = dir.join("meshes");
    let limits = SceneLimits { mesh_root: Some(inner.clone()), ..SceneLimits::default() };
    let e = compile(&s, &limits, Some(&inner)).unwrap_err();
    assert!(e.message.contains("outside the allowed root"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn only_textured_materials_keep_texture_coordinates() {
    // The base scene's quad is constant-coloured: no uv table at all (lights have none either).
    let plain = compile(&base(), &SceneLimits::default(), None).unwrap();
    assert!(plain.geometry.uvs.is_empty());
    let mut s = base();
    s.materials[0].kind = Some(proto::material::Kind::Lambertian(proto::Lambertian {
        albedo: Some(proto::ColorTexture {
            kind: Some(proto::color_texture::Kind::Checker(proto::ColorChecker {
                even: Some(proto::Rgb { r: 0.1, g: 0.1, b: 0.1 }),
                odd: Some(proto::Rgb { r: 0.9, g: 0.9, b: 0.9 }),
                scale: 2.0,
            })),
        }),
    }));
    let textured = compile(&s, &SceneLimits::default(), None).unwrap();
    assert_eq!(textured.geometry.uvs.len(), 2);
}
