//! `auto`: one frequency-guided filter for all the light (methods.md §5). The fusion no paper
//! makes: the axis-aligned filters' per-pixel widths (Mehta 2012 for area-light soft shadows,
//! Mehta 2013 for indirect light) with Tokuyoshi 2015's lobe-aware cross-bilateral weights in
//! place of their normal threshold, every part of the light filtered apart and untextured.
//!
//! - **Samples.** Four times as many per pass, the same everywhere in pass 0; from then on
//!   (`adaptive_from_spp`), in direct-light renders, nine tenths of each pass's samples go where
//!   one sample of the shadowed direct light varies most, read off each pixel's neighbourhood's
//!   shadow rays and samples (`counts.rs`). The AAF papers' counts (Eq. 21 in both) ask for
//!   far more than a preview budget has, so they are not used: the widths follow the samples a
//!   pixel has instead. One jittered camera path per sample, split at its first hit
//!   (`sample.rs`): each rectangular light's diffuse direct light as r(x) times visibility
//!   (Mehta 2012 Eq. 1: r exact, the visibility A / B the only noisy factor), the indirect
//!   light under the cosine lobe and under the glossy lobe without textures (Mehta 2013
//!   Sec. 5), and the rest (emission, point lights, glossy direct light) unfiltered.
//! - **Analysis.** The first `analysis_spp` samples of each pixel record their occluded shadow
//!   rays' slopes (Mehta 2012 Eq. 4) and their bounce rays' reflector distances (Mehta 2013
//!   Sec. 5), as the papers' sparse and initial rays do. Every pixel takes them from its
//!   neighbourhood, so that no width follows its own few samples (which biases the mean).
//! - **Widths.** At n samples per pixel each part is filtered at the width its paper gives at
//!   mu = mu0 (n / n_ref)^(1/6) (Mehta 2012 Eq. 13, Mehta 2013 Eqs. 15-16): the papers' widths
//!   at their operating point near n_ref, wider below it, narrowing as the samples grow, and
//!   never wider than a screen kernel that narrows at the same rate (`AutoOptions::max_sigma`),
//!   so that the stream converges to the `uniform` ground truth.
//! - **Filter.** Tokuyoshi's gather (Eq. 1) with the depth weight (Eq. 3) and the lobe-aware
//!   weight (Eq. 12): diffuse lobes for the visibility and the diffuse light, each pixel's
//!   specular lobe for the glossy light (`lobe_aware::packed`).
//! - **Bias against noise.** From `narrow_from_spp` samples on (`narrow_crease_from_spp` at
//!   pixels next to a change of the surface normal), the diffuse indirect light is also
//!   filtered at half its width, and each pixel leans towards that frame as far as the wide
//!   filter's bias, read off its neighbourhood, outweighs the narrow one's noise (`scales.rs`:
//!   a room's creases). From `blend_from_spp` on, each pixel leans on its own unfiltered mean
//!   the same way (`blend.rs`).
//!
//! Ambient-occlusion renders are the indirect paper's extension (Sec. 6): `auto` renders them as
//! `aaf` does. A render with nothing to filter (direct light from point and environment lights
//! alone) is plain Monte Carlo: `auto` renders it as `uniform` does.
mod blend;
mod counts;
pub mod options;
mod sample;
mod scales;
#[cfg(test)]
mod tests;
mod widths;

pub use options::AutoOptions;

use super::aaf_indirect::tokuyoshi;
use super::aaf_shadows::{fill_slopes, ratio, shadow_light, FillGrid, ShadowLight, Slopes};
use super::lobe_aware::filter::Guide;
use super::lobe_aware::packed::{gather_where, gather_with_power, PackedGuide, PackedOptions};
use super::mode::FilterMode;
use super::parts;
use super::uniform::Uniform;
use crate::pipeline::allocation::{extra_rounds, extras_round, rounds, window};
use crate::pipeline::film::{mean, Tally};
use crate::pipeline::frame::{ComponentMaps, Frame, FrameStats};
use crate::pipeline::job::{Integrand, RenderError, RenderJob};
use crate::pipeline::strategy::{PassContext, Sampled, Strategy};
use crate::render::camera_samples::CameraSamples;
use crate::render::gbuffer::GBuffer;
use crate::render::huge_pages::{collected, filled};
use crate::render::integrator::split_path_pairs;
use crate::render::light::Light;
use crate::render::sampler::hash_words;
use crate::render::wide_bvh::MAX_PACKET;
use rayon::prelude::*;
use sample::{IndirectSums, LightSums, PixelSums, Sampling};
use scales::Composed;
use std::sync::{Arc, OnceLock};
use std::time::Instant;
use widths::Widths;

/// The strategy of `auto` for `job`.
pub fn build(job: &RenderJob) -> Box<dyn Strategy> {
    match job.integrand {
        Integrand::AmbientOcclusion { .. } => parts::build(job, FilterMode::Aaf),
        Integrand::Radiance if renders_as_uniform(job) => Box::new(Uniform::new(job)),
        Integrand::Radiance => Box::new(AutoStrategy::new(job)),
    }
}

/// Whether `job` leaves `auto` nothing to filter: no rectangular light and no indirect light
/// (point and environment lights alone, direct light only). Its samples would then be plain
/// Monte Carlo's with the costs of a G-buffer, guides and filters on top, so it renders as
/// `uniform` does, sample for sample.
pub fn renders_as_uniform(job: &RenderJob) -> bool {
    matches!(job.integrand, Integrand::Radiance) && component_names(job).is_empty()
}

/// Whether the pipeline builds the G-buffer for `auto`'s render of `job`.
pub fn needs_gbuffer(job: &RenderJob) -> bool {
    !renders_as_uniform(job)
}

/// The per-component maps a frame of `job` carries, in order.
pub fn component_names(job: &RenderJob) -> Vec<&'static str> {
    if let Integrand::AmbientOcclusion { .. } = job.integrand {
        return parts::component_names(job, FilterMode::Aaf);
    }
    let mut names = Vec::new();
    if job.scene.lights.iter().any(|l| matches!(l, Light::Rect(_))) {
        names.push("shadow");
    }
    if job.bounces > 0 {
        names.push("diffuse");
        if job.scene.glossy {
            names.push("glossy");
        }
    }
    names
}

/// Random stream of `auto`'s samples.
const STREAM: u64 = 0x6175_746f;

pub struct AutoStrategy {
    opts: AutoOptions,
    width: usize,
    height: usize,
    /// The rectangular lights, and per scene light its index among them.
    lights: Vec<ShadowLight>,
    slot: Vec<Option<usize>>,
    glossy: bool,
    seed: u64,
    sums: Vec<PixelSums>,
    /// Per pixel in renders with bounces; empty in direct-light renders.
    indirect: Vec<IndirectSums>,
    /// Pixel-major: light_sums[pixel * lights + l].
    light_sums: Vec<LightSums>,
    /// Per pixel-light, the slopes its visibility is filtered with (from the neighbourhood).
    slopes: Vec<Slopes>,
    gbuffer: Option<Arc<GBuffer>>,
    /// Tokuyoshi's guides from the G-buffer: diffuse lobes and specular lobes.
    diffuse_guides: Vec<PackedGuide>,
    glossy_guides: Vec<PackedGuide>,
    /// Pixels within 2 px of a change of the surface normal (`scales::creases`), found by the
    /// first frame whose pixels have samples enough for the narrow scale to read them.
    creases: OnceLock<Vec<bool>>,
    widths: Option<Widths>,
    /// Analysis samples were added since the reflector distances were last found.
    reflectors_stale: bool,
    /// Analysis samples were added since the slopes were last found.
    slopes_stale: bool,
    /// Each light's visibility filter width at every pixel (`update_shadow_widths`), and
    /// whether they are those of the samples taken so far.
    shadow_widths: Vec<Vec<f32>>,
    shadow_widths_current: bool,
    /// Samples per pixel the passes so far asked for.
    target: u32,
    rays: u64,
    dropped: u64,
    method_seconds: f64,
}

impl AutoStrategy {
    pub fn new(job: &RenderJob) -> Self {
        let mut lights = Vec::new();
        let slot = (job.scene.lights.iter().enumerate())
            .map(|(i, l)| match l {
                Light::Rect(r) => {
                    lights.push(shadow_light(i, r, &job.aaf));
                    Some(lights.len() - 1)
                }
                Light::Point(_) | Light::Environment(_) => None,
            })
            .collect();
        AutoStrategy {
            opts: job.auto,
            width: job.width() as usize,
            height: job.height() as usize,
            lights,
            slot,
            glossy: job.bounces > 0 && job.scene.glossy,
            seed: hash_words(&[job.seed, STREAM]),
            sums: Vec::new(),
            indirect: Vec::new(),
            light_sums: Vec::new(),
            slopes: Vec::new(),
            gbuffer: None,
            diffuse_guides: Vec::new(),
            glossy_guides: Vec::new(),
            creases: OnceLock::new(),
            widths: None,
            reflectors_stale: false,
            slopes_stale: false,
            shadow_widths: Vec::new(),
            shadow_widths_current: false,
            target: 0,
            rays: 0,
            dropped: 0,
            method_seconds: 0.0,
        }
    }

    fn setup(&mut self, ctx: &PassContext) {
        let g = Arc::clone(ctx.gbuffer());
        let n = self.width * self.height;
        self.sums = filled(n, PixelSums::default());
        if ctx.job.bounces > 0 {
            self.indirect = filled(n, IndirectSums::default());
        }
        // At least one entry per pixel, so that the rows of sums and of light sums pair up
        // (`trace`) in a scene with no rectangular light too.
        self.light_sums = filled(n * self.lights.len().max(1), LightSums::default());
        let t = Instant::now();
        // Emitters neither feed nor are filtered. Each pixel's guide packed as it is made.
        let kappa = ctx.job.lobe.kappa(ctx.job.bounces);
        let packed = |glossy: bool| -> Vec<PackedGuide> {
            (g.pixels.par_iter())
                .map(|s| {
                    let guide = tokuyoshi::guide(ctx, s, glossy, &ctx.job.lobe, kappa);
                    PackedGuide::new(&Guide { valid: guide.valid && !s.emitter, ..guide })
                })
                .collect()
        };
        self.diffuse_guides = packed(false);
        if self.glossy {
            self.glossy_guides = packed(true);
        }
        self.widths = Some(Widths::new(ctx, &g));
        tracing::debug!(seconds = t.elapsed().as_secs_f64(), "auto: guides and pixel sizes");
        self.method_seconds += t.elapsed().as_secs_f64();
        self.gbuffer = Some(g);
    }

    /// Traces every pixel from `before` up to `target` samples, or up to its own count once they
    /// adapt: then first every pixel up to the pass's uniform share and only then the adaptive
    /// extras, so that a pass the deadline cuts has raised the whole image before its
    /// penumbrae. The even part runs in `ROUNDS` sweeps over the image (`rounds`), the extras
    /// in `EXTRA_ROUNDS`; without a deadline to cut the pass, one sweep each (`rounds`).
    fn trace(&mut self, ctx: &PassContext, before: u32, target: u32) -> Result<bool, RenderError> {
        let nl = self.lights.len();
        let Some(counts) =
            counts::adaptive_targets(&self.opts, target, ctx.job.bounces, self.width, &self.sums, &self.light_sums, nl)
        else {
            return self.trace_rounds(ctx, before, target, &|_| target);
        };
        let uniform = self.opts.proportional().uniform_share(target);
        if !self.trace_rounds(ctx, before, uniform, &|p| counts[p])? {
            return Ok(false);
        }
        // The extras in sweeps too, finer ones, each pixel a like fraction of its own further.
        for k in extra_rounds(ctx.stop.can_cut()) {
            if !self.trace_to(ctx, &|p| extras_round(uniform, counts[p], k))? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Each light's visibility filter width (standard deviation, pixels) at every pixel, from
    /// the slopes and the samples the pixels have: what the frame filters with and what the
    /// next pass's penumbra marks read.
    fn shadow_widths(&self, ctx: &PassContext, taken: &[u32]) -> Vec<Vec<f32>> {
        let (nl, widths) = (self.lights.len(), self.widths.as_ref().expect("set up in pass 0"));
        (0..nl)
            .map(|l| {
                let slopes = |p: usize| self.slopes.get(p * nl + l).and_then(|s| s.get());
                widths.shadow(ctx, &self.lights[l], slopes, taken, &self.opts)
            })
            .collect()
    }

    /// Each pixel's samples so far.
    fn taken(&self) -> Vec<u32> {
        self.sums.par_iter().map(|s| s.taken).collect()
    }

    /// Brings the slopes (if analysis samples were added since they were found) and each
    /// light's visibility widths at the pixels' `taken` samples up to date.
    fn update_shadow_widths(&mut self, ctx: &PassContext, taken: &[u32]) {
        let t = Instant::now();
        if std::mem::take(&mut self.slopes_stale) {
            self.update_slopes(ctx.job.aaf.fill_radius as usize);
            tracing::trace!(seconds = t.elapsed().as_secs_f64(), "auto: slopes");
        }
        self.shadow_widths = self.shadow_widths(ctx, taken);
        self.shadow_widths_current = true;
        tracing::trace!(seconds = t.elapsed().as_secs_f64(), "auto: visibility widths");
    }

    /// Marks each pixel-light whose visibility filter is narrower than `penumbra_max_width`
    /// pixels (`LightSums::narrow`): there the filter cannot average the visibility's noise
    /// over neighbours, so a camera sample in a penumbra takes `penumbra_rays` light samples
    /// (`Sampling::run`). Until the first marks every pixel counts as narrow.
    fn mark_narrow_penumbrae(&mut self) {
        let (nl, limit) = (self.lights.len(), self.opts.penumbra_max_width as f32);
        if self.opts.penumbra_rays <= 1 || nl == 0 {
            return;
        }
        let widths = &self.shadow_widths;
        self.light_sums.par_chunks_mut(nl).enumerate().for_each(|(p, lights)| {
            for (l, s) in lights.iter_mut().enumerate() {
                s.narrow = widths[l][p] < limit;
            }
        });
    }

    /// Traces every pixel p up to min(`count(p)`, `target`) in the sweeps of `rounds`: a pass
    /// the deadline cuts then leaves counts within a round of each other instead of a band of
    /// pixels at the pass's target beside the rest at the last one's. The error of a mean over
    /// the image goes as the mean of 1 / n over its pixels, which for a given number of samples
    /// is least when the counts are equal. Each sample's numbers depend on its index alone, so
    /// a complete pass traces the same samples as one sweep would.
    fn trace_rounds(
        &mut self,
        ctx: &PassContext,
        before: u32,
        target: u32,
        count: &(dyn Fn(usize) -> u32 + Sync),
    ) -> Result<bool, RenderError> {
        for round in rounds(before, target, ctx.stop.can_cut()) {
            if !self.trace_to(ctx, &|p| count(p).min(round))? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Traces every pixel p up to `count(p)` samples.
    fn trace_to(&mut self, ctx: &PassContext, count: &(dyn Fn(usize) -> u32 + Sync)) -> Result<bool, RenderError> {
        let (w, nl) = (self.width.max(1), self.lights.len());
        let sampling = Sampling {
            scene: ctx.scene,
            job: ctx.job,
            slot: &self.slot,
            analysis_spp: self.opts.analysis_spp,
            r_block: self.opts.r_block,
            penumbra_rays: self.opts.penumbra_rays,
        };
        let seed = self.seed;
        let pairs_ahead = split_path_pairs(ctx.scene, ctx.job.bounces);
        let trace_row =
            |y: usize, row: &mut [PixelSums], light_row: &mut [LightSums], mut ind: Option<&mut [IndirectSums]>| {
                let (mut rays, mut dropped) = (0u64, 0u64);
                let mut c = CameraSamples { pairs_ahead, ..CameraSamples::default() };
                for (x, px) in row.iter_mut().enumerate() {
                    if ctx.stop.should_stop() {
                        return Tally { rays, dropped, complete: false };
                    }
                    let lights = &mut light_row[x * nl..(x + 1) * nl];
                    let target = count(y * w + x);
                    // The pixel's camera rays a packet at a time, each sample then traced on.
                    while px.taken < target {
                        let m = ((target - px.taken) as usize).min(MAX_PACKET);
                        let pixel = (y * w + x) as u32;
                        let jitter = !ctx.job.pixel_centers;
                        c.set(&ctx.job.view, seed, (x, y), pixel, px.taken, m, jitter);
                        c.trace(ctx.scene, ctx.job.view.position);
                        for i in 0..m {
                            let indirect = ind.as_deref_mut().map(|r| &mut r[x]);
                            let (r, d) = sampling.run(px, lights, indirect, c.samplers[i], c.dirs[i], c.hits[i]);
                            rays += r;
                            dropped += d;
                        }
                    }
                }
                Tally { rays, dropped, complete: true }
            };
        let rows = self.sums.par_chunks_mut(w).zip(self.light_sums.par_chunks_mut(w * nl.max(1))).enumerate();
        let results: Vec<Tally> = if self.indirect.is_empty() {
            rows.map(|(y, (row, light_row))| trace_row(y, row, light_row, None)).collect()
        } else {
            (rows.zip(self.indirect.par_chunks_mut(w)))
                .map(|((y, (row, light_row)), ind)| trace_row(y, row, light_row, Some(ind)))
                .collect()
        };
        Tally::settle(&results, ctx.stop, &mut self.rays, &mut self.dropped)
    }

    /// The slopes every pixel-light is filtered with: the mean of the analysis samples' slopes
    /// over its neighbourhood (Mehta 2012 Sec. 6's fill, the pixel's own included).
    fn update_slopes(&mut self, fill_radius: usize) {
        let Some(g) = self.gbuffer.as_ref() else { return };
        let sums = &self.light_sums;
        let own = |k: usize| sums[k].occ.get();
        let grid = FillGrid { width: self.width, height: self.height, lights: self.lights.len() };
        self.slopes = fill_slopes(grid, fill_radius, &|p| g.pixels[p].is_valid(), &own, false);
    }

    /// Builds the frame: filters each part and composes.
    fn compose(&self, ctx: &PassContext, shadow_widths: &[Vec<f32>]) -> Frame {
        let n = self.width * self.height;
        let nl = self.lights.len();
        let t = Instant::now();
        let widths = self.widths.as_ref().expect("set up in pass 0");
        let o = PackedOptions {
            beta: self.opts.beta as f32,
            sigma_z2_relative: self.opts.sigma_z2_relative as f32,
            max_radius: self.opts.max_radius,
            linear: false,
        };
        let mut width_px = vec![0.0f32; n];
        let mut components = Vec::new();
        let max_into = |acc: &mut [f32], w: &[f32]| acc.iter_mut().zip(w).for_each(|(a, b)| *a = a.max(*b));
        // What the parts below read of the pixels' sums.
        let diffuse_guides: Vec<PackedGuide> =
            (self.sums.par_iter().zip(&self.diffuse_guides)).map(|(s, g)| straddling_guide(g, s)).collect();
        let spp: Vec<f32> = self.sums.par_iter().map(|s| s.taken as f32).collect();
        let x_n: Vec<u32> = self.sums.par_iter().map(|s| s.x_n).collect();
        // Soft shadows: each light's visibility, filtered.
        let mut shadow_width = vec![0.0f32; n];
        let visibility: Vec<Vec<[f32; 3]>> = (0..nl)
            .map(|l| {
                let at = |p: usize| &self.light_sums[p * nl + l];
                let (mut vis, feeds): (Vec<[f32; 3]>, Vec<bool>) = (0..n)
                    .into_par_iter()
                    .map(|p| (ratio(at(p).a, at(p).b).map(|x| x as f32), at(p).b.iter().any(|&b| b > 0.0)))
                    .unzip();
                let sigma = &shadow_widths[l];
                gather_where(&diffuse_guides, &feeds, sigma, self.width, &mut vis, &o);
                max_into(&mut shadow_width, sigma);
                vis
            })
            .collect();
        tracing::trace!(seconds = t.elapsed().as_secs_f64(), "auto: visibility filtered");
        if nl > 0 {
            max_into(&mut width_px, &shadow_width);
            components.push(ComponentMaps {
                name: "shadow".to_string(),
                spp: spp.clone(),
                filter_width: Some(shadow_width),
            });
        }
        // Indirect light: each component's untextured light, filtered; the diffuse light also at
        // the narrow scale, once the samples can tell its bias (`scales.rs`).
        let parts: &[bool] = match (ctx.job.bounces > 0, self.glossy) {
            (false, _) => &[],
            (true, false) => &[false],
            (true, true) => &[false, true],
        };
        // The narrow scale starts at `narrow_from_spp`, and earlier at creases. Until some pixel
        // has the samples the earlier start asks for, no pixel is at either and the creases
        // are not needed (a short preview never finds them).
        let (from, crease_from) = (self.opts.narrow_from_spp, self.opts.narrow_crease_from_spp);
        let may_narrow = self.opts.narrow_scale > 0.0 && !parts.is_empty();
        let creases: &[bool] = if may_narrow && x_n.par_iter().any(|&x| x >= from.min(crease_from)) {
            self.creases.get_or_init(|| scales::creases(&self.diffuse_guides, self.width, 2))
        } else {
            &[]
        };
        let from_at = |p: usize| if creases.get(p) == Some(&true) { from.min(crease_from) } else { from };
        let two_scales = may_narrow && (x_n.par_iter().enumerate()).any(|(p, &x)| x >= from_at(p));
        let mut narrow_sigma = vec![0.0f32; n];
        let mut narrow_power = vec![1.0f32; n];
        let indirect: Vec<IndirectPart> = parts
            .iter()
            .map(|&glossy| {
                let at = |p: usize| self.indirect[p].component(glossy);
                let (mut light, (feeds, taken)): (Vec<_>, (Vec<_>, Vec<_>)) = (0..n)
                    .into_par_iter()
                    .map(|p| (mean(at(p).light, at(p).surface).map(|x| x as f32), (at(p).surface > 0, at(p).n)))
                    .unzip();
                let sigma = widths.indirect(ctx, glossy, &taken, &self.opts);
                let base = if glossy { &self.glossy_guides } else { &diffuse_guides };
                let narrow = (two_scales && !glossy).then(|| {
                    let scale = self.opts.narrow_scale as f32;
                    narrow_sigma.iter_mut().zip(&sigma).for_each(|(ns, s)| *ns = s * scale);
                    let mut narrow = light.clone();
                    let narrow_o = PackedOptions { linear: self.opts.narrow_linear, ..o };
                    narrow_power =
                        gather_with_power(base, Some(&feeds), &narrow_sigma, self.width, &mut narrow, &narrow_o);
                    narrow
                });
                gather_where(base, &feeds, &sigma, self.width, &mut light, &o);
                max_into(&mut width_px, &sigma);
                components.push(ComponentMaps {
                    name: if glossy { "glossy" } else { "diffuse" }.to_string(),
                    spp: taken.par_iter().map(|&n| n as f32).collect(),
                    filter_width: Some(sigma),
                });
                IndirectPart { glossy, light, narrow }
            })
            .collect();
        // Compose: rest + sum over lights of r times visibility + K filter(Lbar) + (P - K Lbar)
        // per indirect component (`aaf_indirect`: the correction makes the unfiltered limit
        // exactly the Monte Carlo mean where the reflectance varies over the pixel).
        tracing::trace!(seconds = t.elapsed().as_secs_f64(), "auto: indirect light filtered");
        let compose_at = |p: usize| {
            let s = &self.sums[p];
            let rest = mean(s.rest, s.taken);
            let (mut color, mut unfiltered) = (rest, rest);
            for (l, vis) in visibility.iter().enumerate() {
                let ls = &self.light_sums[p * nl + l];
                let (r, raw) = (mean(ls.r, ls.r_n), ratio(ls.a, ls.b));
                for c in 0..3 {
                    color[c] += r[c] * vis[p][c] as f64;
                    unfiltered[c] += r[c] * raw[c];
                }
            }
            let mut narrow = color;
            for IndirectPart { glossy, light, narrow: narrow_light } in &indirect {
                let cs = self.indirect[p].component(*glossy);
                let (k, raw, prod) = (mean(cs.reflectance, cs.n), mean(cs.light, cs.surface), mean(cs.product, cs.n));
                let narrow_light = narrow_light.as_ref().unwrap_or(light);
                for c in 0..3 {
                    color[c] += k[c] * light[p][c] as f64 + (prod[c] - k[c] * raw[c]);
                    narrow[c] += k[c] * narrow_light[p][c] as f64 + (prod[c] - k[c] * raw[c]);
                    unfiltered[c] += prod[c];
                }
            }
            Composed { wide: color, narrow, unfiltered }
        };
        // Where the filter's bias outgrows the noise it removes (`blend.rs`); before any pixel
        // has `blend_from_spp` samples every weight is 0 (the frame is the filtered value), and
        // neither the weights nor the (frame, unfiltered) pairs they read are kept: at preview
        // sizes a frame's fresh buffers cost page faults on the order of the arithmetic.
        let from = self.opts.blend_from_spp;
        let blending = from > 0 && x_n.par_iter().any(|&x| x >= from);
        let clamp = |v: [f64; 3]| v.map(|x| x.max(0.0) as f32);
        let (color, unfiltered): (Vec<[f32; 3]>, Vec<[f32; 3]>) = if !two_scales && !blending {
            (0..n).into_par_iter().map(compose_at).map(|c| (clamp(c.wide), clamp(c.unfiltered))).unzip()
        } else {
            let composed: Vec<([f64; 3], [f64; 3])> = if two_scales {
                let composed: Vec<Composed> = (0..n).into_par_iter().map(compose_at).collect();
                scales::select(self.width, &composed, &self.sums, &narrow_sigma, &narrow_power, &from_at)
            } else {
                collected((0..n).into_par_iter().map(compose_at).map(|c| (c.wide, c.unfiltered)))
            };
            let weights = blending.then(|| {
                let variance: Vec<f64> = (self.sums.par_iter())
                    .map(|s| if s.x_n >= from { s.mean_variance() } else { f64::INFINITY })
                    .collect();
                blend::pooled_weights(self.width, &composed, &variance)
            });
            let weight = |p: usize| weights.as_ref().map_or(0.0, |w| w[p]);
            (composed.par_iter().enumerate()).map(|(p, &(f, u))| (clamp(blend::mix(f, u, weight(p))), clamp(u))).unzip()
        };
        tracing::trace!(seconds = t.elapsed().as_secs_f64(), "auto: composed");
        Frame {
            shading: None,
            width: self.width as u32,
            height: self.height as u32,
            color,
            unfiltered: Some(unfiltered),
            aovs: None,
            stats: FrameStats {
                mean_spp: spp.iter().map(|&s| s as f64).sum::<f64>() / n.max(1) as f64,
                rays_traced: self.rays,
                dropped_samples: self.dropped,
                ..FrameStats::default()
            },
            spp,
            filter_width: Some(width_px),
            components,
        }
    }
}

/// A pixel's diffuse guide, turned to the mean of the normals its samples saw where its first
/// samples straddle an edge (`PixelSums::mixed`). The G-buffer's guide is its centre's face
/// alone, so such a pixel would gather from that face's side only and take its light for the
/// pixel's mix of both (a room's crease came out too bright); with the mean normal it gathers
/// mostly from the pixels along the edge, which straddle it alike, and the faces' pixels mostly
/// not from it.
fn straddling_guide(g: &PackedGuide, s: &PixelSums) -> PackedGuide {
    let n = s.seen_normals.normalize_or_zero();
    if s.mixed && g.is_valid() && n != glam::Vec3::ZERO {
        PackedGuide { axis: n.to_array(), ..*g }
    } else {
        *g
    }
}

/// One indirect component's untextured light, filtered at its width and (the diffuse light,
/// from `narrow_from_spp` on) at the narrow scale.
struct IndirectPart {
    glossy: bool,
    light: Vec<[f32; 3]>,
    narrow: Option<Vec<[f32; 3]>>,
}

/// Whether the pass from `before` to `target` samples per pixel sets the penumbra marks: the
/// first pass, the one that completes the `analysis_spp` analysis samples, and every one after.
/// In between (pass 1 of 1, 4, 16, ...) a slope fill and widths over the image would refine the
/// marks of one pass that the first pass's marks steer nearly as well, at a preview budget's
/// price (BENCHMARKS.md, "Denoising"). Frames composed there find the widths for themselves and
/// mark nothing, so the marks, and the final frame, do not depend on which frames were composed.
pub(super) fn refreshes_marks(before: u32, target: u32, analysis_spp: u32) -> bool {
    before == 0 || target >= analysis_spp
}

/// Samples per pixel after pass `pass`: `initial` in pass 0, four times as many per pass after
/// (1, 4, 16, 64, ...), at most `max_mean_spp` (0: no cap). Every frame a stream shows costs a
/// filter, so the passes grow faster than `uniform`'s doubling: fewer frames at a budget, the
/// same samples.
pub fn pass_target(initial: u32, pass: u32, max_mean_spp: f64) -> u32 {
    let total = (initial.max(1) as u64).saturating_mul(1u64 << (2 * pass.min(20)));
    let cap = if max_mean_spp > 0.0 { max_mean_spp.ceil().min(u32::MAX as f64) as u64 } else { u64::MAX };
    total.min(cap).min(u32::MAX as u64) as u32
}

impl Strategy for AutoStrategy {
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError> {
        if ctx.pass == 0 {
            self.setup(ctx);
        }
        let before = self.target;
        self.target = pass_target(ctx.job.initial_spp, ctx.pass, ctx.job.halt.max_mean_spp).max(before);
        let traced = Instant::now();
        let complete = self.trace(ctx, before, self.target)?;
        let t = Instant::now();
        tracing::debug!(pass = ctx.pass, spp = self.target, seconds = (t - traced).as_secs_f64(), "auto: traced");
        // The analysis samples just added move the slopes and reflector distances; reflector
        // distances set the indirect widths alone, which only a composed frame reads: they are
        // brought up to date when one is (`frame`), so that a render which composes its last
        // frame only (`--time`) finds them once, not after every pass.
        if before < self.opts.analysis_spp {
            self.slopes_stale = true;
            self.reflectors_stale = !self.indirect.is_empty();
        }
        let taken = self.taken();
        // The visibility widths: this pass's frame (if composed) filters with them, and the
        // next pass's penumbra marks read them (a pass the budget cut is the last: it marks
        // nothing). The passes between the first and the one that completes the analysis
        // samples leave the first pass's marks (`refreshes_marks`).
        self.shadow_widths_current = false;
        if refreshes_marks(before, self.target, self.opts.analysis_spp) {
            self.update_shadow_widths(ctx, &taken);
            if complete {
                self.mark_narrow_penumbrae();
            }
        }
        tracing::debug!(pass = ctx.pass, seconds = t.elapsed().as_secs_f64(), "auto: analysis");
        self.method_seconds += t.elapsed().as_secs_f64();
        let mean_spp = taken.iter().map(|&n| n as f32 as f64).sum::<f64>() / taken.len().max(1) as f64;
        Ok(Sampled { complete, mean_spp, rays_traced: self.rays, dropped_samples: self.dropped })
    }

    fn frame(&mut self, ctx: &PassContext) -> Result<Frame, RenderError> {
        let t = Instant::now();
        if std::mem::take(&mut self.reflectors_stale) {
            if let Some(w) = self.widths.as_mut() {
                w.update_reflectors(&self.indirect, &self.opts);
            }
            tracing::trace!(seconds = t.elapsed().as_secs_f64(), "auto: reflectors");
        }
        if !self.shadow_widths_current {
            let taken = self.taken();
            self.update_shadow_widths(ctx, &taken);
        }
        let mut frame = self.compose(ctx, &self.shadow_widths);
        tracing::debug!(pass = ctx.pass, seconds = t.elapsed().as_secs_f64(), "auto: filters");
        self.method_seconds += t.elapsed().as_secs_f64();
        frame.stats.method_seconds = self.method_seconds;
        Ok(frame)
    }
}
