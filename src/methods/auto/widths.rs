//! `auto`'s per-pixel filter widths (methods.md §5.2): the AAF papers' widths at the mu the
//! pixel's samples reach, in pixels.
use super::options::AutoOptions;
use super::sample::IndirectSums;
use crate::methods::aaf_indirect::glossy_model;
use crate::methods::aaf_indirect::params::{self as indirect, omega_h_glossy, Reflectors};
use crate::methods::aaf_shadows::params::{self as shadows, PixelGeometry};
use crate::methods::aaf_shadows::ShadowLight;
use crate::pipeline::strategy::PassContext;
use crate::render::gbuffer::GBuffer;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;

pub(super) struct Widths {
    gbuffer: Arc<GBuffer>,
    /// Where the projected pixel sizes are seen from; each paper's options say whether they
    /// count foreshortening (`GSample::projected_size`, found as the widths read them).
    camera: Vec3,
    /// Per pixel, the mean nearest and farthest reflector of its neighbourhood's analysis
    /// samples (the pixel itself left out); None where none was seen.
    reflectors: Vec<Option<(f32, f32)>>,
}

impl Widths {
    pub fn new(ctx: &PassContext, g: &Arc<GBuffer>) -> Self {
        Widths { gbuffer: Arc::clone(g), camera: ctx.view.position, reflectors: vec![None; g.pixels.len()] }
    }

    /// Recomputes each pixel's reflector distances from its neighbours on the same object.
    pub fn update_reflectors(&mut self, sums: &[IndirectSums], opts: &AutoOptions) {
        let g = &self.gbuffer;
        self.reflectors = neighbourhood_reflectors(g.width as usize, g.height as usize, opts.reflector_radius, &|p| {
            let (c, s) = (&g.pixels[p], &sums[p]);
            Seen { valid: c.is_valid(), object: c.object, z: s.z_min.is_finite().then_some((s.z_min, s.z_max)) }
        });
    }

    /// The screen width (standard deviation, pixels) of a light's visibility at each pixel, from
    /// the `slopes` each pixel is filtered with:
    /// Mehta 2012 Eq. 13 at the mu of the pixel's samples; 0 where no slopes were found (no
    /// occluder nearby: nothing to filter).
    pub fn shadow(
        &self,
        ctx: &PassContext,
        light: &ShadowLight,
        slopes: impl Fn(usize) -> Option<(f64, f64)> + Sync,
        taken: &[u32],
        opts: &AutoOptions,
    ) -> Vec<f32> {
        let aaf = &ctx.job.aaf;
        // A table no longer than the image (a tiny image at many samples computes fewer).
        let growths = opts.growths(taken.par_iter().copied().max().unwrap_or(0).min(taken.len() as u32));
        (self.gbuffer.pixels.par_iter().enumerate())
            .map(|(p, g)| {
                let d = g.projected_size(self.camera, aaf.foreshortening);
                let Some((s1, s2)) = slopes(p) else { return 0.0 };
                if !(d > 0.0) {
                    return 0.0;
                }
                let mu = growths.mu(aaf.mu0 * light.mu_scale, taken[p]);
                let geometry = PixelGeometry { s1, s2, sigma: light.sigma, d };
                let beta = shadows::filter_width(&geometry, &aaf.constants, mu) * opts.shadow_width_scale;
                finite_px(beta / d, growths.max_sigma(taken[p]))
            })
            .collect()
    }

    /// The screen width of the diffuse or glossy indirect light at each pixel: Mehta 2013
    /// Eqs. 15-16 at the mu of the pixel's `taken` samples of that component; 0 where no
    /// reflector was seen.
    pub fn indirect(&self, ctx: &PassContext, glossy: bool, taken: &[u32], opts: &AutoOptions) -> Vec<f32> {
        let ind = &ctx.job.indirect;
        let c = &ind.constants;
        let z_floor = c.z_min_fraction * ctx.scene.max_extent() as f64;
        let most = taken.par_iter().copied().max().unwrap_or(0);
        let growths = opts.growths(most.min(taken.len() as u32));
        (self.gbuffer.pixels.par_iter().enumerate())
            .map(|(p, g)| {
                let d = g.projected_size(self.camera, ind.foreshortening);
                let Some((z_min, z_max)) = self.reflectors[p] else { return 0.0 };
                if !(d > 0.0) {
                    return 0.0;
                }
                let omega_h = if glossy {
                    omega_h_glossy(glossy_model(ctx.scene, g.material), g.exponent as f64, c)
                } else {
                    c.omega_h_diffuse
                };
                let z_min = (z_min as f64).max(z_floor);
                let r = Reflectors { z_min, z_max: (z_max as f64).max(z_min), omega_h, d };
                let n = taken[p];
                let mu = growths.mu(ind.mu0, n);
                let beta = indirect::filter_width(&r, c, mu) * ind.kernel_scale * opts.indirect_width_scale;
                finite_px(beta / d, growths.max_sigma(n))
            })
            .collect()
    }
}

/// A width in pixels as f32, at most `max` (`AutoOptions::max_sigma`); 0 for anything not
/// finite and positive.
fn finite_px(w: f64, max: f64) -> f32 {
    if w.is_finite() && w > 0.0 {
        w.min(max) as f32
    } else {
        0.0
    }
}

/// What `neighbourhood_reflectors` needs of a pixel: whether it is filtered, its object, and
/// the nearest and farthest reflector its analysis samples saw (None: none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Seen {
    pub valid: bool,
    pub object: u32,
    pub z: Option<(f32, f32)>,
}

/// Per valid pixel, the means of the nearest and farthest reflectors seen by the pixels of the
/// same object in the (2 radius + 1)^2 window around it, the pixel itself left out; None where
/// none was seen. Where the whole window is one object (most pixels), from separable box sums;
/// elsewhere by visiting the window. Bands of rows run in parallel, each with the row sums of
/// its own rows and the `radius` rows around them, as `aaf_shadows::fill_slopes`: no
/// image-sized buffer besides the result.
pub(super) fn neighbourhood_reflectors(
    w: usize,
    h: usize,
    radius: usize,
    seen: &(dyn Fn(usize) -> Seen + Sync),
) -> Vec<Option<(f32, f32)>> {
    const BAND: usize = 32;
    let mut out = vec![None; w * h];
    if w == 0 {
        return out;
    }
    // Sums of (count, z_min, z_max) and the lowest and highest object over a span.
    let own = |s: &Seen| s.z.map_or([0.0; 3], |(a, b)| [1.0, a as f64, b as f64]);
    let add = |a: ([f64; 3], u32, u32), b: ([f64; 3], u32, u32)| {
        ([a.0[0] + b.0[0], a.0[1] + b.0[1], a.0[2] + b.0[2]], a.1.min(b.1), a.2.max(b.2))
    };
    let empty = ([0.0; 3], u32::MAX, 0);
    out.par_chunks_mut(BAND * w).enumerate().for_each_init(
        || (Vec::new(), Vec::new()),
        |(pixels, across), (band, out)| {
            let (y0, y1) = (band * BAND, (band * BAND + BAND).min(h));
            let (p0, p1) = (y0.saturating_sub(radius), (y1 + radius).min(h));
            // The band's rows and the `radius` rows around it: each pixel as seen, and the sums
            // over the span of 2 radius + 1 pixels centred on it.
            pixels.clear();
            pixels.extend((p0 * w..p1 * w).map(seen));
            let entry = |s: &Seen| (own(s), s.object, s.object);
            across.clear();
            across.extend((0..pixels.len()).map(|i| {
                let (x, row) = (i % w, i - i % w);
                (x.saturating_sub(radius)..(x + radius + 1).min(w))
                    .fold(empty, |acc, nx| add(acc, entry(&pixels[row + nx])))
            }));
            for (i, out) in out.iter_mut().enumerate() {
                let (x, y) = (i % w, y0 + i / w);
                let c = &pixels[(y - p0) * w + x];
                if !c.valid {
                    continue;
                }
                let window = (y.saturating_sub(radius)..(y + radius + 1).min(h))
                    .fold(empty, |acc, ny| add(acc, across[(ny - p0) * w + x]));
                let [count, z_min, z_max] = if window.1 == c.object && window.2 == c.object {
                    let o = own(c);
                    [window.0[0] - o[0], window.0[1] - o[1], window.0[2] - o[2]]
                } else {
                    let mut sum = [0.0f64; 3];
                    for q in super::window(w, h, y * w + x, radius) {
                        let s = &pixels[q - p0 * w];
                        if q != y * w + x && s.object == c.object {
                            let e = own(s);
                            sum = [sum[0] + e[0], sum[1] + e[1], sum[2] + e[2]];
                        }
                    }
                    sum
                };
                *out = (count > 0.5).then(|| ((z_min / count) as f32, (z_max / count) as f32));
            }
        },
    );
    out
}
