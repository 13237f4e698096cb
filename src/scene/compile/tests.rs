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

/// The base scene with an environment light, given as the JSON of its `environment` field.
fn with_environment(json: &str) -> proto::Scene {
    let mut s = base();
    let text = format!(r#"{{"lights": [{{"environment": {json}}}]}}"#);
    s.lights.extend(parse_scene(&text, "env").unwrap().lights);
    s
}

fn env_error(json: &str, limits: &SceneLimits) -> FieldError {
    compile(&with_environment(json), limits, None).map(|_| ()).unwrap_err()
}

#[test]
fn environment_lights_compile_from_a_constant_a_map_and_the_sky() {
    use crate::render::light::Light;
    let limits = SceneLimits::default();
    let c =
        compile(&with_environment(r#"{"constant": {"r": 0.5, "g": 1, "b": 2}, "scale": 2}"#), &limits, None).unwrap();
    let Light::Environment(e) = &c.lights[1] else { panic!("an environment light") };
    assert_eq!(e.radiance(Vec3::X), Vec3::new(1.0, 2.0, 4.0));
    assert_eq!(c.background(Vec3::NEG_Y), Vec3::new(1.0, 2.0, 4.0));
    // An inline 2 x 1 map: the left half faces -Z (u = 0 at its left edge), the right +Z.
    let map = r#"{"map": {"width": 2, "height": 1, "rgb": [1, 1, 1, 3, 3, 3]}}"#;
    let c = compile(&with_environment(map), &limits, None).unwrap();
    assert!((c.background(Vec3::NEG_Z).x - 2.0).abs() < 1e-5, "between the two texel centres");
    assert!((c.background(Vec3::Z).x - 2.0).abs() < 1e-5);
    assert!((c.background(Vec3::X).x - 1.0).abs() < 1e-5, "the first texel's centre, u = 1/4");
    // Turned 90 degrees about +Y, the first texel's centre faces -Z.
    let turned = r#"{"map": {"width": 2, "height": 1, "rgb": [1, 1, 1, 3, 3, 3]}, "rotationDeg": 90}"#;
    let c = compile(&with_environment(turned), &limits, None).unwrap();
    assert!((c.background(Vec3::NEG_Z).x - 1.0).abs() < 1e-5);
    // The sky: blue overhead, the sun where it was put.
    let c = compile(&with_environment(r#"{"sky": {"sunElevationDeg": 30, "resolution": 64}}"#), &limits, None).unwrap();
    let zenith = c.background(Vec3::Y);
    assert!(zenith.z > zenith.x, "{zenith}");
    let sun = Vec3::new(0.0, 0.5, -(0.75f32).sqrt());
    assert!(c.background(sun).x > 100.0 * zenith.x);
    // No shape needed: a scene of an environment alone compiles.
    let mut bare = with_environment(r#"{"constant": {"r": 1, "g": 1, "b": 1}}"#);
    bare.shapes.clear();
    bare.lights.remove(0);
    assert!(compile(&bare, &limits, None).is_ok());
}

#[test]
fn bad_environment_lights_name_their_field() {
    let limits = SceneLimits::default();
    let cases = [
        (r#"{}"#, "scene.lights[1].environment", "needs a radiance"),
        (r#"{"constant": {"r": -1, "g": 1, "b": 1}}"#, "scene.lights[1].environment.constant.r", ">= 0"),
        (r#"{"constant": {"r": 1, "g": 1, "b": 1}, "scale": -2}"#, "scene.lights[1].environment.scale", "got -2"),
        (r#"{"constant": {"r": 1, "g": 1, "b": 1}, "up": {}}"#, "scene.lights[1].environment.up", "non-zero"),
        (r#"{"map": {"width": 2, "height": 1, "rgb": [1, 1, 1]}}"#, "scene.lights[1].environment.map.rgb", "6 numbers"),
        (r#"{"map": {"width": 0, "height": 1}}"#, "scene.lights[1].environment.map", "width and a height"),
        (
            r#"{"map": {"width": 1, "height": 1, "rgb": [1, "NaN", 1]}}"#,
            "scene.lights[1].environment.map.rgb[1]",
            "finite",
        ),
        (r#"{"sky": {"sunElevationDeg": 91}}"#, "scene.lights[1].environment.sky.sun_elevation_deg", "[-90, 90]"),
        (r#"{"sky": {"sunRadiusDeg": 50}}"#, "scene.lights[1].environment.sky.sun_radius_deg", "[0, 45]"),
        (r#"{"sky": {"resolution": 4}}"#, "scene.lights[1].environment.sky.resolution", "[8, 8192]"),
        (r#"{"path": "sky.hdr"}"#, "scene.lights[1].environment.path", "not allowed here"),
    ];
    for (json, field, message) in cases {
        let e = env_error(json, &limits);
        assert_eq!(e.field, field, "{json}: {e}");
        assert!(e.message.contains(message), "{json}: {e}");
    }
    // One environment per scene: the second is named.
    let mut s = with_environment(r#"{"constant": {"r": 1, "g": 1, "b": 1}}"#);
    s.lights.push(s.lights[1].clone());
    let e = compile(&s, &limits, None).map(|_| ()).unwrap_err();
    assert_eq!(e.field, "scene.lights[2].environment");
}

#[test]
fn the_environment_texel_limit_holds_for_maps_and_skies() {
    let limits = SceneLimits { max_environment_texels: 128, ..SceneLimits::default() };
    let rgb = vec!["1"; 3 * 16 * 8].join(", ");
    let fits = format!(r#"{{"map": {{"width": 16, "height": 8, "rgb": [{rgb}]}}}}"#);
    assert!(compile(&with_environment(&fits), &limits, None).is_ok());
    let rgb = vec!["1"; 3 * 17 * 8].join(", ");
    let over = format!(r#"{{"map": {{"width": 17, "height": 8, "rgb": [{rgb}]}}}}"#);
    let e = env_error(&over, &limits);
    assert!(e.field == "scene.lights[1].environment.map" && e.message.contains("limit of 128"), "{e}");
    assert!(compile(&with_environment(r#"{"sky": {"resolution": 16}}"#), &limits, None).is_ok());
    let e = env_error(r#"{"sky": {"resolution": 18}}"#, &limits);
    assert!(e.field.ends_with("sky.resolution") && e.message.contains("limit of 128"), "{e}");
    // The default sky (512 x 256) is over this limit too: the limit is never skipped.
    let e = env_error(r#"{"sky": {}}"#, &limits);
    assert!(e.message.contains("limit of 128"), "{e}");
}

#[test]
fn map_files_resolve_inside_the_root_only_and_name_the_file() {
    let dir = std::env::temp_dir().join(format!("wedge-maproot-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("maps")).unwrap();
    let pixels = vec![image::Rgb([0.25f32, 0.5, 1.0]); 8];
    let file = std::fs::File::create(dir.join("maps/sky.hdr")).unwrap();
    image::codecs::hdr::HdrEncoder::new(file).encode(&pixels, 4, 2).unwrap();
    let limits = SceneLimits { mesh_root: Some(dir.clone()), ..SceneLimits::default() };
    let s = with_environment(r#"{"path": "maps/sky.hdr"}"#);
    let c = compile(&s, &limits, Some(&dir)).unwrap();
    assert_eq!(c.background(Vec3::Y), Vec3::new(0.25, 0.5, 1.0));
    // Outside the root: refused. A broken file: refused, with its name.
    std::fs::write(dir.join("broken.hdr"), "#?RADIANCE\nnot a header").unwrap();
    let inner = dir.join("maps");
    let limits = SceneLimits { mesh_root: Some(inner.clone()), ..SceneLimits::default() };
    let e = compile(&with_environment(r#"{"path": "../broken.hdr"}"#), &limits, Some(&inner)).map(|_| ()).unwrap_err();
    assert!(e.message.contains("outside the allowed root"), "{e}");
    let limits = SceneLimits { mesh_root: Some(dir.clone()), ..SceneLimits::default() };
    let e = compile(&with_environment(r#"{"path": "broken.hdr"}"#), &limits, Some(&dir)).map(|_| ()).unwrap_err();
    assert!(e.field == "scene.lights[1].environment.path" && e.message.contains("broken.hdr"), "{e}");
    // What `wedge client` sends instead: the same map inline.
    let mut inlined = with_environment(r#"{"path": "maps/sky.hdr"}"#);
    crate::scene::inline_files(&mut inlined, &dir, &dir, &SceneLimits::default()).unwrap();
    let c = compile(&inlined, &SceneLimits::default(), None).unwrap();
    assert_eq!(c.background(Vec3::Y), Vec3::new(0.25, 0.5, 1.0));
    std::fs::remove_dir_all(&dir).unwrap();
}
