//! `wedge render`: renders in this process with a progress bar and writes the images.
use super::request::{build_request, resolve_scene, FrameWriter};
use super::RenderArgs;
use crate::api::request::{prepare, Limits};
use crate::pipeline::job::CancelToken;
use crate::runner::{self, RunError};
use anyhow::anyhow;
use indicatif::{ProgressBar, ProgressStyle};

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let scene = resolve_scene(&args)?;
    let req = build_request(&args, scene.source.clone())?;
    let limits = Limits { mesh_root: scene.mesh_root.clone(), ..Limits::local() };
    let mut prepared = prepare(&req, &limits, scene.base_dir.as_deref(), &scene.label)
        .map_err(|e| anyhow!("{}", scene.describe(&e)))?;
    for assignment in &args.settings {
        prepared.job.set(assignment).map_err(|e| anyhow!("--set: {e}"))?;
    }
    let job = &prepared.job;
    // A bar over the passes when a pass count ends the render; a spinner when spp or time do.
    let by_passes =
        args.max_spp.is_none() && args.time.is_none() && args.target_error.is_none() && args.max_passes.is_some();
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
    // The writer gets the frames `--every` asks for and the final one; the others are not
    // composed (a filter nobody sees would spend the time budget).
    let every = args.every.unwrap_or(0);
    let result = runner::run_with_progress(
        job,
        &CancelToken::new(),
        every,
        &mut |stats| {
            bar.set_position(stats.pass as u64 + 1);
            bar.set_message(format!("{:.1} spp, {:.2} s", stats.mean_spp, stats.elapsed_seconds));
        },
        &mut |frame| writer.frame(frame, &prepared.info),
    );
    bar.finish_and_clear();
    match result {
        Ok(_) => Ok(()),
        Err(RunError::Sink(e)) => Err(e),
        Err(RunError::Cancelled) => Err(anyhow!("render cancelled")),
    }
}
