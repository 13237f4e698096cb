//! The progressive renderer: a render is a sequence of passes; each pass adds samples to the
//! running per-pixel estimate and yields a frame, until a halt condition is met.
use super::frame::{Frame, FrameStats, HaltReason};
use super::scene::Scene;
use super::strategy::{make_strategy, PassContext, PassOutput, StopCheck};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Shared flag that stops a render within one tile's work.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Halt conditions; the render stops at whichever is met first. Every render yields at least
/// one frame: a time budget that ends inside pass 0 gives a partial first frame (its spp map
/// shows which pixels it reached).
#[derive(Clone, Debug, PartialEq)]
pub struct Halt {
    pub max_passes: u32,
    pub max_mean_spp: f64,
    pub time_budget: Option<Duration>,
}

/// The sampling-and-filtering strategy of each pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Plain Monte Carlo, unfiltered: the baseline.
    Uniform,
    /// Axis-aligned filtering of area-light soft shadows (Mehta et al. 2012).
    Aaf,
    /// AAF's adaptive sample counts without its filter.
    Adaptive,
    /// The same samples everywhere with a fixed-width filter.
    UniformFiltered,
}

impl Method {
    pub const ALL: &'static [Method] = &[Method::Uniform, Method::Aaf, Method::Adaptive, Method::UniformFiltered];
    pub fn name(self) -> &'static str {
        match self {
            Method::Uniform => "uniform",
            Method::Aaf => "aaf",
            Method::Adaptive => "adaptive",
            Method::UniformFiltered => "uniform-filtered",
        }
    }
    /// Whether frames of this method are filtered (then they carry unfiltered colour and
    /// filter widths of their own).
    pub fn filters(self) -> bool {
        match self {
            Method::Uniform | Method::Adaptive => false,
            Method::Aaf | Method::UniformFiltered => true,
        }
    }

    pub fn from_name(name: &str) -> Option<Method> {
        Self::ALL.iter().copied().find(|m| m.name() == name)
    }
}

/// What a render estimates at each pixel.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Integrand {
    /// Light arriving at the camera.
    #[default]
    Radiance,
    /// Ambient occlusion: the fraction of the cosine-weighted hemisphere above the visible
    /// point that no geometry nearer than `max_distance` (internal units; infinite for no
    /// limit) covers. The AAF indirect paper's extension (Sec. 6) with reflector radiance 1.
    AmbientOcclusion { max_distance: f32 },
}

#[derive(Clone, Debug)]
pub struct RenderJob {
    pub scene: Arc<Scene>,
    pub method: Method,
    pub halt: Halt,
    pub seed: u64,
    /// Indirect bounces after the first hit (0: direct light only).
    pub bounces: u32,
    /// Samples per pixel of the first uniform pass.
    pub initial_spp: u32,
    /// Light or ambient occlusion.
    pub integrand: Integrand,
    /// Shade every sample at its pixel's centre (the AAF papers' setting, no antialiasing):
    /// the ground truth is then the pixel-centre image. Default: samples jittered over the pixel.
    pub pixel_centers: bool,
    /// Parameters of the AAF family of methods (soft shadows).
    pub aaf: crate::render::aaf::AafOptions,
    /// Parameters of the AAF family of methods (indirect light).
    pub indirect: crate::render::indirect::IndirectOptions,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    #[error("render cancelled")]
    Cancelled,
}

/// Runs `job` to a halt condition, calling `on_frame` with each pass's frame (on the calling
/// thread). `on_frame` returning false stops the render like a cancellation. Work runs on the
/// current rayon pool (`pool.install` chooses the threads; the image does not depend on them).
pub fn render(
    job: &RenderJob,
    cancel: &CancelToken,
    on_frame: &mut dyn FnMut(&Frame) -> bool,
) -> Result<FrameStats, RenderError> {
    let start = Instant::now();
    let mut strategy = make_strategy(job);
    let halt = &job.halt;
    for pass in 0.. {
        let stop = StopCheck { cancel: cancel.clone(), deadline: halt.time_budget.map(|b| start + b) };
        let ctx = PassContext { scene: &job.scene, job, pass, stop: &stop };
        let PassOutput { mut frame, complete } = strategy.run_pass(&ctx)?;
        let elapsed = start.elapsed();
        let reason = if halt.max_mean_spp > 0.0 && frame.stats.mean_spp >= halt.max_mean_spp {
            HaltReason::MaxSpp
        } else if pass + 1 >= halt.max_passes.max(1) {
            HaltReason::MaxPasses
        } else if !complete || halt.time_budget.is_some_and(|b| elapsed >= b) {
            HaltReason::TimeBudget
        } else {
            HaltReason::None
        };
        frame.stats.pass = pass;
        frame.stats.elapsed_seconds = elapsed.as_secs_f64();
        frame.stats.is_final = reason != HaltReason::None;
        frame.stats.halt_reason = reason;
        if !on_frame(&frame) {
            return Err(RenderError::Cancelled);
        }
        if frame.stats.is_final {
            return Ok(frame.stats);
        }
    }
    unreachable!("the pass loop only ends by returning")
}

#[cfg(test)]
mod tests;
