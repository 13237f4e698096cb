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

/// A pass's outcome: its frame (stats: mean spp, rays, dropped samples, method seconds filled
/// in; the progressive loop fills in the rest) and whether every pixel got the pass's samples
/// (false when the deadline cut the pass; every pixel still holds a valid estimate).
pub struct PassOutput {
    pub frame: Frame,
    pub complete: bool,
}

pub trait Strategy: Send {
    /// Adds pass `ctx.pass`'s samples and produces its frame.
    fn run_pass(&mut self, ctx: &PassContext) -> Result<PassOutput, RenderError>;
}

/// Strategies that each render one part of the light; a frame is the sum of theirs. The
/// total spp map adds up the parts' camera samples; the filter-width map is the widest.
pub struct SumOfParts {
    pub parts: Vec<Box<dyn Strategy>>,
}

impl Strategy for SumOfParts {
    fn run_pass(&mut self, ctx: &PassContext) -> Result<PassOutput, RenderError> {
        let mut total: Option<PassOutput> = None;
        for (i, part) in self.parts.iter_mut().enumerate() {
            let start = std::time::Instant::now();
            let out = part.run_pass(ctx)?;
            tracing::debug!(pass = ctx.pass, part = i, seconds = start.elapsed().as_secs_f64(), "part done");
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
