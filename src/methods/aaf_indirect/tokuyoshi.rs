//! The lobe- and normal-aware modes (methods.md §3.4): Tokuyoshi's guides built once
//! from the G-buffer, and his gather in place of the AAF filter.
use super::{glossy_model, IndirectStrategy, Part};
use crate::methods::lobe_aware::asg::AsgLobe;
use crate::methods::lobe_aware::filter::{self, BilateralOptions, Guide, Similarity};
use crate::methods::lobe_aware::lobe;
use crate::methods::lobe_aware::options::{LobeAwareOptions, LobeShape};
use crate::methods::mode::FilterMode;
use crate::pipeline::strategy::PassContext;
use crate::render::gbuffer::GBuffer;
use rayon::prelude::*;

/// Tokuyoshi's guides from the G-buffer: each pixel's diffuse lobe about its normal, or with
/// `glossy` its specular lobe (App. B), smoothed with the render's kappa (Eq. 10). Valid at any
/// hit; the filters also ask each pixel for samples that reached a reflecting surface (an area
/// light's pixel at its edge has some). Shared by the lobe- and normal-aware modes and `auto`.
/// With `LobeShape::Asg` glossy pixels also carry their lobe as an ASG (Eq. 13).
pub(crate) fn guides(ctx: &PassContext, g: &GBuffer, glossy: bool, o: &LobeAwareOptions) -> Vec<Guide> {
    let kappa = o.kappa(ctx.job.bounces);
    let camera = ctx.view.position.as_dvec3();
    g.pixels
        .par_iter()
        .map(|s| {
            let n = s.normal.as_dvec3();
            let (lobe, asg) = if glossy {
                let psi = (camera - s.position.as_dvec3()).normalize_or_zero();
                let (model, exponent) = (glossy_model(ctx.scene, s.material), s.exponent as f64);
                let asg = (o.lobe.shape == LobeShape::Asg)
                    .then(|| lobe::specular_asg(model, exponent, n, psi, &o.lobe).smoothed(kappa))
                    .and_then(AsgLobe::new);
                (lobe::specular(model, exponent, n, psi, &o.lobe), asg)
            } else {
                (lobe::diffuse(n), None)
            };
            let (valid, depth) = (s.is_valid(), s.depth as f64);
            Guide { valid, depth, normal: n, lobe: lobe.smoothed(kappa), asg, sigma_px: 0.0 }
        })
        .collect()
}

impl IndirectStrategy {
    /// Filters the untextured light of `part` with Tokuyoshi's gather (Eq. 1), pixel p's screen
    /// kernel `sigma(p)` pixels wide (narrowing with the samples for the lobe- and
    /// normal-aware methods); pixels whose samples found no reflecting
    /// surface stay out.
    pub(super) fn filter_tokuyoshi(
        &self,
        part: Part,
        sigma: impl Fn(usize) -> f64 + Sync,
        light: &mut Vec<[f64; 3]>,
        part_width: &mut [f32],
        width_px: &mut [f32],
    ) {
        let o = &self.lobe_opts;
        let index = self.parts().iter().position(|&p| p == part).expect("guides for every part");
        let guides: Vec<Guide> = self.guides[index]
            .par_iter()
            .zip(&self.sums)
            .enumerate()
            .map(|(p, (g, s))| {
                let valid = g.valid && part.of(s).surface > 0;
                Guide { valid, sigma_px: if valid { sigma(p) } else { 0.0 }, ..*g }
            })
            .collect();
        let similarity = match self.mode {
            FilterMode::NormalAware => Similarity::Normal { sigma_n2: o.weights.sigma_n2 },
            _ => Similarity::Lobe { beta: o.weights.beta },
        };
        let opts = BilateralOptions {
            similarity,
            sigma_z2_relative: o.weights.sigma_z2_relative,
            max_radius: o.max_radius,
            gather: o.gather,
        };
        *light = filter::filter(&guides, self.width, light, &opts).values;
        for ((pw, wp), g) in part_width.iter_mut().zip(width_px.iter_mut()).zip(&guides) {
            *pw = g.sigma_px as f32;
            *wp = wp.max(*pw);
        }
    }
}
