//! Scene descriptions (the proto `Scene`): validation, scene files, built-in scenes, and
//! compilation into the tracer's `render::scene::Scene`.
use crate::proto;
use std::fmt;
use std::path::{Path, PathBuf};

/// A problem with one field of a request or scene, named by its path
/// (e.g. `scene.lights[0].rect.edge_u: must be non-zero`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldError {
    pub field: String,
    pub message: String,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}
impl std::error::Error for FieldError {}

/// Size limits applied while compiling a scene.
#[derive(Clone, Debug)]
pub struct SceneLimits {
    pub max_triangles: u64,
    pub max_pixels: u64,
    /// Mesh files must resolve inside this directory; `None`: mesh paths are refused
    /// (e.g. for scenes that arrive over gRPC).
    pub mesh_root: Option<PathBuf>,
}

/// Validates and compiles a scene. `base_dir` is where relative mesh paths start.
pub fn compile(
    scene: &proto::Scene,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> Result<crate::render::scene::Scene, FieldError> {
    let _ = (scene, limits, base_dir);
    Err(FieldError { field: "scene".into(), message: "in progress".into() })
}

pub mod builtin {
    use crate::proto;
    pub struct BuiltinScene {
        pub name: &'static str,
        pub description: String,
        pub scene: proto::Scene,
    }
    /// All built-in scenes, in a stable order.
    pub fn list() -> Vec<BuiltinScene> {
        Vec::new()
    }
    pub fn get(name: &str) -> Option<proto::Scene> {
        list().into_iter().find(|s| s.name == name).map(|s| s.scene)
    }
}
