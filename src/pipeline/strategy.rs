//! The per-pass strategy interface every method implements, the context a pass sees, and the
//! sum of parts that methods splitting the light into parts (shadows, indirect) build on.
use super::frame::Frame;
use super::job::{RenderError, RenderJob, StopCheck};
use crate::render::camera::Camera;
use crate::render::gbuffer::GBuffer;
use crate::render::scene::Scene;
use std::sync::Arc;

pub struct PassContext<'a> {
    pub scene: &'a Scene,
    pub job: &'a RenderJob,
    /// The render's view (`job.view`).
    pub view: &'a Camera,
    pub pass: u32,
    pub stop: &'a StopCheck,
    /// The render's one G-buffer, built by the pipeline before pass 0 for methods whose
    /// registry row asks for it, and shared by all their parts.
    pub gbuffer: Option<&'a Arc<GBuffer>>,
}

impl PassContext<'_> {
    /// The shared G-buffer. Only methods whose registry row sets `needs_gbuffer` may call this.
    pub fn gbuffer(&self) -> &Arc<GBuffer> {
        self.gbuffer.expect("the method's registry row must set needs_gbuffer")
    }
}

/// What a pass's sampling did: whether every pixel got the pass's samples (false when the
/// deadline cut the pass; every pixel still holds a valid estimate), the samples per pixel so
/// far (the mean of the frame's spp map: the spp halt reads it before any frame is composed),
/// and the rays traced and non-finite samples dropped so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sampled {
    pub complete: bool,
    pub mean_spp: f64,
    pub rays_traced: u64,
    pub dropped_samples: u64,
}

/// A method's progressive render, pass by pass. The loop calls `sample` once per pass and
/// `frame` only for the passes whose frame someone uses (the final one, those the caller
/// streams, every one under a noise target): filtering a frame nobody sees would spend a
/// preview budget on nothing. So `sample` must leave everything the next pass's sampling reads
/// (sample counts, filter widths it marks by) up to date, and `frame` must change nothing
/// the samples depend on: a render's final frame is the same whichever frames were composed.
pub trait Strategy: Send {
    /// Adds pass `ctx.pass`'s samples.
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError>;

    /// The frame of every sample so far (stats: mean spp, rays, dropped samples and method
    /// seconds filled in; the progressive loop fills in the rest). Called after `sample` of
    /// the same pass. A cancelled render may end here with `RenderError::Cancelled` (its frame
    /// would be thrown away: a session's camera change waits for this to return); a deadline
    /// never cuts a frame short.
    fn frame(&mut self, ctx: &PassContext) -> Result<Frame, RenderError>;
}

/// Strategies that each render one part of the light; a frame is the sum of theirs. The
/// total spp map adds up the parts' camera samples; the filter-width map is the widest.
pub struct SumOfParts {
    pub parts: Vec<Box<dyn Strategy>>,
}

impl Strategy for SumOfParts {
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError> {
        let mut total = Sampled { complete: true, ..Sampled::default() };
        for (i, part) in self.parts.iter_mut().enumerate() {
            let start = std::time::Instant::now();
            let s = part.sample(ctx)?;
            tracing::debug!(pass = ctx.pass, part = i, seconds = start.elapsed().as_secs_f64(), "part sampled");
            // The spp maps add up, so their means do.
            total = Sampled {
                complete: total.complete && s.complete,
                mean_spp: total.mean_spp + s.mean_spp,
                rays_traced: total.rays_traced + s.rays_traced,
                dropped_samples: total.dropped_samples + s.dropped_samples,
            };
        }
        Ok(total)
    }

    fn frame(&mut self, ctx: &PassContext) -> Result<Frame, RenderError> {
        let mut frames = self.parts.iter_mut().map(|part| part.frame(ctx));
        let first = frames.next().transpose()?.unwrap_or_default();
        frames.try_fold(first, |sum, frame| Ok(add_frames(sum, frame?)))
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
