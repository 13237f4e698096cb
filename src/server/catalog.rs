//! The `ListScenes` answer: the built-in scenes, compiled once at server start for their sizes.
use crate::api::request::Limits;
use crate::proto::{ListScenesResponse, SceneInfo};
use crate::scene;

/// Describes every built-in scene. A scene that fails to compile under `limits` is still listed
/// (with the camera's resolution and 0 triangles) and logged as a warning.
pub fn builtin_catalog(limits: &Limits) -> ListScenesResponse {
    let scene_limits = crate::api::request::scene_limits(limits);
    let scenes = scene::builtin::list()
        .into_iter()
        .map(|b| {
            let (width, height, triangles, lights) =
                match scene::compile(&b.scene, &scene_limits, limits.mesh_root.as_deref()) {
                    Ok(compiled) => (
                        compiled.default_camera.width,
                        compiled.default_camera.height,
                        u32::try_from(compiled.triangle_count()).unwrap_or(u32::MAX),
                        compiled.lights.len(),
                    ),
                    Err(e) => {
                        tracing::warn!(scene = b.name, error = %e, "built-in scene does not compile");
                        let cam = b.scene.camera.unwrap_or_default();
                        (cam.width, cam.height, 0, b.scene.lights.len())
                    }
                };
            SceneInfo {
                name: b.name.to_string(),
                description: b.description,
                width,
                height,
                triangles,
                lights: u32::try_from(lights).unwrap_or(u32::MAX),
            }
        })
        .collect();
    ListScenesResponse { scenes }
}
