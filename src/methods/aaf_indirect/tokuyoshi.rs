//! The lobe- and normal-aware modes (methods.md §3.4): Tokuyoshi's guides built once
//! from the G-buffer, his gather in place of the AAF filter, and his joint upsampling with the
//! re-render of Fig. 16 (`Upsampling`).
use super::{glossy_model, IndirectStrategy, Part};
use crate::methods::lobe_aware::asg::AsgLobe;
use crate::methods::lobe_aware::filter::{self, BilateralOptions, Gather, Guide, Similarity};
use crate::methods::lobe_aware::lobe;
use crate::methods::lobe_aware::options::{LobeAwareOptions, LobeShape};
use crate::methods::lobe_aware::upsample::{upsample, weight_sums, Grid, UpsampleWeights};
use crate::methods::mode::FilterMode;
use crate::pipeline::job::CancelToken;
use crate::pipeline::strategy::PassContext;
use crate::render::gbuffer::{GBuffer, GSample};
use rayon::prelude::*;

/// Tokuyoshi's guides from the G-buffer: each pixel's diffuse lobe about its normal, or with
/// `glossy` its specular lobe (App. B), smoothed with the render's kappa (Eq. 10). Valid at any
/// hit; the filters also ask each pixel for samples that reached a reflecting surface (an area
/// light's pixel at its edge has some). Shared by the lobe- and normal-aware modes and `auto`.
/// With `LobeShape::Asg` glossy pixels also carry their lobe as an ASG (Eq. 13).
pub(crate) fn guides(ctx: &PassContext, g: &GBuffer, glossy: bool, o: &LobeAwareOptions, kappa: f64) -> Vec<Guide> {
    g.pixels.par_iter().map(|s| guide(ctx, s, glossy, o, kappa)).collect()
}

/// One pixel's guide (`guides`), for callers that keep another form of it and need not hold
/// the image of `Guide`s.
pub(crate) fn guide(ctx: &PassContext, s: &GSample, glossy: bool, o: &LobeAwareOptions, kappa: f64) -> Guide {
    let n = s.normal.as_dvec3();
    let (lobe, asg) = if glossy {
        let psi = (ctx.view.position.as_dvec3() - s.position.as_dvec3()).normalize_or_zero();
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
}

/// Joint upsampling while it lasts (Tokuyoshi Sec. 5, Fig. 16): which pixels trace indirect
/// light, and what the others upsample from. Built once per render from the G-buffer alone.
pub(super) struct Upsampling {
    grid: Grid,
    /// Per part: the upsampling guides (lobes smoothed with the upsampling kappa) and the sites
    /// that give light (valid, reflecting the part at their centre).
    guides: Vec<Vec<Guide>>,
    sources: Vec<Vec<bool>>,
    /// The pixels that trace indirect light: the sites and the re-rendered pixels.
    pub(super) traced: Vec<bool>,
    /// How many pixels that are not sites are re-rendered.
    pub(super) rerendered: usize,
}

impl Upsampling {
    /// The sites of a grid of `o.upsample.factor` and, per part, the pixels whose weights over
    /// those sites sum below `o.upsample.rerender_below` (Fig. 16), which trace their own light.
    pub(super) fn new(
        ctx: &PassContext,
        g: &GBuffer,
        parts: &[Part],
        similarity: Similarity,
        o: &LobeAwareOptions,
    ) -> Self {
        let grid = Grid::new(o.upsample.factor as usize, g.width as usize, g.height as usize);
        let weights = UpsampleWeights { similarity, sigma_z2_relative: o.weights.sigma_z2_relative };
        let n = g.pixels.len();
        let reflects = |part: Part, p: usize| {
            let s = &g.pixels[p];
            s.is_valid() && if part == Part::Glossy { s.ks != glam::Vec3::ZERO } else { s.kd != glam::Vec3::ZERO }
        };
        let mut traced: Vec<bool> = (0..n).map(|p| grid.is_site(p)).collect();
        let (mut guides, mut sources) = (Vec::new(), Vec::new());
        for &part in parts {
            let gd = self::guides(ctx, g, part == Part::Glossy, o, o.upsample.kappa);
            let src: Vec<bool> = (0..n).map(|p| grid.is_site(p) && gd[p].valid && reflects(part, p)).collect();
            let sums = weight_sums(&gd, &src, &grid, &weights);
            for (p, t) in traced.iter_mut().enumerate() {
                *t |= reflects(part, p) && sums[p] < o.upsample.rerender_below;
            }
            guides.push(gd);
            sources.push(src);
        }
        let rerendered = (0..n).filter(|&p| traced[p] && !grid.is_site(p)).count();
        Upsampling { grid, guides, sources, traced, rerendered }
    }
}

impl IndirectStrategy {
    /// The directional weight of the mode: Eq. 4 for `normal-aware`, Eq. 12 otherwise.
    pub(super) fn similarity(&self) -> Similarity {
        let w = &self.lobe_opts.weights;
        match self.mode {
            FilterMode::NormalAware => Similarity::Normal { sigma_n2: w.sigma_n2 },
            _ => Similarity::Lobe { beta: w.beta },
        }
    }

    /// Filters the untextured light of `part` with Tokuyoshi's gather (Eq. 1), pixel p's screen
    /// kernel `sigma(p)` pixels wide (narrowing with the samples for the lobe- and
    /// normal-aware methods); pixels whose samples found no reflecting
    /// surface stay out. While upsampling (and in the pass that ends it, if the deadline cuts
    /// it), the pixels without samples of the part get the filtered light of their sites,
    /// upsampled, and the gather is the full 2-D one (the separable one would miss the rows
    /// without sites); `raw` gets the unfiltered light upsampled the same way (the stream's
    /// unfiltered layer). Once `cancel` trips, the gather stops and leaves `light` as it was
    /// (`compose` then throws the frame away).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn filter_tokuyoshi(
        &self,
        part: Part,
        sigma: impl Fn(usize) -> f64 + Sync,
        light: &mut Vec<[f64; 3]>,
        raw: &mut [[f64; 3]],
        part_width: &mut [f32],
        width_px: &mut [f32],
        cancel: &CancelToken,
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
        let untraced = |p: usize| part.of(&self.sums[p]).n == 0;
        let sparse = self.upsampling.is_some() && (0..guides.len()).any(|p| self.guides[index][p].valid && untraced(p));
        let similarity = self.similarity();
        let opts = BilateralOptions {
            similarity,
            sigma_z2_relative: o.weights.sigma_z2_relative,
            max_radius: o.max_radius,
            gather: if sparse { Gather::Full } else { o.gather },
        };
        // Each pixel's light is the mean over its samples that found a reflecting surface.
        let counts: Vec<f64> = self.sums.par_iter().map(|s| part.of(s).surface as f64).collect();
        // Cancelled: `compose` throws the frame away.
        let cancelled = || cancel.is_cancelled();
        let Some(f) = filter::filter_counted_until(&guides, self.width, light, Some(&counts), &opts, &cancelled) else {
            return;
        };
        *light = f.values;
        for ((pw, wp), g) in part_width.iter_mut().zip(width_px.iter_mut()).zip(&guides) {
            *pw = g.sigma_px as f32;
            *wp = wp.max(*pw);
        }
        let Some(u) = self.upsampling.as_ref().filter(|_| sparse) else { return };
        // Sources that found light this time (a site at a light's edge may have none).
        let sources: Vec<bool> =
            u.sources[index].iter().zip(&self.sums).map(|(&s, sums)| s && part.of(sums).surface > 0).collect();
        let weights = UpsampleWeights { similarity, sigma_z2_relative: o.weights.sigma_z2_relative };
        let (up, up_raw) = rayon::join(
            || upsample(&u.guides[index], &sources, light, &u.grid, &weights),
            || upsample(&u.guides[index], &sources, raw, &u.grid, &weights),
        );
        for p in 0..light.len() {
            if untraced(p) {
                light[p] = up[p].unwrap_or([0.0; 3]);
                raw[p] = up_raw[p].unwrap_or([0.0; 3]);
                if up[p].is_some() {
                    part_width[p] = sigma(p) as f32;
                    width_px[p] = width_px[p].max(part_width[p]);
                }
            }
        }
    }
}
