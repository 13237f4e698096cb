//! Edits give the scene a fresh compile of the edited description gives, bit for bit, without
//! building the BVH again; bad edits name their field.
use super::*;
use crate::pipeline::job::{CancelToken, Halt, Method, RenderJob};
use crate::pipeline::progressive;
use crate::render::scene::CameraDesc;
use crate::scene::json::parse_scene;
use crate::scene::{builtin, compile, SceneLimits};
use std::sync::Arc;

fn cornell() -> proto::Scene {
    builtin::get("cornell").expect("built-in cornell")
}

fn compiled(scene: &proto::Scene) -> Scene {
    compile(scene, &SceneLimits::default(), None).unwrap()
}

/// The final colour of a small 1-bounce `uniform` render, as bits.
fn image(scene: Scene) -> Vec<[u32; 3]> {
    let scene = Arc::new(scene);
    let mut job = RenderJob::new(Arc::clone(&scene), Method::Uniform, Halt::passes(2));
    job.view = scene.view(&CameraDesc { width: 24, height: 20, ..scene.default_camera.clone() });
    job.bounces = 1;
    job.seed = 7;
    let mut last = Vec::new();
    progressive::render(&job, &CancelToken::new(), &mut |f| {
        last = f.color.iter().map(|c| c.map(f32::to_bits)).collect();
        true
    })
    .unwrap();
    assert!(!last.is_empty());
    last
}

fn material(json: &str) -> proto::Material {
    parse_scene(&format!(r#"{{"materials": [{json}]}}"#), "test").unwrap().materials.remove(0)
}

fn light(json: &str) -> proto::Light {
    parse_scene(&format!(r#"{{"lights": [{json}]}}"#), "test").unwrap().lights.remove(0)
}

fn glossy(name: &str) -> proto::Material {
    material(&format!(
        r#"{{"name": "{name}", "glossy": {{"diffuse": {{"constant": {{"r": 0.3, "g": 0.1, "b": 0.1}}}},
            "specular": {{"constant": {{"r": 0.5, "g": 0.5, "b": 0.5}}}}, "exponent": {{"constant": 200}}}}}}"#
    ))
}

fn rect_light(scene: &proto::Scene, shift_x: f32, radiance: f32) -> proto::Light {
    let mut l = scene.lights[0].clone();
    let Some(proto::light::Kind::Rect(r)) = l.kind.as_mut() else { panic!("cornell's light is a rect") };
    r.corner.as_mut().unwrap().x += shift_x;
    r.radiance = Some(proto::Rgb { r: radiance, g: radiance, b: radiance });
    l
}

#[test]
fn a_material_edit_renders_as_a_fresh_compile_and_shares_the_bvh() {
    let source = cornell();
    let before = compiled(&source);
    let edit = proto::SceneEdit { materials: vec![glossy("red")], lights: vec![] };
    let (header, after) = apply(&super::header(&source), &before, &edit, &SceneLimits::default()).unwrap();
    assert!(Arc::ptr_eq(&after.geometry, &before.geometry), "the BVH is shared");
    assert_eq!(header.materials.iter().find(|m| m.name == "red"), Some(&glossy("red")));
    let mut edited = source.clone();
    let red = edited.materials.iter().position(|m| m.name == "red").unwrap();
    edited.materials[red] = glossy("red");
    let (got, fresh, old) = (image(after), image(compiled(&edited)), image(before));
    assert_eq!(got, fresh, "the edit renders as a fresh compile");
    assert_ne!(got, old, "and differs from the scene before it");
}

#[test]
fn a_moved_light_refits_the_bvh_and_renders_as_a_fresh_compile() {
    let source = cornell();
    let before = compiled(&source);
    // Within the box's bounds, so the fresh compile has the same internal frame.
    let light = rect_light(&source, -60.0, 12.0);
    let edit =
        proto::SceneEdit { materials: vec![], lights: vec![proto::LightEdit { index: 0, light: Some(light.clone()) }] };
    let (_, after) = apply(&super::header(&source), &before, &edit, &SceneLimits::default()).unwrap();
    assert!(!Arc::ptr_eq(&after.geometry, &before.geometry), "moved light triangles need new geometry");
    let mut edited = source.clone();
    edited.lights[0] = light;
    let fresh = compiled(&edited);
    assert_eq!(after.light_tris, fresh.light_tris);
    assert_eq!(format!("{:?}", after.lights), format!("{:?}", fresh.lights));
    assert_eq!(image(after), image(fresh), "the refitted scene renders as a fresh compile");

    // A radiance change alone moves nothing: the geometry stays shared.
    let edit = proto::SceneEdit {
        materials: vec![],
        lights: vec![proto::LightEdit { index: 0, light: Some(rect_light(&source, 0.0, 5.0)) }],
    };
    let (_, dimmer) = apply(&super::header(&source), &before, &edit, &SceneLimits::default()).unwrap();
    assert!(Arc::ptr_eq(&dimmer.geometry, &before.geometry));
}

#[test]
fn bad_edits_name_their_field_and_change_nothing() {
    let source = cornell();
    let before = compiled(&source);
    let refuse = |edit: proto::SceneEdit| {
        apply(&super::header(&source), &before, &edit, &SceneLimits::default()).map(|_| ()).unwrap_err().field
    };
    let mats = |m: proto::Material| proto::SceneEdit { materials: vec![m], lights: vec![] };
    let lights = |index: u32, light: Option<proto::Light>| proto::SceneEdit {
        materials: vec![],
        lights: vec![proto::LightEdit { index, light }],
    };
    assert_eq!(refuse(mats(glossy("chrome"))), "edit.materials[0].name");
    let mut steep = glossy("red");
    if let Some(proto::material::Kind::Glossy(g)) = steep.kind.as_mut() {
        g.exponent = Some(proto::ScalarTexture { kind: Some(proto::scalar_texture::Kind::Constant(-3.0)) });
    }
    assert_eq!(refuse(mats(steep)), "edit.materials[0].glossy.exponent.constant");
    let checker = material(
        r#"{"name": "white", "lambertian": {"albedo": {"checker": {"even": {"r": 1}, "odd": {"g": 1}, "scale": 4}}}}"#,
    );
    assert_eq!(refuse(mats(checker)), "edit.materials[0]");
    assert_eq!(refuse(lights(3, Some(rect_light(&source, 0.0, 1.0)))), "edit.lights[0].index");
    assert_eq!(refuse(lights(0, None)), "edit.lights[0].light");
    let point = light(r#"{"point": {"position": {"y": 500}, "intensity": {"r": 1e5}}}"#);
    assert_eq!(refuse(lights(0, Some(point))), "edit.lights[0].light");
    let mut flat = rect_light(&source, 0.0, 1.0);
    if let Some(proto::light::Kind::Rect(r)) = flat.kind.as_mut() {
        r.edge_u = Some(proto::Vec3 { x: 0.0, y: 0.0, z: 0.0 });
    }
    assert_eq!(refuse(lights(0, Some(flat))), "edit.lights[0].light.rect.edge_u");
}

#[test]
fn environment_edits_render_as_fresh_compiles_and_untouched_maps_are_kept() {
    use crate::render::environment::EnvironmentRadiance;
    use crate::render::light::Light;
    let mut source = cornell();
    source.lights.push(light(r#"{"environment": {"sky": {"resolution": 32}}}"#));
    let before = compiled(&source);
    let map_of = |s: &Scene| match &s.lights[1] {
        Light::Environment(e) => match &e.radiance {
            EnvironmentRadiance::Map(m) => Arc::clone(m),
            EnvironmentRadiance::Constant(_) => panic!("a map"),
        },
        _ => panic!("an environment light"),
    };
    // A material edit leaves the sky alone: its compiled map is kept, not baked again.
    let edit = proto::SceneEdit { materials: vec![glossy("red")], lights: vec![] };
    let (_, after) = apply(&super::header(&source), &before, &edit, &SceneLimits::default()).unwrap();
    assert!(Arc::ptr_eq(&map_of(&after), &map_of(&before)));
    // Editing the sky itself gives what a fresh compile of the edited scene gives.
    let brighter = light(r#"{"environment": {"sky": {"resolution": 32}, "scale": 3, "rotationDeg": 40}}"#);
    let edit = proto::SceneEdit {
        materials: vec![],
        lights: vec![proto::LightEdit { index: 1, light: Some(brighter.clone()) }],
    };
    let (_, after) = apply(&super::header(&source), &before, &edit, &SceneLimits::default()).unwrap();
    let mut edited = source.clone();
    edited.lights[1] = brighter;
    assert_eq!(image(after), image(compiled(&edited)));
    // Another kind in its place is refused by name.
    let edit = proto::SceneEdit {
        materials: vec![],
        lights: vec![proto::LightEdit { index: 1, light: Some(source.lights[0].clone()) }],
    };
    let e = apply(&super::header(&source), &before, &edit, &SceneLimits::default()).map(|_| ()).unwrap_err();
    assert_eq!(e.field, "edit.lights[0].light");
}
