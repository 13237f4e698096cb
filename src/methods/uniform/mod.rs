//! `uniform`: plain Monte Carlo, the same samples per pixel everywhere, no filter. The baseline
//! every other method is measured against. Pass 0 takes `initial_spp`; each later pass doubles
//! the total, so frame k has initial_spp * 2^k samples per pixel (capped at max_mean_spp).
pub mod options;

use crate::pipeline::film::Film;
use crate::pipeline::frame::{Frame, FrameStats};
use crate::pipeline::job::{RenderError, RenderJob};
use crate::pipeline::strategy::{PassContext, Sampled, Strategy};

pub struct Uniform {
    film: Film,
    /// Samples per pixel every pixel has been asked for so far.
    spp: u64,
    rays: u64,
    dropped: u64,
}

impl Uniform {
    pub fn new(job: &RenderJob) -> Self {
        Uniform { film: Film::new(job.width(), job.height()), spp: 0, rays: 0, dropped: 0 }
    }

    /// Samples per pixel to add in `pass`.
    pub fn pass_spp(initial: u32, pass: u32, done: u64, max_mean_spp: f64) -> u32 {
        let initial = initial.max(1) as u64;
        let target = if pass == 0 { initial } else { initial.saturating_mul(1u64 << pass.min(40)) };
        let cap = if max_mean_spp > 0.0 { max_mean_spp.ceil() as u64 } else { u64::MAX };
        target.min(cap).saturating_sub(done).min(u32::MAX as u64) as u32
    }
}

impl Strategy for Uniform {
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError> {
        let job = ctx.job;
        let k = Self::pass_spp(job.initial_spp, ctx.pass, self.spp, job.halt.max_mean_spp);
        let tally = self.film.add_samples(ctx.scene, job, &|_| k, ctx.stop)?;
        self.spp += k as u64;
        self.rays += tally.rays;
        self.dropped += tally.dropped;
        Ok(Sampled {
            complete: tally.complete,
            mean_spp: self.film.mean_taken(),
            rays_traced: self.rays,
            dropped_samples: self.dropped,
        })
    }

    fn frame(&mut self, _ctx: &PassContext) -> Result<Frame, RenderError> {
        Ok(Frame {
            shading: None,
            width: self.film.width,
            height: self.film.height,
            color: self.film.mean_image(),
            unfiltered: None,
            spp: self.film.spp_map(),
            filter_width: None,
            components: Vec::new(),
            aovs: None,
            stats: FrameStats {
                // Samples drawn, including any dropped as non-finite (the spp map counts the
                // ones kept), so a dropped sample cannot keep the spp halt from firing.
                mean_spp: self.film.mean_taken(),
                rays_traced: self.rays,
                dropped_samples: self.dropped,
                ..FrameStats::default()
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_double_the_total_and_stop_at_the_cap() {
        let mut done = 0u64;
        let mut totals = Vec::new();
        for pass in 0..10 {
            let k = Uniform::pass_spp(1, pass, done, 100.0);
            done += k as u64;
            totals.push(done);
        }
        assert_eq!(totals, [1, 2, 4, 8, 16, 32, 64, 100, 100, 100]);
        assert_eq!(Uniform::pass_spp(4, 0, 0, 0.0), 4);
        assert_eq!(Uniform::pass_spp(4, 3, 16, 0.0), 16);
        assert_eq!(Uniform::pass_spp(1, 1000, 0, 0.0), u32::MAX);
    }
}
