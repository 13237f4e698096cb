//! The `bandwidth` strategy (Bagher et al. 2012 made progressive): pass 0 analyses every pixel
//! (`analysis`); each pass lowers the levels by `level_step`, shades the pixels the nested
//! grids ask for (`grid`) with `N_p` lookups per camera sample shared out by Eq. 8, traces
//! every pixel's camera samples (more where Eq. 9 gives an antialiasing level), and composes
//! `S_hat` with the shadows and the rest those samples traced (`sample`, `options::Visibility`).
//! Once every level reaches 0 every surface pixel is shaded at its own samples, so `S_hat` is
//! the pixel's own mean and the estimate is consistent: the render converges to the `uniform`
//! image.
use super::analysis::{analyse, coarsest_level, finest_level, Analysis};
use super::counts::Moments;
use super::grid::{grid_level, Upsampling};
use super::levels::pyramid;
use super::options::Visibility;
use super::sample::{sample_terms, shade, LookupStream, MAX_LOOKUPS};
use crate::methods::uniform::Uniform;
use crate::pipeline::allocation::{extra_rounds, extras_round, pooled_sigmas, rounds};
use crate::pipeline::film::{trace_bands, Tally};
use crate::pipeline::frame::{Frame, FrameStats, ShadingMaps};
use crate::pipeline::job::{Integrand, RenderError, RenderJob};
use crate::pipeline::strategy::{PassContext, Sampled, Strategy};
use crate::render::camera_samples::CameraSamples;
use crate::render::geometry::NONE;
use crate::render::integrator::{path_pairs, sample_from};
use crate::render::sampler::hash_words;
use crate::render::wide_bvh::MAX_PACKET;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Seed of the shading lookups' stream.
const STREAM: u64 = 0x7368_6164_6521;

/// A pixel's running sums (f64).
#[derive(Clone, Copy, Debug, Default)]
struct Accum {
    /// Samples that hit something other than the pixel's centre: the full estimate, which
    /// `S_hat` (the centre's shading) cannot stand for.
    whole: [f64; 3],
    n_whole: u32,
    /// Samples on the centre's object (or, at a background pixel, in the sky): their terms.
    rest: [f64; 3],
    shadowed: [f64; 3],
    unshadowed: [f64; 3],
    n_same: u32,
    /// The pixel's own shading, `S`, at its shaded samples.
    shaded: [f64; 3],
    n_shaded: u32,
    /// Samples drawn (the next sample's index).
    taken: u32,
    /// Luminance moments of the samples' terms, for the adaptive counts.
    moments: Moments,
}

impl Accum {
    /// The pixel's value given `S_hat` (None: no shading reached it yet).
    fn estimate(&self, s_hat: Option<&[f64; 3]>, visibility: Visibility) -> [f32; 3] {
        let n = self.n_whole + self.n_same;
        if n == 0 {
            return [0.0; 3];
        }
        let same = self.n_same as f64;
        let mut sum = [0.0f64; 3];
        for c in 0..3 {
            // What the samples on the centre's surface say its environment light is.
            let environment = match (s_hat, visibility) {
                (None, _) => self.shadowed[c],
                (Some(s), Visibility::ControlVariate) => same * s[c] + self.shadowed[c] - self.unshadowed[c],
                // With no unshadowed light to compare with, the samples' own sum stands.
                (Some(_), Visibility::Ratio) if self.unshadowed[c] <= 0.0 => self.shadowed[c],
                (Some(s), Visibility::Ratio) => same * s[c] * (self.shadowed[c] / self.unshadowed[c]),
            };
            sum[c] = self.whole[c] + self.rest[c] + environment;
        }
        // The control variate can go below 0 where a shadow's noise exceeds the light.
        sum.map(|v| (v / n as f64).max(0.0) as f32)
    }
}

fn add(sum: &mut [f64; 3], v: Vec3) {
    for c in 0..3 {
        sum[c] += v[c] as f64;
    }
}

/// What a pass does at one pixel.
#[derive(Clone, Copy, Debug, Default)]
struct PixelPlan {
    samples: u32,
    /// Lookups per shaded sample; 0: the pixel is not shaded this pass.
    lookups: u32,
}

pub struct BandwidthShading {
    width: u32,
    height: u32,
    seed: u64,
    /// Shading is possible (radiance and an environment light); otherwise every sample is a
    /// whole estimate and the method is the plain path tracer.
    shades: bool,
    analysis: Option<Analysis>,
    upsampling: Option<Upsampling>,
    pixels: Vec<Accum>,
    /// Camera samples per pixel asked for so far at antialiasing factor 1.
    base_spp: u64,
    rays: u64,
    dropped: u64,
    method_seconds: f64,
    /// Seconds of pass 0's analysis (the bandwidth prediction) and upsampling setup.
    analysis_seconds: f64,
    /// Each pixel's `S_hat` as the last pass left it: its frame and the next pass's counts
    /// read it.
    s_hat: Vec<Option<[f64; 3]>>,
    /// The last pass's levels, and its shaded and full-resolution camera samples (for its frame).
    levels: Option<Vec<i32>>,
    pass_points: (u64, u64),
}

impl BandwidthShading {
    pub fn new(job: &RenderJob) -> Self {
        let (width, height) = (job.width(), job.height());
        BandwidthShading {
            width,
            height,
            seed: job.seed,
            shades: job.integrand == Integrand::Radiance && job.scene.environment().is_some(),
            analysis: None,
            upsampling: None,
            pixels: vec![Accum::default(); width as usize * height as usize],
            base_spp: 0,
            rays: 0,
            dropped: 0,
            method_seconds: 0.0,
            analysis_seconds: 0.0,
            s_hat: Vec::new(),
            levels: None,
            pass_points: (0, 0),
        }
    }

    /// The levels of `pass`: Eq. 9's lowered by `level_step` per pass.
    fn pass_levels(analysis: &Analysis, pass: u32, step: u32) -> Vec<i32> {
        let lower = (pass as i64 * step as i64).min(64) as i32;
        analysis.level.iter().map(|&l| l.saturating_sub(lower)).collect()
    }

    /// Each pixel's samples and lookups this pass.
    fn plan(&self, ctx: &PassContext, levels: &[i32], k: u32) -> Vec<PixelPlan> {
        let opts = &ctx.job.bandwidth;
        let (Some(analysis), Some(up)) = (&self.analysis, &self.upsampling) else {
            return vec![PixelPlan { samples: k, lookups: 0 }; self.pixels.len()];
        };
        let g = ctx.gbuffer();
        let surface: Vec<bool> = g.pixels.iter().map(|p| p.is_valid() && !p.emitter).collect();
        let shaded = up.shaded(levels, &surface);
        // Eq. 8's bound, max-mipmapped: a shaded pixel stands for its block.
        let (w, h) = (self.width as usize, self.height as usize);
        let maxes = pyramid(&analysis.variance, w, h, f64::max);
        let coarsest = up.coarsest;
        let block_variance = |i: usize| {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let level = grid_level(x, y, coarsest) as usize;
            let (bw, _, ref v) = maxes[level];
            v[(y as usize >> level) * bw + (x as usize >> level)]
        };
        let variances: Vec<f64> =
            (0..w * h).into_par_iter().map(|i| if shaded[i] { block_variance(i) } else { 0.0 }).collect();
        let influence = if opts.lookups_by_influence {
            let has_value: Vec<bool> =
                shaded.par_iter().zip(&self.pixels).map(|(&s, px)| s || px.n_shaded > 0).collect();
            up.influence(&has_value)
        } else {
            vec![1.0; w * h]
        };
        let count = shaded.iter().filter(|&&s| s).count().max(1) as f64;
        let mean = variances.iter().filter(|v| v.is_finite()).sum::<f64>() / count;
        let max_lookups = opts.max_lookups.clamp(1, MAX_LOOKUPS);
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let level = analysis.level[i];
                let factor = if level < 0 { 1u32 << (2 * (-level).min(2)) } else { 1 };
                let lookups = if !shaded[i] {
                    0
                } else {
                    let share = if mean > 0.0 && variances[i].is_finite() {
                        opts.lookups_per_sample * variances[i] / mean
                    } else if mean > 0.0 {
                        max_lookups as f64
                    } else {
                        opts.lookups_per_sample
                    };
                    // Never below the mean: a shaded pixel's noise is every upsampled child's.
                    let share = share.max(opts.lookups_per_sample) * influence[i].sqrt();
                    (share.min(max_lookups as f64).round() as u32).clamp(1, max_lookups)
                };
                PixelPlan { samples: k.saturating_mul(factor), lookups }
            })
            .collect()
    }

    /// Traces every pixel p up to `upto(p)` samples, in parallel over bands of rows.
    fn trace(
        &mut self,
        ctx: &PassContext,
        plan: &[PixelPlan],
        upto: &(dyn Fn(usize) -> u32 + Sync),
    ) -> Result<Tally, RenderError> {
        let job = ctx.job;
        let scene = ctx.scene;
        let cam = ctx.view;
        let w = self.width as usize;
        let (seed, shades) = (self.seed, self.shades);
        let shade_seed = hash_words(&[seed, STREAM]);
        let env = scene.environment();
        let gbuffer = ctx.gbuffer.map(|g| g.as_ref());
        let pairs_ahead = path_pairs(scene, job.integrand, job.bounces);
        let scratch = || CameraSamples { pairs_ahead, ..CameraSamples::default() };
        trace_bands(&mut self.pixels, w, ctx.stop, scratch, |camera, x, y, px, t| {
            let i = y * w + x;
            let centre_object = gbuffer.map_or(NONE, |g| g.pixels[i].object);
            // The pixel's camera rays a packet at a time (`CameraSamples`), each sample then
            // traced on in order.
            let target = upto(i);
            while px.taken < target {
                let m = ((target - px.taken) as usize).min(MAX_PACKET);
                camera.set(cam, seed, (x, y), i as u32, px.taken, m, !job.pixel_centers);
                t.rays += camera.trace(scene, cam.position);
                for k in 0..m {
                    let index = px.taken;
                    px.taken += 1;
                    let (mut sampler, dir, hit) = (camera.samplers[k], camera.dirs[k], camera.hits[k]);
                    let (Some(env), true) = (env, shades) else {
                        let p = sample_from(scene, hit, -dir, job.integrand, job.bounces, &mut sampler);
                        t.rays += p.rays as u64;
                        if p.radiance.is_finite() {
                            add(&mut px.whole, p.radiance);
                            px.moments.add_whole(p.radiance.into());
                            px.n_whole += 1;
                        } else {
                            t.dropped += 1;
                        }
                        continue;
                    };
                    let terms = sample_terms(scene, env, hit.as_ref(), -dir, job.bounces, &mut sampler);
                    t.rays += terms.rays as u64;
                    let same = hit.as_ref().map_or(NONE, |s| s.object) == centre_object;
                    let shaded_value = match (&hit, same && plan[i].lookups > 0) {
                        (Some(s), true) => {
                            let stream = LookupStream { seed: shade_seed, pixel: i as u32, index };
                            Some(shade(scene, env, s, -dir, plan[i].lookups, stream))
                        }
                        _ => None,
                    };
                    let finite = terms.rest.is_finite()
                        && terms.shadowed.is_finite()
                        && terms.unshadowed.is_finite()
                        && shaded_value.is_none_or(|v| v.is_finite());
                    if !finite {
                        t.dropped += 1;
                        continue;
                    }
                    if !same {
                        add(&mut px.whole, terms.rest + terms.shadowed);
                        px.moments.add_whole((terms.rest + terms.shadowed).into());
                        px.n_whole += 1;
                        continue;
                    }
                    px.moments.add_terms(terms.rest.into(), terms.shadowed.into(), terms.unshadowed.into());
                    add(&mut px.rest, terms.rest);
                    add(&mut px.shadowed, terms.shadowed);
                    add(&mut px.unshadowed, terms.unshadowed);
                    px.n_same += 1;
                    if let Some(s) = shaded_value {
                        add(&mut px.shaded, s);
                        px.moments.add_shaded(s.into());
                        px.n_shaded += 1;
                    }
                }
            }
        })
    }

    /// Every pixel's `S_hat`, from its own shading or its parents' (None: none reached it yet).
    fn s_hat(&self, ctx: &PassContext) -> Vec<Option<[f64; 3]>> {
        match (&self.upsampling, ctx.gbuffer) {
            (Some(up), Some(g)) => {
                let own: Vec<Option<[f64; 3]>> = self
                    .pixels
                    .par_iter()
                    .zip(&g.pixels)
                    .map(|(px, p)| {
                        if !p.is_valid() || p.emitter {
                            // Nothing at the centre reflects the environment: S is 0 there.
                            Some([0.0; 3])
                        } else {
                            (px.n_shaded > 0).then(|| px.shaded.map(|v| v / px.n_shaded as f64))
                        }
                    })
                    .collect();
                up.resolve(&own)
            }
            _ => vec![None; self.pixels.len()],
        }
    }
}

impl BandwidthShading {
    /// The samples each pixel should have after a pass of mean `target` (`counts`), or None
    /// while they stay uniform: below `adaptive_from_spp`, with antialiasing levels, before
    /// every pixel has two samples, where no pixel varies, or with nothing to shade (then the
    /// method is the plain path tracer, `uniform` bit for bit).
    fn adaptive_counts(&self, ctx: &PassContext, target: u32) -> Option<Vec<u32>> {
        let opts = &ctx.job.bandwidth;
        let off = opts.adaptive_from_spp == 0 || target < opts.adaptive_from_spp || opts.antialiasing;
        if off || !self.shades || self.base_spp < 2 {
            return None;
        }
        let own: Vec<Option<f64>> = self
            .pixels
            .par_iter()
            .zip(&self.s_hat)
            .map(|(px, s)| {
                let s = s.map(|s| (s[0] + s[1] + s[2]) / 3.0);
                px.moments.sample_variance(px.n_whole + px.n_same, px.n_same, px.n_shaded, s, opts.visibility)
            })
            .collect();
        let sigma = pooled_sigmas(self.width as usize, &own, 1);
        let taken: Vec<u32> = self.pixels.par_iter().map(|p| p.taken).collect();
        opts.proportional().counts(&sigma, target, &taken)
    }

    /// Traces the pass: every pixel up to the pass's uniform share in sweeps over the image,
    /// then the adaptive extras in `EXTRA_ROUNDS` more, so that a pass the deadline cuts leaves the
    /// counts even (one sweep each without a deadline to cut the pass, `rounds`); without
    /// adaptive counts, every pixel its plan's samples in one sweep.
    fn trace_pass(
        &mut self,
        ctx: &PassContext,
        plan: &[PixelPlan],
        counts: Option<&[u32]>,
        target: u32,
    ) -> Result<Tally, RenderError> {
        let Some(counts) = counts else {
            let ends: Vec<u32> =
                self.pixels.par_iter().zip(plan).map(|(p, q)| p.taken.saturating_add(q.samples)).collect();
            return self.trace(ctx, plan, &|p| ends[p]);
        };
        let before = self.base_spp.min(u32::MAX as u64) as u32;
        let uniform = ctx.job.bandwidth.proportional().uniform_share(target);
        let can_cut = ctx.stop.can_cut();
        let mut total = Tally { complete: true, ..Tally::default() };
        let sweeps = rounds(before, uniform, can_cut)
            .into_iter()
            .map(|r| (r, 0))
            .chain(extra_rounds(can_cut).map(|k| (uniform, k)));
        for (round, k) in sweeps {
            let tally = if k == 0 {
                self.trace(ctx, plan, &|p| counts[p].min(round))?
            } else {
                self.trace(ctx, plan, &|p| extras_round(uniform, counts[p], k))?
            };
            total = Tally::total(&[total, tally]);
            if !total.complete {
                break;
            }
        }
        Ok(total)
    }
}

impl Strategy for BandwidthShading {
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError> {
        let job = ctx.job;
        let opts = &job.bandwidth;
        let start = Instant::now();
        if ctx.pass == 0 && self.shades {
            let g = ctx.gbuffer();
            self.analysis = Some(analyse(ctx.scene, ctx.view, g, opts, job.seed));
            let coarsest = coarsest_level(self.width, self.height);
            self.upsampling = Some(Upsampling::new(g, ctx.view, coarsest, &opts.upsample, opts.same_object));
            self.analysis_seconds = start.elapsed().as_secs_f64();
            tracing::debug!(seconds = self.analysis_seconds, "bandwidth: analysis and upsampling setup");
        }
        let k = Uniform::pass_spp(job.initial_spp, ctx.pass, self.base_spp, job.halt.max_mean_spp);
        let levels = self.analysis.as_ref().map(|a| Self::pass_levels(a, ctx.pass, opts.level_step));
        let mut plan = match &levels {
            Some(levels) => self.plan(ctx, levels, k),
            None => vec![PixelPlan { samples: k, lookups: 0 }; self.pixels.len()],
        };
        let target = (self.base_spp + k as u64).min(u32::MAX as u64) as u32;
        let counts = self.adaptive_counts(ctx, target);
        if let Some(counts) = &counts {
            for ((q, &c), px) in plan.iter_mut().zip(counts).zip(&self.pixels) {
                let samples = c.saturating_sub(px.taken);
                // Eq. 8 shares the pass's lookups per pixel: a pixel given more camera samples
                // than the mean spreads its lookups over them.
                if q.lookups > 0 && samples > k {
                    q.lookups = ((q.lookups as u64 * k as u64).div_ceil(samples as u64) as u32).max(1);
                }
                q.samples = samples;
            }
        }
        self.method_seconds += start.elapsed().as_secs_f64();
        let tally = self.trace_pass(ctx, &plan, counts.as_deref(), target)?;
        self.base_spp += k as u64;
        self.rays += tally.rays;
        self.dropped += tally.dropped;
        let start = Instant::now();
        // The next pass's counts read S_hat: resolved whether or not this pass's frame is.
        self.s_hat = self.s_hat(ctx);
        let analysed = self.analysis.is_some();
        self.pass_points = (
            if analysed { plan.iter().filter(|p| p.lookups > 0).map(|p| p.samples as u64).sum() } else { 0 },
            if analysed { plan.iter().map(|p| p.samples as u64).sum() } else { 0 },
        );
        self.levels = levels;
        self.method_seconds += start.elapsed().as_secs_f64();
        let n = self.pixels.len().max(1) as f64;
        let mean_spp = self.pixels.par_iter().map(|p| p.taken as f64).sum::<f64>() / n;
        Ok(Sampled { complete: tally.complete, mean_spp, rays_traced: self.rays, dropped_samples: self.dropped })
    }

    fn frame(&mut self, ctx: &PassContext) -> Result<Frame, RenderError> {
        let start = Instant::now();
        let visibility = ctx.job.bandwidth.visibility;
        let color =
            self.pixels.par_iter().zip(&self.s_hat).map(|(px, s)| px.estimate(s.as_ref(), visibility)).collect();
        let finest = finest_level(&ctx.job.bandwidth);
        let shading = self.analysis.as_ref().zip(self.levels.as_ref()).map(|(a, levels)| ShadingMaps {
            bandwidth: a.bandwidth.clone(),
            level: levels.iter().map(|&l| l.max(finest) as f32).collect(),
            analysis_seconds: self.analysis_seconds,
        });
        self.method_seconds += start.elapsed().as_secs_f64();
        let n = self.pixels.len().max(1) as f64;
        let (shaded_points, full_resolution_points) = self.pass_points;
        Ok(Frame {
            width: self.width,
            height: self.height,
            color,
            unfiltered: None,
            spp: self.pixels.par_iter().map(|p| (p.n_whole + p.n_same) as f32).collect(),
            filter_width: None,
            components: Vec::new(),
            aovs: None,
            shading,
            stats: FrameStats {
                mean_spp: self.pixels.par_iter().map(|p| p.taken as f64).sum::<f64>() / n,
                rays_traced: self.rays,
                dropped_samples: self.dropped,
                method_seconds: self.method_seconds,
                shaded_points,
                full_resolution_points,
                ..FrameStats::default()
            },
        })
    }
}
