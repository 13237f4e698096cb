//! Validates a proto `Scene` and compiles it into the tracer's scene, in one walk, so that every
//! field the tracer reads has been checked and every error names its field.
use super::fields::{direction, enum_value, err, finite, in_range, positive, resolve_file, rgb, vec3, FieldResult};
use super::meshfile;
use super::shapes::{self, TriMesh};
use super::SceneLimits;
use crate::proto;
use crate::render::light::{EmissionProfile, Light, PointLight, RectLight};
use crate::render::material::{GlossyModel, Material};
use crate::render::scene::{CameraDesc, Scene, SceneBuilder};
use crate::render::texture::Texture;
use glam::{Mat4, Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Largest Phong/Blinn-Phong exponent accepted (beyond it the lobe is a mirror in f32).
pub const MAX_EXPONENT: f32 = 1e6;
pub use super::fields::MAX_RADIANCE;
/// Largest point-light intensity (see `MAX_RADIANCE`).
pub const MAX_INTENSITY: f32 = 1e12;

pub fn compile(scene: &proto::Scene, limits: &SceneLimits, base_dir: Option<&Path>) -> FieldResult<Scene> {
    Ok(compile_builder(scene, limits, base_dir)?.build())
}

/// Validates the scene and collects it, before the BVH is built (so that a caller can choose
/// its build options).
pub fn compile_builder(
    scene: &proto::Scene,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> FieldResult<SceneBuilder> {
    let camera = camera("scene.camera", &scene.camera, limits)?;
    let mut b = SceneBuilder::new(camera);
    let materials = materials("scene.materials", &scene.materials, &mut b)?;
    let mut budget = limits.max_triangles;
    for (i, light) in scene.lights.iter().enumerate() {
        add_light(&format!("scene.lights[{i}]"), light, &mut b, limits, base_dir)?;
    }
    one_environment(&scene.lights)?;
    // Rect lights are geometry too.
    budget = budget.saturating_sub(b.geometry.len() as u64);
    // Instances refer to shapes by name: meshes are built once and placed by each transform.
    let names = shape_names(&scene.shapes)?;
    let mut local: HashMap<usize, TriMesh> = HashMap::new();
    for (i, shape) in scene.shapes.iter().enumerate() {
        let path = format!("scene.shapes[{i}]");
        let xf = shapes::transform(&format!("{path}.transform"), &shape.transform)?;
        let (source, material_name) = match &shape.geometry {
            Some(proto::shape::Geometry::Instance(inst)) => {
                let Some(&j) = names.get(inst.shape.as_str()) else {
                    return err(format!("{path}.instance.shape"), format!("no shape named {:?}", inst.shape));
                };
                if matches!(scene.shapes[j].geometry, Some(proto::shape::Geometry::Instance(_))) {
                    return err(format!("{path}.instance.shape"), "cannot refer to another instance");
                }
                let m = if shape.material.is_empty() { &scene.shapes[j].material } else { &shape.material };
                (j, m)
            }
            _ => (i, &shape.material),
        };
        let Some(&material) = materials.get(material_name.as_str()) else {
            return err(format!("{path}.material"), format!("no material named {material_name:?}"));
        };
        if let std::collections::hash_map::Entry::Vacant(slot) = local.entry(source) {
            let spath = format!("scene.shapes[{source}]");
            slot.insert(shape_mesh(&spath, &scene.shapes[source], budget, limits, base_dir)?);
        }
        let mesh = &local[&source];
        let n = mesh.triangle_count() as u64;
        if n > budget {
            return err(path, format!("the scene exceeds the limit of {} triangles", limits.max_triangles));
        }
        budget -= n;
        let object = b.new_object();
        let uses_uv = b.materials[material as usize].uses_uv();
        place(&mut b, mesh, &xf, material, object, uses_uv);
    }
    Ok(b)
}

/// Validates a camera (`path` names it in errors) against the image-size limit.
pub fn camera(path: &str, c: &Option<proto::Camera>, limits: &SceneLimits) -> FieldResult<CameraDesc> {
    let Some(c) = c else { return err(path, "is required") };
    let position = vec3(&format!("{path}.position"), &c.position)?;
    let look_at = vec3(&format!("{path}.look_at"), &c.look_at)?;
    let view = look_at - position;
    if !(view.length_squared() > 0.0) {
        return err(format!("{path}.look_at"), "must differ from position");
    }
    let up = match &c.up {
        None => Vec3::Y,
        Some(_) => direction(&format!("{path}.up"), &c.up)?,
    };
    if !(view.normalize().cross(up.normalize()).length() > 1e-6) {
        return err(format!("{path}.up"), "must not be parallel to the view direction");
    }
    let fov = finite(&format!("{path}.vertical_fov_deg"), c.vertical_fov_deg)?;
    if !(fov > 0.0 && fov < 180.0) {
        return err(format!("{path}.vertical_fov_deg"), format!("must be in (0, 180), got {fov}"));
    }
    if c.width == 0 {
        return err(format!("{path}.width"), "must be > 0");
    }
    if c.height == 0 {
        return err(format!("{path}.height"), "must be > 0");
    }
    let pixels = c.width as u64 * c.height as u64;
    if pixels > limits.max_pixels {
        return err(
            format!("{path}.width"),
            format!("{}x{} = {pixels} pixels exceeds the limit of {}", c.width, c.height, limits.max_pixels),
        );
    }
    Ok(CameraDesc { position, look_at, up, vertical_fov_deg: fov, width: c.width, height: c.height })
}

fn color_texture(path: &str, t: &Option<proto::ColorTexture>) -> FieldResult<Texture<Vec3>> {
    use proto::color_texture::Kind;
    match t.as_ref().and_then(|t| t.kind.as_ref()) {
        None => err(path, "is required (constant or checker)"),
        Some(Kind::Constant(c)) => Ok(Texture::Constant(rgb(&format!("{path}.constant"), &Some(*c), 1.0)?)),
        Some(Kind::Checker(c)) => Ok(Texture::Checker {
            even: rgb(&format!("{path}.checker.even"), &c.even, 1.0)?,
            odd: rgb(&format!("{path}.checker.odd"), &c.odd, 1.0)?,
            scale: positive(&format!("{path}.checker.scale"), c.scale)?,
        }),
    }
}

fn scalar_texture(path: &str, t: &Option<proto::ScalarTexture>, lo: f32, hi: f32) -> FieldResult<Texture<f32>> {
    use proto::scalar_texture::Kind;
    match t.as_ref().and_then(|t| t.kind.as_ref()) {
        None => err(path, "is required (constant or checker)"),
        Some(Kind::Constant(v)) => Ok(Texture::Constant(in_range(&format!("{path}.constant"), *v, lo, hi)?)),
        Some(Kind::Checker(c)) => Ok(Texture::Checker {
            even: in_range(&format!("{path}.checker.even"), c.even, lo, hi)?,
            odd: in_range(&format!("{path}.checker.odd"), c.odd, lo, hi)?,
            scale: positive(&format!("{path}.checker.scale"), c.scale)?,
        }),
    }
}

/// Validates and adds the materials of `list` (named `prefix[i]` in errors); returns their
/// indices by name.
pub(super) fn materials<'a>(
    prefix: &str,
    list: &'a [proto::Material],
    b: &mut SceneBuilder,
) -> FieldResult<HashMap<&'a str, u32>> {
    use proto::material::Kind;
    let mut by_name = HashMap::new();
    for (i, m) in list.iter().enumerate() {
        let path = format!("{prefix}[{i}]");
        if m.name.is_empty() {
            return err(format!("{path}.name"), "is required");
        }
        let material = match &m.kind {
            None => return err(path, "needs a kind (lambertian or glossy)"),
            Some(Kind::Lambertian(l)) => {
                Material::Lambertian { albedo: color_texture(&format!("{path}.lambertian.albedo"), &l.albedo)? }
            }
            Some(Kind::Glossy(g)) => {
                let p = format!("{path}.glossy");
                let diffuse = color_texture(&format!("{p}.diffuse"), &g.diffuse)?;
                let specular = color_texture(&format!("{p}.specular"), &g.specular)?;
                // Energy conservation of the normalised lobes needs kd + ks <= 1 everywhere.
                let max = |t: &Texture<Vec3>| t.values().into_iter().fold(Vec3::ZERO, Vec3::max);
                let sum = max(&diffuse) + max(&specular);
                if sum.max_element() > 1.0 + 1e-6 {
                    return err(
                        format!("{p}.specular"),
                        format!("diffuse + specular must be <= 1 per channel, got {sum}"),
                    );
                }
                Material::Glossy {
                    diffuse,
                    specular,
                    exponent: scalar_texture(&format!("{p}.exponent"), &g.exponent, 0.0, MAX_EXPONENT)?,
                    model: match enum_value(&format!("{p}.model"), g.model)? {
                        proto::GlossyModel::BlinnPhong => GlossyModel::BlinnPhong,
                        proto::GlossyModel::Phong => GlossyModel::Phong,
                    },
                }
            }
        };
        if by_name.insert(m.name.as_str(), b.add_material(material)).is_some() {
            return err(format!("{path}.name"), format!("duplicate material name {:?}", m.name));
        }
    }
    Ok(by_name)
}

/// A scene may hold one environment light: the sky is one.
pub(super) fn one_environment(lights: &[proto::Light]) -> FieldResult<()> {
    let mut env = lights.iter().enumerate().filter(|(_, l)| matches!(l.kind, Some(proto::light::Kind::Environment(_))));
    match (env.next(), env.next()) {
        (Some((i, _)), Some((j, _))) => err(
            format!("scene.lights[{j}].environment"),
            format!("a scene has at most one environment light, and scene.lights[{i}] is one already"),
        ),
        _ => Ok(()),
    }
}

/// Validates light `l` and adds it to `b`. Environment maps named by path resolve as mesh
/// files do (`limits.mesh_root`, `base_dir`).
pub(super) fn add_light(
    path: &str,
    l: &proto::Light,
    b: &mut SceneBuilder,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> FieldResult<()> {
    use proto::light::Kind;
    match &l.kind {
        None => err(path, "needs a kind (rect, point or environment)"),
        Some(Kind::Environment(e)) => {
            let light = super::environment::environment_light(&format!("{path}.environment"), e, limits, base_dir)?;
            b.lights.push(Light::Environment(light));
            Ok(())
        }
        Some(Kind::Rect(r)) => {
            let p = format!("{path}.rect");
            let corner = vec3(&format!("{p}.corner"), &r.corner)?;
            let u = vec3(&format!("{p}.edge_u"), &r.edge_u)?;
            let v = vec3(&format!("{p}.edge_v"), &r.edge_v)?;
            if !(u.length_squared() > 0.0) {
                return err(
                    format!("{p}.edge_u"),
                    "must be non-zero (a light needs area > 0; use a point light for a point)",
                );
            }
            if !(v.length_squared() > 0.0) {
                return err(
                    format!("{p}.edge_v"),
                    "must be non-zero (a light needs area > 0; use a point light for a point)",
                );
            }
            let area = u.cross(v).length();
            if !(area > 0.0) || !area.is_finite() {
                return err(format!("{p}.edge_v"), "must not be parallel to edge_u (the area must be > 0)");
            }
            let radiance = rgb(&format!("{p}.radiance"), &r.radiance, MAX_RADIANCE)?;
            let profile = match enum_value(&format!("{p}.profile"), r.profile)? {
                proto::EmissionProfile::Uniform => EmissionProfile::Uniform,
                proto::EmissionProfile::Gaussian => EmissionProfile::Gaussian,
            };
            let light = match (profile, r.gaussian_sigma) {
                (_, 0.0) => RectLight::new(corner, u, v, radiance, profile),
                (EmissionProfile::Gaussian, sigma) => {
                    let least = u.length().min(v.length()) / 8.0;
                    if !(sigma >= least) || !sigma.is_finite() {
                        return err(
                            format!("{p}.gaussian_sigma"),
                            format!(
                                "must be finite and at least the shorter edge / 8 = {least} (the rectangle may span \
                                 at most +-4 sigma), or 0 for sqrt(area)/2; got {sigma}"
                            ),
                        );
                    }
                    RectLight::gaussian(corner, u, v, radiance, sigma)
                }
                (EmissionProfile::Uniform, _) => {
                    return err(
                        format!("{p}.gaussian_sigma"),
                        "applies only to EMISSION_PROFILE_GAUSSIAN lights (set profile, or leave this 0)",
                    );
                }
            };
            b.add_rect_light(light);
            Ok(())
        }
        Some(Kind::Point(pt)) => {
            let p = format!("{path}.point");
            let position = vec3(&format!("{p}.position"), &pt.position)?;
            let intensity = rgb(&format!("{p}.intensity"), &pt.intensity, MAX_INTENSITY)?;
            b.lights.push(Light::Point(PointLight { position, intensity }));
            Ok(())
        }
    }
}

fn shape_names(shapes: &[proto::Shape]) -> FieldResult<HashMap<&str, usize>> {
    let mut names = HashMap::new();
    for (i, s) in shapes.iter().enumerate() {
        if !s.name.is_empty() && names.insert(s.name.as_str(), i).is_some() {
            return err(format!("scene.shapes[{i}].name"), format!("duplicate shape name {:?}", s.name));
        }
    }
    Ok(names)
}

/// The local-space triangles of a non-instance shape.
fn shape_mesh(
    path: &str,
    s: &proto::Shape,
    budget: u64,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> FieldResult<TriMesh> {
    use proto::shape::Geometry;
    let over = |n: u64| n > budget;
    let too_many = || err(path, format!("the scene exceeds the limit of {} triangles", limits.max_triangles));
    match &s.geometry {
        None => err(path, "needs a geometry (mesh, quad, box, sphere or instance)"),
        Some(Geometry::Quad(q)) => shapes::quad(&format!("{path}.quad"), q),
        Some(Geometry::Box(bx)) => shapes::cuboid(&format!("{path}.box"), bx),
        Some(Geometry::Sphere(sp)) => {
            let bands = if sp.subdivisions == 0 { shapes::DEFAULT_SPHERE_BANDS } else { sp.subdivisions };
            if over(shapes::sphere_triangles(bands.min(shapes::MAX_SPHERE_BANDS))) {
                return too_many();
            }
            shapes::sphere(&format!("{path}.sphere"), sp)
        }
        Some(Geometry::Mesh(m)) => mesh(&format!("{path}.mesh"), m, budget, limits, base_dir),
        Some(Geometry::Instance(_)) => err(path, "an instance has no geometry of its own"),
    }
}

fn mesh(
    path: &str,
    m: &proto::Mesh,
    budget: u64,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> FieldResult<TriMesh> {
    if !m.path.is_empty() {
        if !m.positions.is_empty() || !m.indices.is_empty() {
            return err(format!("{path}.path"), "give either a path or inline arrays, not both");
        }
        return mesh_file(&format!("{path}.path"), &m.path, budget, limits, base_dir);
    }
    if !m.positions.len().is_multiple_of(3) {
        return err(format!("{path}.positions"), format!("length must be a multiple of 3, got {}", m.positions.len()));
    }
    if !m.indices.len().is_multiple_of(3) {
        return err(format!("{path}.indices"), format!("length must be a multiple of 3, got {}", m.indices.len()));
    }
    if m.indices.is_empty() {
        return err(format!("{path}.indices"), "must list at least one triangle");
    }
    if (m.indices.len() / 3) as u64 > budget {
        return err(path, format!("the scene exceeds the limit of {} triangles", limits.max_triangles));
    }
    let nv = m.positions.len() / 3;
    let floats = |name: &str, v: &[f32], k: usize| -> FieldResult<()> {
        if v.len() != k * nv {
            return err(
                format!("{path}.{name}"),
                format!("must have {} numbers ({k} per vertex), got {}", k * nv, v.len()),
            );
        }
        match v.iter().position(|x| !x.is_finite()) {
            Some(i) => err(format!("{path}.{name}[{i}]"), format!("must be a finite number, got {}", v[i])),
            None => Ok(()),
        }
    };
    floats("positions", &m.positions, 3)?;
    if !m.normals.is_empty() {
        floats("normals", &m.normals, 3)?;
    }
    if !m.uvs.is_empty() {
        floats("uvs", &m.uvs, 2)?;
    }
    if let Some(i) = m.indices.iter().position(|&i| i as usize >= nv) {
        return err(format!("{path}.indices[{i}]"), format!("vertex {} out of range ({nv} vertices)", m.indices[i]));
    }
    let v3 = |v: &[f32]| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
    Ok(TriMesh {
        positions: v3(&m.positions),
        indices: m.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        normals: (!m.normals.is_empty()).then(|| v3(&m.normals)),
        uvs: (!m.uvs.is_empty()).then(|| m.uvs.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect()),
    })
}

/// Loads a mesh file named by a scene file: relative to the scene's directory, and only inside
/// the allowed root (so a scene cannot read arbitrary files).
pub(crate) fn load_mesh_file(
    path: &str,
    file: &str,
    budget: u64,
    root: &Path,
    base: &Path,
) -> FieldResult<meshfile::MeshData> {
    let resolved = resolve_file(path, file, root, base)?;
    meshfile::load_mesh(&resolved, budget).or_else(|e| err(path, e.to_string()))
}

fn mesh_file(
    path: &str,
    file: &str,
    budget: u64,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> FieldResult<TriMesh> {
    let (Some(root), Some(base)) = (&limits.mesh_root, base_dir) else {
        return err(path, "mesh files are not allowed here (only in scene files under the mesh root)");
    };
    let data = load_mesh_file(path, file, budget, root, base)?;
    let v3 = |v: &[[f32; 3]]| v.iter().map(|&a| Vec3::from(a)).collect::<Vec<_>>();
    Ok(TriMesh {
        positions: v3(&data.positions),
        indices: data.indices,
        normals: data.normals.as_deref().map(v3),
        uvs: data.uvs.map(|u| u.into_iter().map(Vec2::from).collect()),
    })
}

/// Adds a local-space mesh to the builder, transformed by `xf`. Texture coordinates are kept
/// only when the material reads them.
fn place(b: &mut SceneBuilder, mesh: &TriMesh, xf: &Mat4, material: u32, object: u32, uses_uv: bool) {
    let normal_xf = glam::Mat3::from_mat4(*xf).inverse().transpose();
    for t in &mesh.indices {
        let [i, j, k] = t.map(|i| i as usize);
        let p = [i, j, k].map(|v| xf.transform_point3(mesh.positions[v]));
        let n = mesh.normals.as_ref().map(|n| [i, j, k].map(|v| normal_xf * n[v]));
        let uv = mesh.uvs.as_ref().filter(|_| uses_uv).map(|u| [i, j, k].map(|v| u[v]));
        b.geometry.push(p, n, uv, material, object);
    }
}

#[cfg(test)]
mod tests;
