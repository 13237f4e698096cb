//! `wedge client`: the same render through a server, written to the same files.
use super::request::{build_request, resolve_scene, FrameWriter};
use super::ClientArgs;
use crate::api::request::Limits;
use crate::client::{RemoteError, Target};
use crate::pipeline::frame::{CameraInfo, RenderInfo};
use crate::pipeline::job::Method;
use crate::proto::{self, render_request::SceneSource};
use crate::scene::FieldError;
use anyhow::anyhow;

pub fn run(args: ClientArgs) -> anyhow::Result<()> {
    let r = &args.render;
    anyhow::ensure!(
        r.settings.is_empty(),
        "--set: `wedge render` only; a server takes no options beyond its request's"
    );
    let scene = resolve_scene(r)?;
    let mut source = scene.source.clone();
    // Servers refuse file paths: send mesh files' and maps' contents inline.
    if let (SceneSource::Scene(s), Some(base), Some(root)) = (&mut source, &scene.base_dir, &scene.mesh_root) {
        let limits = crate::api::request::scene_limits(&Limits::default());
        crate::scene::inline_files(s, base, root, &limits).map_err(|e| anyhow!("{}", scene.describe(&e)))?;
    }
    let req = build_request(r, source)?;
    let info = request_info(&req, &scene.label);
    let writer = FrameWriter::new(r);
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let mut failure = None;
    let target = target(&args)?;
    let result = runtime.block_on(crate::client::render_remote(target, req, |started, frame| {
        if failure.is_some() {
            return;
        }
        let mut frame = frame.clone();
        let method = proto::Method::try_from(started.method).ok().and_then(Method::from_proto);
        // Unfiltered methods send colour in the unfiltered layer too; keep files identical to
        // `wedge render`'s, which leave those layers out.
        if method.is_some_and(|m| !m.filters()) {
            frame.unfiltered = None;
            frame.filter_width = None;
        }
        let info = RenderInfo { method: method.map(|m| m.name().to_string()).unwrap_or_default(), ..info.clone() };
        if let Err(e) = writer.frame(&frame, &info) {
            failure = Some(e);
        }
    }));
    if let Err(e) = result {
        // The server names the invalid field; for scene files, name the line too.
        if let Some(r) = e.downcast_ref::<RemoteError>() {
            if let (tonic::Code::InvalidArgument, Some((field, message))) = (r.code, r.message.split_once(": ")) {
                let fe = FieldError { field: field.to_string(), message: message.to_string() };
                return Err(anyhow!("server error INVALID_ARGUMENT: {}", scene.describe(&fe)));
            }
        }
        return Err(e);
    }
    failure.map_or(Ok(()), Err)
}

/// The server, its CA and the token to send, from the options and `WEDGE_TOKEN`.
fn target(args: &ClientArgs) -> anyhow::Result<Target> {
    let read = |option: &str, path: &std::path::Path| {
        std::fs::read(path).map_err(|e| anyhow!("{option} {}: {e}", path.display()))
    };
    let ca_pem = args.tls_ca.as_deref().map(|p| read("--tls-ca", p)).transpose()?;
    let token = match &args.token_file {
        Some(path) => {
            let text = String::from_utf8(read("--token-file", path)?)
                .map_err(|_| anyhow!("--token-file {}: not UTF-8 text", path.display()))?;
            let first = text.lines().map(str::trim).find(|l| !l.is_empty() && !l.starts_with('#'));
            Some(first.ok_or_else(|| anyhow!("--token-file {}: no token in the file", path.display()))?.to_string())
        }
        None => std::env::var(super::serve_cmd::TOKEN_ENV).ok().map(|t| t.trim().to_string()),
    };
    Ok(Target { addr: args.addr.clone(), ca_pem, token })
}

/// Output metadata for a remote render: what the request and its scene say.
fn request_info(req: &proto::RenderRequest, label: &str) -> RenderInfo {
    let scene = match &req.scene_source {
        Some(SceneSource::Scene(s)) => Some(s.clone()),
        Some(SceneSource::Builtin(n)) => crate::scene::builtin::get(n),
        Some(SceneSource::SceneDigest(_)) | None => None,
    };
    let bounces = req
        .settings
        .as_ref()
        .and_then(|s| s.bounces)
        .or_else(|| scene.as_ref().and_then(|s| s.settings.as_ref()).and_then(|s| s.bounces))
        .unwrap_or(0);
    let cam = scene.as_ref().and_then(|s| s.camera).unwrap_or_default();
    let v = |v: &Option<proto::Vec3>, d: [f32; 3]| v.as_ref().map_or(d, |v| [v.x, v.y, v.z]);
    RenderInfo {
        scene: label.to_string(),
        method: String::new(),
        seed: req.seed,
        bounces,
        camera: CameraInfo {
            position: v(&cam.position, [0.0; 3]),
            look_at: v(&cam.look_at, [0.0; 3]),
            up: v(&cam.up, [0.0, 1.0, 0.0]),
            vertical_fov_deg: cam.vertical_fov_deg,
        },
    }
}
