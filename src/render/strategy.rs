//! The per-pass sampling-and-filtering strategy interface, and the stop check every pass obeys.
use super::frame::Frame;
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

pub fn make_strategy(job: &RenderJob) -> Box<dyn Strategy> {
    match job.method {
        Method::Uniform => Box::new(Uniform::new(job)),
    }
}
