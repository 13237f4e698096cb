//! `wedge render`: renders in this process with a progress bar and writes the images.
use super::request::{build_request, resolve_scene, FrameWriter};
use super::RenderArgs;
use crate::api::request::{prepare, Limits};
use crate::pipeline::job::CancelToken;
use crate::pipeline::progressive::render;
use anyhow::anyhow;
use indicatif::{ProgressBar, ProgressStyle};

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let scene = resolve_scene(&args)?;
    let req = build_request(&args, scene.source.clone())?;
    let limits = Limits { mesh_root: scene.mesh_root.clone(), ..Limits::local() };
    let prepared = prepare(&req, &limits, scene.base_dir.as_deref(), &scene.label)
        .map_err(|e| anyhow!("{}", scene.describe(&e)))?;
    let job = &prepared.job;
    // A bar over the passes when a pass count ends the render; a spinner when spp or time do.
    let by_passes = args.max_spp.is_none() && args.time.is_none();
    let bar = if by_passes {
        ProgressBar::new(job.halt.max_passes as u64).with_style(
            ProgressStyle::with_template("{spinner} pass {pos}/{len} {wide_bar} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    } else {
        ProgressBar::new_spinner().with_style(
            ProgressStyle::with_template("{spinner} pass {pos} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        )
    };
    bar.set_message(format!("{}x{} {}", job.width(), job.height(), job.method.name()));
    let writer = FrameWriter::new(&args);
    let mut failure = None;
    let result = render(job, &CancelToken::new(), &mut |frame| {
        bar.set_position(frame.stats.pass as u64 + 1);
        bar.set_message(format!("{:.1} spp, {:.2} s", frame.stats.mean_spp, frame.stats.elapsed_seconds));
        match writer.frame(frame, &prepared.info) {
            Ok(()) => true,
            Err(e) => {
                failure = Some(e);
                false
            }
        }
    });
    bar.finish_and_clear();
    if let Some(e) = failure {
        return Err(e);
    }
    result.map(|_| ()).map_err(|e| anyhow!("{e}"))
}
