//! Turns a `RenderRequest` (from gRPC or built by the CLI) into a validated render job. Both
//! front ends go through here, so the same request renders the same image either way, and every
//! field of the request is checked in one place.
use crate::api::wire::wants_aovs;
use crate::methods::lobe_aware::options::{LobeAwareOptions, MAX_UPSAMPLE_FACTOR};
use crate::pipeline::frame::{CameraInfo, RenderInfo};
use crate::pipeline::job::{Halt, Integrand, Method, RenderJob};
use crate::pipeline::registry::DEFAULT_METHOD;
use crate::proto;
use crate::scene::fields::{enum_value, err, finite, opt_vec3, FieldResult};
use crate::scene::{builtin, compile, FieldError, SceneLimits};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// Camera rays per pixel of the denoiser inputs when the outputs ask for them: a 2x2
/// stratified pattern (the first four points of the pixel's sample stream), enough for
/// antialiased edges at a cost of four camera rays per pixel, once per render.
pub const AOV_SAMPLES: u32 = 4;

/// The noise target of a render when the request and scene set no halt condition at all: 1%
/// relative RMSE, by the render's own estimate (`pipeline::noise`).
pub const DEFAULT_TARGET_ERROR: f64 = 0.01;
/// The time budget of a render when the request and scene set no halt condition at all: a
/// render with no halt given anywhere always ends, whatever the method and scene.
pub const DEFAULT_TIME_BUDGET_SECONDS: f64 = 20.0;
/// Most indirect bounces a request may ask for.
pub const MAX_BOUNCES: u32 = 64;
/// Most samples per pixel of the first uniform pass.
pub const MAX_INITIAL_SPP: u32 = 1 << 16;

/// Server-side limits; each is a `wedge serve` option.
#[derive(Clone, Debug)]
pub struct Limits {
    pub max_pixels: u64,
    pub max_triangles: u64,
    pub max_passes: u32,
    pub max_mean_spp: f64,
    pub max_time_budget_seconds: f64,
    /// Root for mesh and map files referenced by scene files; `None` refuses file paths.
    pub mesh_root: Option<PathBuf>,
    /// Most texels of an environment map.
    pub max_environment_texels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_pixels: 4096 * 4096,
            max_triangles: 5_000_000,
            max_passes: 64,
            max_mean_spp: 65536.0,
            max_time_budget_seconds: 3600.0,
            mesh_root: None,
            max_environment_texels: crate::scene::DEFAULT_MAX_ENVIRONMENT_TEXELS,
        }
    }
}

impl Limits {
    /// Limits for rendering in the user's own process (`wedge render`): the size limits stay
    /// (they guard memory), but passes, samples and time are the user's to choose.
    pub fn local() -> Self {
        Limits { max_passes: 1 << 20, max_mean_spp: 1e12, max_time_budget_seconds: f64::INFINITY, ..Limits::default() }
    }
}

pub struct PreparedJob {
    pub job: RenderJob,
    pub info: RenderInfo,
    /// The source scene's camera (with the request's overrides) and settings, without its
    /// geometry: what later views of the same compiled scene start from (`prepare_compiled`).
    pub header: proto::Scene,
}

/// Validates `req` against `limits` and compiles its scene. `base_dir` resolves relative mesh
/// paths of scene files; `scene_label` names the scene in output metadata. Errors name the
/// request field (`settings.max_passes: ...`, `scene.lights[0].rect.edge_u: ...`). A request
/// naming a stored scene by digest goes through `prepare_compiled` instead.
pub fn prepare(
    req: &proto::RenderRequest,
    limits: &Limits,
    base_dir: Option<&Path>,
    scene_label: &str,
) -> Result<PreparedJob, FieldError> {
    use proto::render_request::SceneSource;
    let mut scene = match &req.scene_source {
        Some(SceneSource::Scene(s)) => s.clone(),
        Some(SceneSource::Builtin(name)) => builtin::get(name).ok_or_else(|| FieldError {
            field: "builtin".into(),
            message: format!(
                "unknown built-in scene {name:?} (available: {})",
                builtin::names().collect::<Vec<_>>().join(", ")
            ),
        })?,
        Some(SceneSource::SceneDigest(_)) => {
            return err("scene_digest", "stored scenes are resolved by the server (prepare_compiled)")
        }
        None => return err("scene", "a scene or the name of a built-in scene is required"),
    };
    apply_overrides(req, &mut scene)?;
    // Settings errors before the (costly) compile; `prepare_compiled` checks them again.
    validate_settings(&merge_settings(scene.settings.as_ref(), req.settings.as_ref()), limits)?;
    let compiled = compile_scene(&scene, limits, base_dir).map_err(|e| name_override(e, req))?;
    prepare_compiled(req, &header(&scene), Arc::new(compiled), limits, scene_label)
}

/// Validates and compiles a scene as it stands (its own camera) for `prepare_compiled`,
/// refusing one with nothing to render.
pub fn compile_scene(
    scene: &proto::Scene,
    limits: &Limits,
    base_dir: Option<&Path>,
) -> Result<crate::render::scene::Scene, FieldError> {
    let compiled = compile(scene, &scene_limits(limits), base_dir)?;
    // Checked after compiling, so that a scene's own errors (its camera, say) come first.
    if scene.shapes.is_empty() && scene.lights.is_empty() {
        return err("scene", "nothing to render: the scene has no shapes and no lights");
    }
    Ok(compiled)
}

/// What a compiled scene keeps of its source for later views, settings and edits: all but the
/// shapes (which may be large).
pub fn header(scene: &proto::Scene) -> proto::Scene {
    crate::scene::edit::header(scene)
}

pub(crate) fn scene_limits(limits: &Limits) -> SceneLimits {
    SceneLimits {
        max_triangles: limits.max_triangles,
        max_pixels: limits.max_pixels,
        mesh_root: limits.mesh_root.clone(),
        max_environment_texels: limits.max_environment_texels,
    }
}

/// A job for `req` on a scene compiled before (stored by digest, or a session's; `prepare`
/// ends here too): the request's camera, size and settings override the `header`'s (the
/// source's camera and settings), and no geometry is compiled again.
pub fn prepare_compiled(
    req: &proto::RenderRequest,
    header: &proto::Scene,
    compiled: Arc<crate::render::scene::Scene>,
    limits: &Limits,
    scene_label: &str,
) -> Result<PreparedJob, FieldError> {
    let mut header = header.clone();
    apply_overrides(req, &mut header)?;
    let settings = merge_settings(header.settings.as_ref(), req.settings.as_ref());
    let (method, halt, bounces, initial_spp) = validate_settings(&settings, limits)?;
    if let Some(o) = &req.outputs {
        enum_value::<proto::PixelFormat>("outputs.format", o.format)?;
    }
    let desc = crate::scene::camera("scene.camera", &header.camera, &scene_limits(limits))
        .map_err(|e| name_override(e, req))?;
    let view = compiled.view(&desc);
    // The AAF family keeps running sums per pixel and per area light (BENCHMARKS.md, "Server
    // memory per request", measures what a render holds per pixel): bound the product like the
    // image size, so one request cannot exhaust the server's memory.
    let area_lights =
        compiled.lights.iter().filter(|l| matches!(l, crate::render::light::Light::Rect(_))).count() as u64;
    let pixels = view.width as u64 * view.height as u64;
    if method != Method::Uniform && pixels * area_lights.max(1) > limits.max_pixels {
        return err(
            "settings.method",
            format!(
                "{} keeps state per pixel and area light: {pixels} pixels x {area_lights} lights exceeds the limit of {}",
                method.name(),
                limits.max_pixels
            ),
        );
    }
    let integrand = integrand(&settings, compiled.world_scale)?;
    let lobe = lobe_options(&settings, method)?;
    let cam = header.camera.as_ref().map(camera_info).unwrap_or_default();
    Ok(PreparedJob {
        job: RenderJob {
            bandwidth: Default::default(),
            view,
            scene: compiled,
            method,
            halt,
            seed: req.seed,
            bounces,
            initial_spp,
            aaf: Default::default(),
            integrand,
            pixel_centers: settings.pixel_centers,
            indirect: Default::default(),
            lobe,
            auto: Default::default(),
            uniform: Default::default(),
            aov_samples: if req.outputs.as_ref().is_some_and(wants_aovs) { AOV_SAMPLES } else { 0 },
        },
        info: RenderInfo {
            scene: scene_label.to_string(),
            method: method.name().to_string(),
            seed: req.seed,
            bounces,
            camera: cam,
        },
        header,
    })
}

/// A scene error caused by a value the request overrode names the request's field.
fn name_override(mut e: FieldError, req: &proto::RenderRequest) -> FieldError {
    let cam = req.camera.as_ref();
    let overridden = [
        ("scene.camera.width", "width", req.width != 0),
        ("scene.camera.height", "height", req.height != 0),
        ("scene.camera.position", "camera.position", cam.is_some_and(|c| c.position.is_some())),
        ("scene.camera.look_at", "camera.look_at", cam.is_some_and(|c| c.look_at.is_some())),
        ("scene.camera.up", "camera.up", cam.is_some_and(|c| c.up.is_some())),
        ("scene.camera.vertical_fov_deg", "camera.vertical_fov_deg", cam.is_some_and(|c| c.vertical_fov_deg.is_some())),
    ];
    if let Some((from, to, _)) = overridden.iter().find(|(from, _, set)| *set && e.field.starts_with(from)) {
        e.field = e.field.replacen(from, to, 1);
    }
    e
}

fn camera_info(c: &proto::Camera) -> CameraInfo {
    let v = |v: &Option<proto::Vec3>| v.as_ref().map_or([0.0; 3], |v| [v.x, v.y, v.z]);
    CameraInfo {
        position: v(&c.position),
        look_at: v(&c.look_at),
        up: if c.up.is_some() { v(&c.up) } else { [0.0, 1.0, 0.0] },
        vertical_fov_deg: c.vertical_fov_deg,
    }
}

/// Applies the request's camera and resolution overrides to the scene, checking each.
fn apply_overrides(req: &proto::RenderRequest, scene: &mut proto::Scene) -> FieldResult<()> {
    let cam = scene.camera.get_or_insert_with(Default::default);
    if req.width != 0 {
        cam.width = req.width;
    }
    if req.height != 0 {
        cam.height = req.height;
    }
    if let Some(o) = &req.camera {
        if let Some(p) = &o.position {
            cam.position = Some(check_vec3("camera.position", p)?);
        }
        if let Some(p) = &o.look_at {
            cam.look_at = Some(check_vec3("camera.look_at", p)?);
        }
        if let Some(p) = &o.up {
            cam.up = Some(check_vec3("camera.up", p)?);
        }
        if let Some(f) = o.vertical_fov_deg {
            if !(finite("camera.vertical_fov_deg", f)? > 0.0 && f < 180.0) {
                return err("camera.vertical_fov_deg", format!("must be in (0, 180), got {f}"));
            }
            cam.vertical_fov_deg = f;
        }
    }
    Ok(())
}

fn check_vec3(path: &str, v: &proto::Vec3) -> FieldResult<proto::Vec3> {
    opt_vec3(path, v)?;
    Ok(*v)
}

/// The scene's settings with every field the request sets (non-zero) taking precedence. The
/// halt conditions go as a group: a request that sets any of them replaces all of the scene's,
/// so "render to 256 spp" is not cut short by the scene's default pass count.
fn merge_settings(scene: Option<&proto::RenderSettings>, req: Option<&proto::RenderSettings>) -> proto::RenderSettings {
    let mut s = scene.cloned().unwrap_or_default();
    if let Some(r) = req {
        if r.method != 0 {
            s.method = r.method;
        }
        if r.max_passes != 0 || r.max_mean_spp != 0.0 || r.time_budget_seconds != 0.0 || r.target_error != 0.0 {
            s.max_passes = r.max_passes;
            s.max_mean_spp = r.max_mean_spp;
            s.time_budget_seconds = r.time_budget_seconds;
            s.target_error = r.target_error;
        }
        if r.bounces.is_some() {
            s.bounces = r.bounces;
        }
        if r.initial_spp != 0 {
            s.initial_spp = r.initial_spp;
        }
        if r.ambient_occlusion {
            s.ambient_occlusion = true;
        }
        if r.pixel_centers {
            s.pixel_centers = true;
        }
        if r.ambient_occlusion_distance != 0.0 {
            s.ambient_occlusion_distance = r.ambient_occlusion_distance;
        }
        if r.upsample_factor != 0 {
            s.upsample_factor = r.upsample_factor;
        }
    }
    s
}

/// The lobe- and normal-aware methods' options: their upsampling factor, checked.
fn lobe_options(s: &proto::RenderSettings, method: Method) -> FieldResult<LobeAwareOptions> {
    let mut o = LobeAwareOptions::default();
    let field = "settings.upsample_factor";
    if s.upsample_factor > MAX_UPSAMPLE_FACTOR {
        return err(field, format!("must be <= {MAX_UPSAMPLE_FACTOR}, got {}", s.upsample_factor));
    }
    if s.upsample_factor > 1 && !matches!(method, Method::LobeAware | Method::NormalAware) {
        return err(field, format!("only lobe-aware and normal-aware upsample, not {}", method.name()));
    }
    o.upsample.factor = s.upsample_factor.max(1);
    Ok(o)
}

/// Light or ambient occlusion; the occlusion distance is moved into the scene's internal units
/// (`world_scale` per scene unit).
fn integrand(s: &proto::RenderSettings, world_scale: f32) -> FieldResult<Integrand> {
    let field = "settings.ambient_occlusion_distance";
    let distance = finite(field, s.ambient_occlusion_distance)?;
    if distance < 0.0 {
        return err(field, format!("must be >= 0 (0: no limit), got {distance}"));
    }
    if !s.ambient_occlusion {
        if distance > 0.0 {
            return err(field, "applies only with settings.ambient_occlusion = true");
        }
        return Ok(Integrand::Radiance);
    }
    let max_distance = if distance > 0.0 { distance * world_scale } else { f32::INFINITY };
    Ok(Integrand::AmbientOcclusion { max_distance })
}

fn validate_settings(s: &proto::RenderSettings, limits: &Limits) -> FieldResult<(Method, Halt, u32, u32)> {
    let method = Method::from_proto(enum_value("settings.method", s.method)?).unwrap_or(DEFAULT_METHOD);
    if s.max_passes > limits.max_passes {
        return err(
            "settings.max_passes",
            format!("must be <= {} (server limit), got {}", limits.max_passes, s.max_passes),
        );
    }
    let spp = finite("settings.max_mean_spp", s.max_mean_spp)? as f64;
    if !(0.0..=limits.max_mean_spp).contains(&spp) {
        return err(
            "settings.max_mean_spp",
            format!("must be in [0, {}] (server limit), got {spp}", limits.max_mean_spp),
        );
    }
    let time = finite("settings.time_budget_seconds", s.time_budget_seconds)? as f64;
    if !(0.0..=limits.max_time_budget_seconds).contains(&time) {
        return err(
            "settings.time_budget_seconds",
            format!("must be in [0, {}] (server limit), got {time}", limits.max_time_budget_seconds),
        );
    }
    let bounces = s.bounces.unwrap_or(0);
    if bounces > MAX_BOUNCES {
        return err("settings.bounces", format!("must be <= {MAX_BOUNCES}, got {bounces}"));
    }
    if s.initial_spp > MAX_INITIAL_SPP {
        return err("settings.initial_spp", format!("must be <= {MAX_INITIAL_SPP}, got {}", s.initial_spp));
    }
    let target = finite("settings.target_error", s.target_error)? as f64;
    if !(0.0..=1.0).contains(&target) {
        return err("settings.target_error", format!("must be in [0, 1] (0: no noise target), got {target}"));
    }
    // With no halt condition at all, a noise target within a time budget: every render ends.
    // With some, the server's pass limit still bounds the render.
    let any = s.max_passes != 0 || spp > 0.0 || time > 0.0 || target > 0.0;
    let max_passes = if s.max_passes != 0 { s.max_passes } else { limits.max_passes };
    let (time, target) = if any {
        (time, target)
    } else {
        (DEFAULT_TIME_BUDGET_SECONDS.min(limits.max_time_budget_seconds), DEFAULT_TARGET_ERROR)
    };
    // The server's time limit bounds every render, also one that asks for no budget.
    let budget = if time > 0.0 { time } else { limits.max_time_budget_seconds };
    let halt = Halt {
        max_passes,
        max_mean_spp: if spp > 0.0 { spp } else { limits.max_mean_spp },
        time_budget: Duration::try_from_secs_f64(budget).ok(),
        target_error: (target > 0.0).then_some(target),
    };
    Ok((method, halt, bounces, s.initial_spp.max(1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn builtin_req(name: &str) -> proto::RenderRequest {
        proto::RenderRequest {
            scene_source: Some(proto::render_request::SceneSource::Builtin(name.into())),
            width: 32,
            height: 24,
            ..Default::default()
        }
    }

    fn field_of(req: proto::RenderRequest) -> String {
        match prepare(&req, &Limits::default(), None, "t") {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.field,
        }
    }

    #[test]
    fn builtin_scene_with_overrides() {
        let mut req = builtin_req("cornell");
        req.seed = 5;
        req.settings = Some(proto::RenderSettings { max_passes: 3, bounces: Some(2), ..Default::default() });
        let p = prepare(&req, &Limits::default(), None, "cornell").unwrap();
        assert_eq!((p.job.width(), p.job.height()), (32, 24));
        assert_eq!(p.job.halt.max_passes, 3);
        assert_eq!(p.job.bounces, 2);
        assert_eq!(p.info.seed, 5);
        assert_eq!(p.info.method, "auto");
        assert_eq!(p.info.camera.position, [278.0, 273.0, -800.0]);
    }

    #[test]
    fn defaults_and_server_limits_bound_the_halt() {
        // No halt anywhere (the built-in scenes set none): a noise target within a time
        // budget, so that every render ends; the product's method.
        let mut req = builtin_req("grids");
        req.settings = Some(proto::RenderSettings { max_passes: 0, ..Default::default() });
        let p = prepare(&req, &Limits::default(), None, "grids").unwrap();
        assert_eq!(p.job.halt.target_error, Some(DEFAULT_TARGET_ERROR));
        assert_eq!(p.job.halt.time_budget, Some(Duration::from_secs_f64(DEFAULT_TIME_BUDGET_SECONDS)));
        assert_eq!(p.job.halt.max_passes, Limits::default().max_passes);
        assert_eq!(p.job.method, DEFAULT_METHOD);
        // A server whose time limit is shorter than the default budget bounds it.
        let short = Limits { max_time_budget_seconds: 5.0, ..Limits::default() };
        assert_eq!(prepare(&req, &short, None, "grids").unwrap().job.halt.time_budget, Some(Duration::from_secs(5)));
        // A request's halt conditions replace the defaults as a group; the server's pass and
        // time limits still bound them.
        req.settings = Some(proto::RenderSettings { time_budget_seconds: 2.0, ..Default::default() });
        let p = prepare(&req, &Limits::default(), None, "grids").unwrap();
        assert_eq!(p.job.halt.time_budget, Some(Duration::from_secs(2)));
        assert_eq!((p.job.halt.max_passes, p.job.halt.target_error), (Limits::default().max_passes, None));
        req.settings = Some(proto::RenderSettings { max_mean_spp: 256.0, ..Default::default() });
        let p = prepare(&req, &Limits::default(), None, "grids").unwrap();
        assert_eq!((p.job.halt.max_mean_spp, p.job.halt.max_passes), (256.0, 64));
        assert_eq!(p.job.halt.time_budget, Some(Duration::from_secs(3600)));
        req.settings = Some(proto::RenderSettings { target_error: 0.05, ..Default::default() });
        let p = prepare(&req, &Limits::default(), None, "grids").unwrap();
        assert_eq!(
            (p.job.halt.target_error, p.job.halt.time_budget),
            (Some(0.05f32 as f64), Some(Duration::from_secs(3600)))
        );
    }

    #[test]
    fn ambient_occlusion_distance_moves_into_internal_units() {
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings {
            ambient_occlusion: true,
            ambient_occlusion_distance: 100.0,
            ..Default::default()
        });
        let p = prepare(&r, &Limits::default(), None, "cornell").unwrap();
        let k = p.job.scene.world_scale;
        assert_eq!(p.job.integrand, Integrand::AmbientOcclusion { max_distance: 100.0 * k });
        r.settings.as_mut().unwrap().ambient_occlusion_distance = 0.0;
        let p = prepare(&r, &Limits::default(), None, "cornell").unwrap();
        assert_eq!(p.job.integrand, Integrand::AmbientOcclusion { max_distance: f32::INFINITY });
        assert_eq!(
            prepare(&builtin_req("cornell"), &Limits::default(), None, "c").unwrap().job.integrand,
            Integrand::Radiance
        );
    }

    #[test]
    fn bad_requests_name_their_field() {
        assert_eq!(field_of(builtin_req("nope")), "builtin");
        assert_eq!(field_of(proto::RenderRequest::default()), "scene");
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { max_passes: 1000, ..Default::default() });
        assert_eq!(field_of(r), "settings.max_passes");
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { max_mean_spp: f32::NAN, ..Default::default() });
        assert_eq!(field_of(r), "settings.max_mean_spp");
        for bad in [f32::NAN, -0.1, 1.5] {
            let mut r = builtin_req("cornell");
            r.settings = Some(proto::RenderSettings { target_error: bad, ..Default::default() });
            assert_eq!(field_of(r), "settings.target_error");
        }
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { method: 99, ..Default::default() });
        assert_eq!(field_of(r), "settings.method");
        let mut r = builtin_req("cornell");
        r.camera = Some(proto::CameraOverride { vertical_fov_deg: Some(0.0), ..Default::default() });
        assert_eq!(field_of(r), "camera.vertical_fov_deg");
        let mut r = builtin_req("cornell");
        r.camera = Some(proto::CameraOverride {
            position: Some(proto::Vec3 { x: f32::INFINITY, y: 0.0, z: 0.0 }),
            ..Default::default()
        });
        assert_eq!(field_of(r), "camera.position.x");
        let mut r = builtin_req("cornell");
        r.width = 100_000;
        r.height = 100_000;
        assert_eq!(field_of(r), "width");
        let mut r = builtin_req("cornell");
        r.camera =
            Some(proto::CameraOverride { up: Some(proto::Vec3 { x: 0.0, y: 0.0, z: 1.0 }), ..Default::default() });
        assert_eq!(field_of(r), "camera.up");
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { bounces: Some(1000), ..Default::default() });
        assert_eq!(field_of(r), "settings.bounces");
        for bad in [f32::NAN, -1.0] {
            let mut r = builtin_req("cornell");
            r.settings = Some(proto::RenderSettings {
                ambient_occlusion: true,
                ambient_occlusion_distance: bad,
                ..Default::default()
            });
            assert_eq!(field_of(r), "settings.ambient_occlusion_distance");
        }
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { ambient_occlusion_distance: 2.0, ..Default::default() });
        assert_eq!(field_of(r), "settings.ambient_occlusion_distance");
        // Upsampling: at most MAX_UPSAMPLE_FACTOR, and only for the methods that upsample.
        let lobe_aware = proto::Method::LobeAware as i32;
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { method: lobe_aware, upsample_factor: 9, ..Default::default() });
        assert_eq!(field_of(r), "settings.upsample_factor");
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { upsample_factor: 2, ..Default::default() });
        assert_eq!(field_of(r), "settings.upsample_factor");
        let mut r = builtin_req("cornell");
        r.settings = Some(proto::RenderSettings { method: lobe_aware, upsample_factor: 8, ..Default::default() });
        let job = prepare(&r, &Limits::default(), None, "t").expect("factor 8 is allowed").job;
        assert_eq!(job.lobe.upsample.factor, 8);
        // AAF state grows with pixels x area lights: bounded like the image. Two lights on a
        // 32 x 24 image: 1536 pixel-lights against a limit of 1000 pixels (the image fits).
        let mut scene = builtin::get("curved").unwrap();
        let light = scene.lights[0].clone();
        scene.lights.push(light);
        let mut r = proto::RenderRequest {
            scene_source: Some(proto::render_request::SceneSource::Scene(scene)),
            width: 32,
            height: 24,
            settings: Some(proto::RenderSettings { method: proto::Method::Uniform as i32, ..Default::default() }),
            ..Default::default()
        };
        let limits = Limits { max_pixels: 1000, ..Limits::default() };
        assert!(prepare(&r, &limits, None, "t").is_ok(), "uniform keeps no per-light state");
        r.settings = Some(proto::RenderSettings { method: proto::Method::Aaf as i32, ..Default::default() });
        assert_eq!(prepare(&r, &limits, None, "t").err().map(|e| e.field), Some("settings.method".into()));
    }

    #[test]
    fn a_scene_with_nothing_to_render_is_refused() {
        let mut scene = builtin::get("cornell").unwrap();
        scene.shapes.clear();
        let lights = scene.lights.clone();
        scene.lights.clear();
        let req = |scene: &proto::Scene| proto::RenderRequest {
            scene_source: Some(proto::render_request::SceneSource::Scene(scene.clone())),
            ..Default::default()
        };
        let e = prepare(&req(&scene), &Limits::default(), None, "t").err().expect("refused");
        assert_eq!(e.field, "scene");
        assert!(e.message.contains("no shapes and no lights"), "{}", e.message);
        // Lights alone still render (their own surfaces), as do shapes alone (black).
        scene.lights = lights;
        assert!(prepare(&req(&scene), &Limits::default(), None, "t").is_ok());
    }
}
