//! Scene descriptions (the proto `Scene`): validation and compilation into the tracer's scene,
//! scene files (canonical protobuf JSON), and the built-in scenes.
use crate::proto;
use std::fmt;
use std::path::{Path, PathBuf};

pub mod builtin;
mod compile;
pub mod edit;
mod environment;
pub mod envmap;
pub(crate) mod fields;
pub mod json;
pub mod locate;
pub mod meshfile;
mod shapes;

pub use compile::MAX_EXPONENT;
pub use environment::MAX_SKY_RESOLUTION;

/// Replaces every file a scene file names (mesh files, environment maps) with the file's
/// contents inline, so that the scene can travel over gRPC (servers refuse file paths). Paths
/// resolve as in `compile`: from `base_dir`, inside `root`.
pub fn inline_files(
    scene: &mut proto::Scene,
    base_dir: &Path,
    root: &Path,
    limits: &SceneLimits,
) -> Result<(), FieldError> {
    for (i, shape) in scene.shapes.iter_mut().enumerate() {
        let Some(proto::shape::Geometry::Mesh(m)) = &mut shape.geometry else { continue };
        if m.path.is_empty() {
            continue;
        }
        let field = format!("scene.shapes[{i}].mesh.path");
        let data = compile::load_mesh_file(&field, &m.path, limits.max_triangles, root, base_dir)?;
        *m = proto::Mesh {
            positions: data.positions.iter().flatten().copied().collect(),
            indices: data.indices.iter().flatten().copied().collect(),
            normals: data.normals.map(|n| n.iter().flatten().copied().collect()).unwrap_or_default(),
            uvs: data.uvs.map(|n| n.iter().flatten().copied().collect()).unwrap_or_default(),
            path: String::new(),
        };
    }
    for (i, light) in scene.lights.iter_mut().enumerate() {
        let Some(proto::light::Kind::Environment(e)) = &mut light.kind else { continue };
        let Some(proto::environment_light::Radiance::Path(file)) = &e.radiance else { continue };
        let field = format!("scene.lights[{i}].environment.path");
        let resolved = fields::resolve_file(&field, file, root, base_dir)?;
        let data = envmap::load_map(&resolved, limits.max_environment_texels)
            .map_err(|message| FieldError { field: field.clone(), message })?;
        e.radiance = Some(proto::environment_light::Radiance::Map(proto::EnvironmentMap {
            width: data.width as u32,
            height: data.height as u32,
            rgb: data.rgb.iter().flatten().copied().collect(),
        }));
    }
    Ok(())
}

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
    /// Mesh and environment map files must resolve inside this directory; `None`: file
    /// paths are refused (e.g. for scenes that arrive over gRPC).
    pub mesh_root: Option<PathBuf>,
    /// Most texels an environment map (a file, an inline map or a baked sky) may have.
    pub max_environment_texels: u64,
}

/// The default of `SceneLimits::max_environment_texels`: a 4K x 2K map (about 200 MB with its
/// sampling tables).
pub const DEFAULT_MAX_ENVIRONMENT_TEXELS: u64 = 4096 * 2048;

impl Default for SceneLimits {
    fn default() -> Self {
        SceneLimits {
            max_triangles: 5_000_000,
            max_pixels: 4096 * 4096,
            mesh_root: None,
            max_environment_texels: DEFAULT_MAX_ENVIRONMENT_TEXELS,
        }
    }
}

/// Validates and compiles a scene. `base_dir` is where relative mesh paths start. Errors name
/// the field (`scene.shapes[2].sphere.radius: must be > 0, got -1`).
pub fn compile(
    scene: &proto::Scene,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> Result<crate::render::scene::Scene, FieldError> {
    compile::compile(scene, limits, base_dir)
}

/// Validates a camera against the image-size limit; `path` names it in errors.
pub fn camera(
    path: &str,
    camera: &Option<proto::Camera>,
    limits: &SceneLimits,
) -> Result<crate::render::scene::CameraDesc, FieldError> {
    compile::camera(path, camera, limits)
}

/// `compile` up to the BVH build, which the caller starts with `SceneBuilder::build` after
/// choosing its options (the ray benchmark compares BVH layouts).
pub fn compile_builder(
    scene: &proto::Scene,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> Result<crate::render::scene::SceneBuilder, FieldError> {
    compile::compile_builder(scene, limits, base_dir)
}
