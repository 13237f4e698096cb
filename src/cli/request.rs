//! Builds a `RenderRequest` from command-line arguments, and writes the frames the user asked
//! for. `render` and `client` share both, so the same arguments give the same files.
use super::RenderArgs;
use crate::output::{write_frame_files, OutputOptions};
use crate::pipeline::frame::{Frame, HaltReason, RenderInfo};
use crate::pipeline::job::Method;
use crate::proto::{self, render_request::SceneSource};
use crate::scene::{builtin, json};
use anyhow::{bail, Context};
use std::path::{Path, PathBuf};

/// A scene named on the command line.
pub struct ResolvedScene {
    pub source: SceneSource,
    /// The name used in output metadata: the built-in name or the path as given.
    pub label: String,
    /// For scene files: their directory (relative mesh paths start there).
    pub base_dir: Option<PathBuf>,
    /// For scene files: the directory mesh files must lie in.
    pub mesh_root: Option<PathBuf>,
}

pub fn resolve_scene(args: &RenderArgs) -> anyhow::Result<ResolvedScene> {
    let path = Path::new(&args.scene);
    if path.is_file() {
        let scene = json::load_scene(path)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let base = if base.as_os_str().is_empty() { PathBuf::from(".") } else { base };
        Ok(ResolvedScene {
            source: SceneSource::Scene(scene),
            label: args.scene.clone(),
            mesh_root: Some(args.mesh_root.clone().unwrap_or_else(|| base.clone())),
            base_dir: Some(base),
        })
    } else if builtin::names().any(|n| n == args.scene) {
        Ok(ResolvedScene {
            source: SceneSource::Builtin(args.scene.clone()),
            label: args.scene.clone(),
            base_dir: None,
            mesh_root: None,
        })
    } else {
        bail!(
            "{}: no such scene file, and no built-in scene of that name (built-in: {})",
            args.scene,
            builtin::names().collect::<Vec<_>>().join(", ")
        )
    }
}

impl ResolvedScene {
    /// Describes a validation error: for scene files with the file and line of the field.
    pub fn describe(&self, e: &crate::scene::FieldError) -> String {
        if self.base_dir.is_some() && e.field.starts_with("scene") {
            let line = std::fs::read_to_string(&self.label)
                .ok()
                .and_then(|text| crate::scene::locate::line_of(&text, &e.field))
                .unwrap_or(1);
            format!("{}:{line}: {e}", self.label)
        } else {
            format!("{}: {e}", self.label)
        }
    }
}

pub fn build_request(args: &RenderArgs, source: SceneSource) -> anyhow::Result<proto::RenderRequest> {
    let method = match &args.method {
        None => proto::Method::Unspecified,
        Some(name) => {
            let m = Method::from_name(name).with_context(|| {
                let all: Vec<_> = Method::ALL.iter().map(|m| m.name()).collect();
                format!("--method {name}: unknown method (available: {})", all.join(", "))
            })?;
            m.to_proto()
        }
    };
    Ok(proto::RenderRequest {
        scene_source: Some(source),
        camera: None,
        width: args.width.unwrap_or(0),
        height: args.height.unwrap_or(0),
        settings: Some(proto::RenderSettings {
            method: method as i32,
            max_passes: args.max_passes.unwrap_or(0),
            max_mean_spp: args.max_spp.unwrap_or(0.0),
            time_budget_seconds: args.time.unwrap_or(0.0),
            target_error: args.target_error.unwrap_or(0.0),
            bounces: args.bounces,
            initial_spp: args.initial_spp.unwrap_or(0),
            ambient_occlusion: args.ao,
            pixel_centers: args.pixel_centers,
            ambient_occlusion_distance: args.ao_distance.unwrap_or(0.0),
            upsample_factor: args.upsample.unwrap_or(0),
        }),
        seed: args.seed,
        // Everything the files need, losslessly.
        outputs: Some(proto::OutputSelection {
            color: true,
            spp: true,
            filter_width: true,
            unfiltered: true,
            components: true,
            albedo: args.aovs,
            normal: args.aovs,
            depth: args.aovs,
            bandwidth: true,
            level: true,
            format: proto::PixelFormat::F32 as i32,
        }),
        frame_every: 0,
    })
}

/// Writes the frames `--every` asks for (`pass_NNN.*`) and the final one (`final.*`).
pub struct FrameWriter {
    out: PathBuf,
    every: Option<u32>,
    opts: OutputOptions,
}

impl FrameWriter {
    pub fn new(args: &RenderArgs) -> Self {
        FrameWriter {
            out: args.out.clone(),
            every: args.every,
            opts: OutputOptions { reproducible: args.reproducible },
        }
    }

    pub fn frame(&self, frame: &Frame, info: &RenderInfo) -> anyhow::Result<()> {
        let pass = frame.stats.pass;
        // Every N-th pass counting from 1, as the server's `frame_every` does.
        if self.every.is_some_and(|n| n > 0 && (pass + 1).is_multiple_of(n)) {
            write_frame_files(&self.out, &format!("pass_{pass:03}"), frame, info, &self.opts)?;
        }
        if frame.stats.is_final {
            let files = write_frame_files(&self.out, "final", frame, info, &self.opts)?;
            let s = &frame.stats;
            let error = s.estimated_error.map_or_else(String::new, |e| format!(", estimated error {:.2}%", e * 100.0));
            let cut = if s.pass_complete { "" } else { " inside its last pass" };
            eprintln!(
                "wrote {} ({} passes, {:.1} spp, {:.2} s{error}; stopped by {}{cut})",
                files.exr.display(),
                pass + 1,
                s.mean_spp,
                s.elapsed_seconds,
                halt_reason_text(s.halt_reason),
            );
        }
        Ok(())
    }
}

/// Why a render stopped, in words.
fn halt_reason_text(reason: HaltReason) -> &'static str {
    match reason {
        HaltReason::None => "nothing (not final)",
        HaltReason::MaxPasses => "the pass limit",
        HaltReason::MaxSpp => "the spp limit",
        HaltReason::TimeBudget => "the time budget",
        HaltReason::NoiseTarget => "the noise target",
    }
}
