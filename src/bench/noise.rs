//! `wedge bench noise`: is the noise-target halt honest? Each method renders each scene to
//! each target; the final frame's own estimate (`pipeline::noise`) is set against its true
//! relative RMSE, measured against a high-spp `uniform` reference. Two references with their
//! own seeds give the reference's own noise, which is taken out of the true error:
//! true^2 = RMSE(frame, ref1)^2 - RMSE(ref1, ref2)^2 / 2.
use super::convergence::rmse;
use crate::api::request::{prepare, Limits};
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{CancelToken, Halt, Method, RenderJob};
use crate::pipeline::progressive::render;
use crate::proto;

/// One render to a target.
#[derive(Clone, Debug)]
pub struct NoiseRow {
    pub scene: String,
    pub method: Method,
    pub target: f64,
    pub estimated: f64,
    pub truth: f64,
    pub mean_spp: f64,
    pub seconds: f64,
    pub halted_by_target: bool,
}

impl NoiseRow {
    /// True error over the estimate.
    pub fn ratio(&self) -> f64 {
        self.truth / self.estimated
    }
}

fn job(scene: &str, width: u32, height: u32, method: Method, seed: u64) -> anyhow::Result<RenderJob> {
    let req = proto::RenderRequest {
        scene_source: Some(proto::render_request::SceneSource::Builtin(scene.into())),
        width,
        height,
        settings: Some(proto::RenderSettings { method: method.to_proto() as i32, ..Default::default() }),
        seed,
        ..Default::default()
    };
    Ok(prepare(&req, &Limits::local(), None, scene).map_err(|e| anyhow::anyhow!("{scene}: {e}"))?.job)
}

fn final_frame(job: &RenderJob) -> Frame {
    let mut last = None;
    // Nothing cancels these renders, and the sink never refuses a frame.
    let _ = render(job, &CancelToken::new(), &mut |f| {
        last = Some(f.clone());
        true
    });
    last.unwrap_or_default()
}

fn image_mean(f: &Frame) -> f64 {
    f.color.iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * f.color.len().max(1)) as f64
}

/// The reference of `scene` at `spp` (two seeds) and its own relative RMSE.
pub fn reference(scene: &str, width: u32, height: u32, spp: f64) -> anyhow::Result<(Frame, f64)> {
    let mut frames = Vec::new();
    for seed in [1_000_001, 1_000_002] {
        let mut j = job(scene, width, height, Method::Uniform, seed)?;
        j.halt = Halt { max_passes: 64, max_mean_spp: spp, time_budget: None, target_error: None };
        frames.push(final_frame(&j));
    }
    let own = rmse(&frames[0], &frames[1]) / 2f64.sqrt() / image_mean(&frames[0]);
    Ok((frames.swap_remove(0), own))
}

/// Renders `scene` with `method` to `target` (no other halt but `max_seconds`) and measures it.
pub fn measure(
    scene: &str,
    (width, height): (u32, u32),
    method: Method,
    target: f64,
    max_seconds: f64,
    reference: &(Frame, f64),
) -> anyhow::Result<NoiseRow> {
    let mut j = job(scene, width, height, method, 7)?;
    let budget = Some(std::time::Duration::from_secs_f64(max_seconds));
    j.halt = Halt { max_passes: 64, max_mean_spp: f64::INFINITY, time_budget: budget, target_error: Some(target) };
    let f = final_frame(&j);
    let (ref_frame, ref_error) = reference;
    let mean = image_mean(ref_frame);
    let measured = (rmse(&f, ref_frame) / mean).powi(2);
    let truth = (measured - ref_error * ref_error).max(0.0).sqrt();
    Ok(NoiseRow {
        scene: scene.to_string(),
        method,
        target,
        estimated: f.stats.estimated_error.unwrap_or(f64::NAN),
        truth,
        mean_spp: f.stats.mean_spp,
        seconds: f.stats.elapsed_seconds,
        halted_by_target: f.stats.halt_reason == crate::pipeline::frame::HaltReason::NoiseTarget,
    })
}
