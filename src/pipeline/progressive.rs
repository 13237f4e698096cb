//! The progressive renderer: a render is a sequence of passes; each pass adds samples to the
//! running per-pixel estimate and yields a complete frame, until a halt condition is met.
//!
//! The loop owns what every method shares: the one G-buffer (built before pass 0 for methods
//! whose registry row asks for it, its rays counted once), the rule that pass 0 always
//! completes (only a cancellation stops it; every method makes it cheap), the deadline of
//! later passes (a cut pass still ends in a valid estimate of every pixel), and the render's
//! own error estimate behind the noise-target halt (`noise`), the denoiser inputs (AOVs)
//! when the job asks for them, and which passes' frames are composed at all (a frame nobody
//! uses is not filtered: `render_frames`).
use super::frame::{Frame, FrameStats, HaltReason};
use super::job::{CancelToken, RenderError, RenderJob, StopCheck};
use super::noise::ErrorEstimate;
use super::registry::make_strategy;
use super::strategy::{PassContext, Sampled};
use crate::render::aovs::Aovs;
use crate::render::gbuffer::GBuffer;
use std::sync::Arc;
use std::time::Instant;

/// Runs `job` to a halt condition, calling `on_frame` with each pass's frame (on the calling
/// thread). `on_frame` returning false stops the render like a cancellation. Work runs on the
/// current rayon pool (`pool.install` chooses the threads; the image does not depend on them).
pub fn render(
    job: &RenderJob,
    cancel: &CancelToken,
    on_frame: &mut dyn FnMut(&Frame) -> bool,
) -> Result<FrameStats, RenderError> {
    render_frames(job, cancel, &|_| true, &mut |_, frame| frame.is_none_or(&mut *on_frame))
}

/// Runs `job` to a halt condition, composing the frames of the passes `wanted` names (by pass
/// index), the final frame, and, under a noise target, every frame (the halt compares them).
/// `on_pass` gets every pass's stats and its frame when composed; returning false stops the
/// render like a cancellation. The final frame does not depend on which frames were composed.
pub fn render_frames(
    job: &RenderJob,
    cancel: &CancelToken,
    wanted: &dyn Fn(u32) -> bool,
    on_pass: &mut dyn FnMut(&FrameStats, Option<&Frame>) -> bool,
) -> Result<FrameStats, RenderError> {
    let start = Instant::now();
    let halt = &job.halt;
    let deadline = halt.time_budget.map(|b| start + b);
    // The G-buffer and the denoiser inputs are built before pass 0, and given up within a row
    // of work if the render is cancelled.
    let cancelled = || cancel.is_cancelled();
    let gbuffer = if (job.method.spec().needs_gbuffer)(job) {
        let g = GBuffer::build_until(&job.scene, &job.view, &cancelled);
        Some(Arc::new(g.ok_or(RenderError::Cancelled)?))
    } else {
        None
    };
    let gbuffer_rays = gbuffer.as_ref().map_or(0, |g| g.pixels.len() as u64);
    if gbuffer.is_some() {
        tracing::debug!(seconds = start.elapsed().as_secs_f64(), "G-buffer built");
    }
    // The denoiser inputs do not change from pass to pass: traced once, shared by every frame.
    let aovs = if job.aov_samples > 0 {
        let (samples, centres) = (job.aov_samples, job.pixel_centers);
        let a = Aovs::trace_until(&job.scene, &job.view, samples, job.seed, centres, &cancelled);
        Some(Arc::new(a.ok_or(RenderError::Cancelled)?))
    } else {
        None
    };
    let aov_rays = aovs.as_ref().map_or(0, |_| {
        Aovs::rays_per_pixel(job.aov_samples, job.pixel_centers) as u64 * job.width() as u64 * job.height() as u64
    });
    let mut strategy = make_strategy(job);
    let mut error = ErrorEstimate::default();
    for pass in 0.. {
        if cancel.is_cancelled() {
            return Err(RenderError::Cancelled);
        }
        let stop = StopCheck::for_pass(cancel, pass, deadline);
        let ctx = PassContext { scene: &job.scene, job, view: &job.view, pass, stop: &stop, gbuffer: gbuffer.as_ref() };
        let sampled = strategy.sample(&ctx)?;
        let Sampled { complete, mean_spp, .. } = sampled;
        tracing::debug!(pass, complete, seconds = start.elapsed().as_secs_f64(), "pass sampled");
        // The halts that need no frame, in the order they are reported.
        let limit = if halt.max_mean_spp > 0.0 && mean_spp >= halt.max_mean_spp {
            HaltReason::MaxSpp
        } else if pass + 1 >= halt.max_passes.max(1) {
            HaltReason::MaxPasses
        } else {
            HaltReason::None
        };
        let out_of_time = !complete || deadline.is_some_and(|d| Instant::now() >= d);
        let compose = halt.target_error.is_some() || limit != HaltReason::None || out_of_time || wanted(pass);
        let mut frame = if compose { Some(strategy.frame(&ctx)?) } else { None };
        // A pass the deadline cut left most pixels as they were: the change since the previous
        // frame says little about the error, so a cut frame claims no estimate.
        let estimate = frame.as_ref().and_then(|f| error.update(f)).filter(|_| complete);
        let reason = if limit != HaltReason::None {
            limit
        } else if halt.target_error.zip(estimate).is_some_and(|(target, e)| e <= target) {
            HaltReason::NoiseTarget
        } else if out_of_time {
            HaltReason::TimeBudget
        } else {
            HaltReason::None
        };
        let elapsed = start.elapsed();
        tracing::debug!(pass, composed = compose, seconds = elapsed.as_secs_f64(), "pass done");
        let stats = FrameStats {
            pass,
            mean_spp,
            rays_traced: sampled.rays_traced + gbuffer_rays + aov_rays,
            dropped_samples: sampled.dropped_samples,
            elapsed_seconds: elapsed.as_secs_f64(),
            is_final: reason != HaltReason::None,
            halt_reason: reason,
            pass_complete: complete,
            estimated_error: estimate,
            ..frame.as_ref().map(|f| f.stats.clone()).unwrap_or_default()
        };
        if let Some(f) = frame.as_mut() {
            debug_assert!(
                (f.stats.mean_spp - mean_spp).abs() <= 1e-9 * mean_spp.max(1.0),
                "the frame's mean spp {} differs from the sampling's {mean_spp}",
                f.stats.mean_spp
            );
            f.stats = stats.clone();
            f.aovs.clone_from(&aovs);
        }
        if !on_pass(&stats, frame.as_ref()) {
            return Err(RenderError::Cancelled);
        }
        if stats.is_final {
            return Ok(stats);
        }
    }
    unreachable!("the pass loop only ends by returning")
}

#[cfg(test)]
mod tests;
