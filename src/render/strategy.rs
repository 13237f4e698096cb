//! The per-pass sampling-and-filtering strategy interface, and the stop check every pass obeys.
use super::aaf::ShadowStrategy;
use super::frame::Frame;
use super::indirect::IndirectStrategy;
use super::light::Light;
use super::progressive::{CancelToken, Integrand, Method, RenderError, RenderJob};
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

/// What the AAF-family strategies do with their samples (the curves of the soft-shadow
/// paper's Fig. 6c and the indirect paper's Fig. 10a).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterMode {
    /// Adaptive sampling and adaptive filtering: the method.
    Aaf,
    /// AAF's sample counts, no filter.
    Adaptive,
    /// The same samples everywhere (doubling per pass) and a fixed-width filter.
    UniformFiltered,
}

/// The strategy of `job.method`. The AAF family splits the light into the parts a scene has:
/// area-light direct light (soft shadows, when the scene has rectangular lights) and indirect
/// light (when the request asks for bounces, or for ambient occlusion). Each part runs its own
/// strategy and the frames add up; a scene with neither renders as `uniform`.
pub fn make_strategy(job: &RenderJob) -> Box<dyn Strategy> {
    let mode = match job.method {
        Method::Uniform => return Box::new(Uniform::new(job)),
        Method::Aaf => FilterMode::Aaf,
        Method::Adaptive => FilterMode::Adaptive,
        Method::UniformFiltered => FilterMode::UniformFiltered,
    };
    let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
    let shadows = !ao && job.scene.lights.iter().any(|l| matches!(l, Light::Rect(_)));
    let indirect = ao || job.bounces > 0;
    match (shadows, indirect) {
        (false, false) => Box::new(Uniform::new(job)),
        (true, false) => Box::new(ShadowStrategy::new(job, mode)),
        (false, true) => Box::new(IndirectStrategy::new(job, mode, true)),
        (true, true) => Box::new(SumOfParts {
            parts: vec![Box::new(ShadowStrategy::new(job, mode)), Box::new(IndirectStrategy::new(job, mode, false))],
        }),
    }
}

/// The names of the per-component maps (`Frame::components`) the frames of `job` carry, in
/// order: known before the render starts, so a stream can announce its layers.
pub fn component_names(job: &RenderJob) -> Vec<&'static str> {
    if job.method == Method::Uniform {
        return Vec::new();
    }
    let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
    let shadows = !ao && job.scene.lights.iter().any(|l| matches!(l, Light::Rect(_)));
    let mut names = Vec::new();
    if shadows {
        names.push("shadow");
    }
    if ao || job.bounces > 0 {
        names.push("diffuse");
        if !ao && IndirectStrategy::has_glossy(&job.scene) {
            names.push("glossy");
        }
    }
    names
}

/// Strategies that each render one part of the light; a frame is the sum of theirs. The
/// total spp map adds up the parts' camera samples; the filter-width map is the widest.
pub struct SumOfParts {
    parts: Vec<Box<dyn Strategy>>,
}

impl Strategy for SumOfParts {
    fn run_pass(&mut self, ctx: &PassContext) -> Result<PassOutput, RenderError> {
        let mut total: Option<PassOutput> = None;
        for part in &mut self.parts {
            let out = part.run_pass(ctx)?;
            total = Some(match total {
                None => out,
                Some(acc) => {
                    PassOutput { frame: add_frames(acc.frame, out.frame), complete: acc.complete && out.complete }
                }
            });
        }
        Ok(total.unwrap_or_else(|| PassOutput { frame: Frame::default(), complete: true }))
    }
}

fn add_frames(mut a: Frame, b: Frame) -> Frame {
    let add_rgb = |x: &mut [[f32; 3]], y: &[[f32; 3]]| {
        for (p, q) in x.iter_mut().zip(y) {
            for c in 0..3 {
                p[c] += q[c];
            }
        }
    };
    let mut unfiltered = a.unfiltered_color().to_vec();
    add_rgb(&mut unfiltered, b.unfiltered_color());
    add_rgb(&mut a.color, &b.color);
    a.unfiltered = (a.unfiltered.is_some() || b.unfiltered.is_some()).then_some(unfiltered);
    for (p, q) in a.spp.iter_mut().zip(&b.spp) {
        *p += q;
    }
    a.filter_width = match (a.filter_width.take(), b.filter_width) {
        (Some(mut x), Some(y)) => {
            for (p, q) in x.iter_mut().zip(&y) {
                *p = p.max(*q);
            }
            Some(x)
        }
        (x, y) => x.or(y),
    };
    a.components.extend(b.components);
    let n = a.spp.len().max(1) as f64;
    a.stats.mean_spp = a.spp.iter().map(|&s| s as f64).sum::<f64>() / n;
    a.stats.rays_traced += b.stats.rays_traced;
    a.stats.dropped_samples += b.stats.dropped_samples;
    a.stats.method_seconds += b.stats.method_seconds;
    a
}
