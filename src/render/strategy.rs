//! The per-pass sampling-and-filtering strategy interface, and the stop check every pass obeys.
use super::aaf::{ShadowMode, ShadowStrategy};
use super::frame::Frame;
use super::light::Light;
use super::progressive::{CancelToken, Method, RenderError, RenderJob};
use super::scene::Scene;
use super::uniform::Uniform;
use std::time::Instant;

/// Tells a pass when to stop early: on cancellation (the render ends) or at the time-budget
/// deadline (the pass ends partially and becomes the final frame).
#[derive(Clone, Debug)]
pub struct StopCheck {
    pub cancel: CancelToken,
    pub deadline: Option<Instant>,
}

impl StopCheck {
    #[inline]
    pub fn should_stop(&self) -> bool {
        self.cancel.is_cancelled() || self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancel.is_cancelled()
    }
}

pub struct PassContext<'a> {
    pub scene: &'a Scene,
    pub job: &'a RenderJob,
    pub pass: u32,
    pub stop: &'a StopCheck,
}

/// A pass's outcome: its frame (stats: mean spp, rays, dropped samples, method seconds filled
/// in; the progressive loop fills in the rest) and whether the deadline cut it short.
pub struct PassOutput {
    pub frame: Frame,
    pub complete: bool,
}

pub trait Strategy: Send {
    /// Adds pass `ctx.pass`'s samples and produces its frame.
    fn run_pass(&mut self, ctx: &PassContext) -> Result<PassOutput, RenderError>;
}

/// The strategy of `job.method`. The shadow methods work on rectangular area lights; a scene
/// without any has nothing for them to filter, and renders as `uniform`.
pub fn make_strategy(job: &RenderJob) -> Box<dyn Strategy> {
    let has_area_light = job.scene.lights.iter().any(|l| matches!(l, Light::Rect(_)));
    let shadow = |mode| -> Box<dyn Strategy> {
        if has_area_light {
            Box::new(ShadowStrategy::new(job, mode))
        } else {
            Box::new(Uniform::new(job))
        }
    };
    match job.method {
        Method::Uniform => Box::new(Uniform::new(job)),
        Method::Aaf => shadow(ShadowMode::Aaf),
        Method::Adaptive => shadow(ShadowMode::Adaptive),
        Method::UniformFiltered => shadow(ShadowMode::UniformFiltered),
    }
}
