//! Axis-aligned filtering of indirect light (Mehta, Wang, Ramamoorthi, Durand 2013) as a
//! progressive strategy, with the baselines of the soft-shadow paper's Fig. 6 as modes of the
//! same code, and the paper's ambient-occlusion extension (Sec. 6).
//!
//! The indirect light leaving a pixel is kd * D + ks * S (Sec. 5): D, the incident indirect
//! light under the cosine lobe (one cosine-sampled ray per sample: its radiance), and S, under
//! the glossy lobe (one lobe-sampled ray: radiance * lobe * cos / pdf), both without textures.
//! Each is averaged per pixel, filtered with its own width (Eqs. 15-16; 10-degree normal check,
//! world distances) and modulated by the pixel's kd or ks.
//!
//! Passes 0 and 1 trace 16 samples per pixel (Sec. 5's initial rays, drawn from the same
//! distribution as later ones and kept, so reusing them adds no bias): the first in pass 0, a
//! preview filtered with what that one sample found, the other 15 in pass 1. Their cosine rays
//! give z_min and z_max (hits only; z_min clamped to 2% of the scene's largest dimension), or
//! their glossy rays on surfaces without a diffuse part. Pass k >= 2 uses mu = mu0 * 2^(k-2)
//! and tops each pixel and component up to n(mu) of Eq. 21, clamped to [16, 100 mu].
//!
//! Departures from the paper, each for the same reason as in the soft-shadow strategy (the
//! stream converges to the same ground truth as `uniform`, antialiasing included):
//! - Every sample has its own jittered camera ray, so a pixel's kd varies over its samples.
//!   With K the mean of kd over the samples, Dbar the mean D over the samples that hit a
//!   reflecting surface and P the mean of kd * D, the output is K * filter(Dbar) + (P - K Dbar):
//!   the filter acts on untextured light as in the paper, and the correction, zero wherever kd
//!   is constant over the pixel, makes the unfiltered limit exactly the Monte Carlo mean P.
//! - Pixels whose initial rays all miss have no indirect light to filter (no environment
//!   light in wedge): they stay unfiltered, and their count grows as 16 mu / mu0 so that they
//!   converge too. Pixels with reflectors also never fall below that floor.
//! - The filter standard deviation can be scaled (`kernel_scale`): the authors' code used an
//!   effective beta / 4; the default is the paper's beta.
//!
//! The same sampling, demodulation and composition serve Tokuyoshi's methods (`lobe-aware`,
//! `normal-aware`: equal samples, his gather) as `FilterMode`s; `tokuyoshi.rs` holds their part
//! (methods.md §3.4).
pub mod options;
pub mod params;
pub(crate) mod tokuyoshi;

pub use options::IndirectOptions;

use super::lobe_aware::filter::Guide;
use super::lobe_aware::options::LobeAwareOptions;
use super::mode::FilterMode;
use crate::pipeline::film::{interleave_rank, mean, Tally};
use crate::pipeline::frame::{ComponentMaps, Frame, FrameStats};
use crate::pipeline::job::{CancelToken, Integrand, RenderError, RenderJob};
use crate::pipeline::strategy::{PassContext, Sampled, Strategy};
use crate::render::camera_samples::CameraSamples;
use crate::render::filter::{FilterKernel, FilterSurface};
use crate::render::frame_basis::{cosine_hemisphere, to_world};
use crate::render::gbuffer::GBuffer;
use crate::render::huge_pages::filled;
use crate::render::integrator::{direct_light, emitted, occlusion_ray, radiance_from, split_path_pairs, DirectLights};
use crate::render::material::{GlossyModel, Material};
use crate::render::sampler::{hash_words, PixelSampler};
use crate::render::scene::{Scene, Surface};
use crate::render::wide_bvh::MAX_PACKET;
use glam::Vec3;
use params::{clamp_samples, filter_width, gamma_glossy, omega_h_glossy, sample_count, Reflectors};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// The running sums of one component (diffuse or glossy) of one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ComponentSums {
    /// Camera samples that drew this component.
    pub(crate) n: u32,
    /// Of those, the ones that hit a surface reflecting this component (kd or ks non-zero).
    pub(crate) surface: u32,
    /// Sum of the untextured light (D or S) over the `surface` samples.
    pub(crate) light: [f64; 3],
    /// Sum of the reflectance (kd or ks; 0 where the sample hit nothing reflecting) over n.
    pub(crate) reflectance: [f64; 3],
    /// Sum of reflectance * light over n: the plain Monte Carlo estimate's numerator.
    pub(crate) product: [f64; 3],
}

impl ComponentSums {
    pub(crate) fn add(&mut self, reflectance: Vec3, light: Option<Vec3>) {
        self.n += 1;
        let Some(l) = light else { return };
        self.surface += 1;
        for c in 0..3 {
            self.light[c] += l[c] as f64;
            self.reflectance[c] += reflectance[c] as f64;
            self.product[c] += (reflectance[c] * l[c]) as f64;
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct PixelSums {
    /// Camera samples drawn: the divisor of `direct` and the next sample index.
    taken: u32,
    /// Emission and direct light of the samples (only when this strategy owns direct light).
    direct: [f64; 3],
    diffuse: ComponentSums,
    glossy: ComponentSums,
    /// Sums over every camera sample of the first hit's kd and ks (0 where it is back-facing
    /// or missed): the reflectance of a pixel whose light is upsampled (`Upsampling`).
    reflectance: [[f64; 3]; 2],
    /// Nearest and farthest reflector hit by the initial cosine rays (internal units).
    z_min: f32,
    z_max: f32,
}

impl Default for PixelSums {
    fn default() -> Self {
        PixelSums {
            taken: 0,
            direct: [0.0; 3],
            diffuse: ComponentSums::default(),
            glossy: ComponentSums::default(),
            reflectance: [[0.0; 3]; 2],
            z_min: f32::INFINITY,
            z_max: 0.0,
        }
    }
}

/// Which component a per-component computation is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Part {
    Diffuse,
    Glossy,
}

impl Part {
    fn of(self, p: &PixelSums) -> &ComponentSums {
        match self {
            Part::Diffuse => &p.diffuse,
            Part::Glossy => &p.glossy,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Part::Diffuse => "diffuse",
            Part::Glossy => "glossy",
        }
    }
}

pub struct IndirectStrategy {
    mode: FilterMode,
    opts: IndirectOptions,
    /// Whether emission and direct light at the first hit are this strategy's to add (false
    /// when the soft-shadow strategy runs beside it and owns them).
    owns_direct: bool,
    /// Whether any material has a glossy lobe: otherwise there is no glossy component.
    glossy: bool,
    width: usize,
    height: usize,
    /// The render's shared G-buffer (`PassContext::gbuffer`), from pass 0 on.
    gbuffer: Option<Arc<GBuffer>>,
    /// The filter's view of the G-buffer (world positions), built once per render; None for
    /// `adaptive`, which does not filter.
    surface: Option<FilterSurface>,
    sums: Vec<PixelSums>,
    /// Tokuyoshi's guides (lobes, depths, normals) per part, for the lobe- and normal-aware
    /// modes; built once per render.
    guides: Vec<Vec<Guide>>,
    lobe_opts: LobeAwareOptions,
    /// Tokuyoshi's joint upsampling while its passes last (None without it, and after the
    /// first complete pass that traces every pixel).
    upsampling: Option<tokuyoshi::Upsampling>,
    /// The last pass traced every pixel's indirect light completely: upsampling ends at the
    /// next pass (its frame still composed with it).
    upsampling_ended: bool,
    /// Projected pixel size per pixel.
    d: Vec<f64>,
    seed: u64,
    rays: u64,
    dropped: u64,
    method_seconds: f64,
}

/// Random stream of this strategy, apart from the soft-shadow strategy's (both start at
/// sample index 0 of the same pixels).
const STREAM: u64 = 0x696e_6469_7265_6374;

impl IndirectStrategy {
    pub fn new(job: &RenderJob, mode: FilterMode, owns_direct: bool) -> Self {
        let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
        let glossy = !ao && job.scene.glossy;
        IndirectStrategy {
            mode,
            opts: job.indirect.clone(),
            owns_direct: owns_direct && !ao,
            glossy,
            width: job.width() as usize,
            height: job.height() as usize,
            gbuffer: None,
            surface: None,
            sums: Vec::new(),
            guides: Vec::new(),
            lobe_opts: job.lobe,
            upsampling: None,
            upsampling_ended: false,
            d: Vec::new(),
            seed: hash_words(&[job.seed, STREAM]),
            rays: 0,
            dropped: 0,
            method_seconds: 0.0,
        }
    }

    fn parts(&self) -> &'static [Part] {
        if self.glossy {
            &[Part::Diffuse, Part::Glossy]
        } else {
            &[Part::Diffuse]
        }
    }

    /// mu of pass `pass`: passes 0 (the preview), 1 (the initial samples completed) and 2
    /// share mu0; pass k >= 2 uses mu0 * 2^(k-2).
    fn mu(&self, pass: u32) -> f64 {
        self.opts.mu0 * 2f64.powi(pass.saturating_sub(2).min(60) as i32)
    }

    fn setup(&mut self, ctx: &PassContext) {
        let g = Arc::clone(ctx.gbuffer());
        self.d = g.pixel_sizes(ctx.view.position, self.opts.foreshortening);
        self.sums = filled(self.width * self.height, PixelSums::default());
        // The surface is the filter's own work: it counts in the method's seconds.
        let t = Instant::now();
        if self.mode.tokuyoshi() {
            let kappa = self.lobe_opts.kappa(ctx.job.bounces);
            self.guides = self
                .parts()
                .iter()
                .map(|&part| tokuyoshi::guides(ctx, &g, part == Part::Glossy, &self.lobe_opts, kappa))
                .collect();
            if self.lobe_opts.upsample.factor > 1 {
                let u = tokuyoshi::Upsampling::new(ctx, &g, self.parts(), self.similarity(), &self.lobe_opts);
                tracing::debug!(factor = self.lobe_opts.upsample.factor, rerendered = u.rerendered, "upsampling");
                self.upsampling = Some(u);
            }
        }
        self.surface = (self.mode != FilterMode::Adaptive && !self.mode.tokuyoshi()).then(|| {
            FilterSurface::new(g.pixels.len(), self.width, &self.opts.filter, |p| {
                let s = &g.pixels[p];
                (s.position.as_dvec3(), s.normal, s.object)
            })
        });
        self.method_seconds += t.elapsed().as_secs_f64();
        self.gbuffer = Some(g);
    }

    /// The reflector distances and bandlimit of pixel `p` for `part`; None when its initial
    /// rays found no reflector (or it sees nothing): no filter, the floor count.
    fn reflectors(&self, scene: &Scene, p: usize, part: Part) -> Option<Reflectors> {
        let g = self.gbuffer.as_ref()?.pixels[p];
        let s = &self.sums[p];
        if !g.is_valid() || !s.z_min.is_finite() || !(self.d[p] > 0.0) {
            return None;
        }
        let c = &self.opts.constants;
        let z_min = (s.z_min as f64).max(c.z_min_fraction * scene.max_extent() as f64);
        let omega_h = match part {
            Part::Diffuse => c.omega_h_diffuse,
            Part::Glossy => omega_h_glossy(glossy_model(scene, g.material), g.exponent as f64, c),
        };
        Some(Reflectors { z_min, z_max: (s.z_max as f64).max(z_min), omega_h, d: self.d[p] })
    }

    /// Samples per pixel after pass `pass` when every pixel has the same: the preview's, then
    /// the initial samples, doubling from pass 2 on; Tokuyoshi's modes, which need no initial
    /// samples for an analysis, double from the preview on (1, 2, 4, ...), so that a pass the
    /// deadline cuts leaves no pixel with much fewer samples than its neighbours (their direct
    /// light is not filtered).
    fn uniform_count(&self, pass: u32) -> u32 {
        let initial = self.opts.initial_samples.max(1);
        let preview = self.opts.preview_samples.clamp(1, initial);
        if self.mode.tokuyoshi() {
            return preview.saturating_mul(1u32 << pass.min(20));
        }
        match pass {
            0 => preview,
            1 => initial,
            _ => initial.saturating_mul(1u32 << (pass - 1).min(20)),
        }
    }

    /// Samples each pixel should have of each component after pass `pass`: (diffuse, glossy).
    fn targets(&self, scene: &Scene, pass: u32) -> Vec<(u32, u32)> {
        let initial = self.opts.initial_samples.max(1);
        if pass <= 1 {
            let n = self.uniform_count(pass);
            return vec![(n, if self.glossy { n } else { 0 }); self.sums.len()];
        }
        let mu = self.mu(pass);
        let floor = (initial as f64 * (mu / self.opts.mu0).max(1.0)).ceil() as u32;
        let g = self.gbuffer.as_ref();
        (0..self.sums.len())
            .into_par_iter()
            .map(|p| {
                let s = &self.sums[p];
                let count = |part: Part| -> u32 {
                    let have = part.of(s).n;
                    if self.mode.uniform_samples() {
                        return self.uniform_count(pass).max(have);
                    }
                    let Some(r) = self.reflectors(scene, p, part) else { return floor.max(have) };
                    let c = &self.opts.constants;
                    let gamma = match part {
                        Part::Diffuse => c.gamma_diffuse,
                        Part::Glossy => gamma_glossy(g.map_or(0.0, |g| g.pixels[p].exponent as f64)),
                    };
                    let n = clamp_samples(sample_count(&r, c, mu, gamma), c, mu);
                    (n.ceil() as u32).max(floor).max(have)
                };
                let gp = g.map(|g| g.pixels[p]);
                let (has_kd, has_ks) = gp.map_or((false, false), |g| (g.kd != Vec3::ZERO, g.ks != Vec3::ZERO));
                let nd = count(Part::Diffuse);
                if !self.glossy {
                    return (nd, 0);
                }
                let ns = count(Part::Glossy);
                // A component the pixel centre does not reflect takes the other's count: its
                // samples then come with camera rays traced anyway (edges still get both).
                match (has_kd, has_ks) {
                    (true, false) => (nd, nd.max(s.glossy.n)),
                    (false, true) => (ns.max(s.diffuse.n), ns),
                    _ => (nd, ns),
                }
            })
            .collect()
    }

    /// While upsampling, keeps the indirect targets of the pixels that trace light and returns
    /// the camera samples every pixel takes (direct light only at the others); 0 otherwise.
    /// The first pass that reaches the full-resolution count traces every pixel; once one such
    /// pass is complete, upsampling ends for good (`sample`).
    fn upsample_targets(&self, pass: u32, targets: &mut [(u32, u32)]) -> u32 {
        let count = self.uniform_count(pass);
        let Some(u) = self.upsampling.as_ref().filter(|_| self.lobe_opts.upsample.active(count)) else { return 0 };
        for (t, &traced) in targets.iter_mut().zip(&u.traced) {
            if !traced {
                *t = (0, 0);
            }
        }
        count
    }

    /// Traces the samples each pixel still needs to reach `targets`, and at least `taken`
    /// camera samples per pixel.
    fn trace(
        &mut self,
        ctx: &PassContext,
        targets: &[(u32, u32)],
        taken: u32,
        record_z: bool,
    ) -> Result<bool, RenderError> {
        let (scene, job) = (ctx.scene, ctx.job);
        let w = self.width;
        let (seed, owns_direct) = (self.seed, self.owns_direct);
        let pairs_ahead = split_path_pairs(scene, job.bounces);
        // Rows in interleaved order: a pass the deadline cuts leaves its reached rows spread
        // out, and the counted gather fills the others from them.
        let mut rows: Vec<_> = self.sums.chunks_mut(w.max(1)).zip(targets.chunks(w.max(1))).enumerate().collect();
        rows.sort_by_key(|(y, _)| interleave_rank(*y));
        let results: Vec<Tally> = rows
            .into_par_iter()
            .map(|(y, (row, want_row))| {
                let (mut rays, mut dropped) = (0u64, 0u64);
                let mut camera = CameraSamples { pairs_ahead, ..CameraSamples::default() };
                for (x, (px, &(nd, ns))) in row.iter_mut().zip(want_row).enumerate() {
                    if ctx.stop.should_stop() {
                        return Tally { rays, dropped, complete: false };
                    }
                    // With pixel centres, the pass's samples share one camera ray.
                    let more = |px: &PixelSums| px.taken < taken || px.diffuse.n < nd || px.glossy.n < ns;
                    let centre = (job.pixel_centers && more(px)).then(|| {
                        rays += 1;
                        let dir = job.view.direction(x as f32 + 0.5, y as f32 + 0.5);
                        (dir, scene.intersect(job.view.position, dir, 0.0))
                    });
                    let pixel = (y * w + x) as u32;
                    if centre.is_some() {
                        while more(px) {
                            let mut sampler = PixelSampler::new(seed, pixel, px.taken);
                            px.taken += 1;
                            let want = (px.diffuse.n < nd, px.glossy.n < ns);
                            let s = Sample { scene, job, owns_direct, record_z, want, centre, own: None };
                            let (r, d) = s.run(x, y, &mut sampler, px);
                            rays += r;
                            dropped += d;
                        }
                        continue;
                    }
                    // The camera rays a packet at a time: as many as the pixel surely takes
                    // (each sample adds at most one to each count), then again while it wants more.
                    while more(px) {
                        let surely = (taken.saturating_sub(px.taken))
                            .max(nd.saturating_sub(px.diffuse.n))
                            .max(ns.saturating_sub(px.glossy.n));
                        let m = (surely as usize).clamp(1, MAX_PACKET);
                        camera.set(&job.view, seed, (x, y), pixel, px.taken, m, true);
                        camera.trace(scene, job.view.position);
                        for k in 0..m {
                            px.taken += 1;
                            let want = (px.diffuse.n < nd, px.glossy.n < ns);
                            let own = Some((camera.dirs[k], camera.hits[k]));
                            let s = Sample { scene, job, owns_direct, record_z, want, centre: None, own };
                            let (r, d) = s.run(x, y, &mut camera.samplers[k], px);
                            rays += r;
                            dropped += d;
                        }
                    }
                }
                Tally { rays, dropped, complete: true }
            })
            .collect();
        Tally::settle(&results, ctx.stop, &mut self.rays, &mut self.dropped)
    }

    /// Builds the frame of pass `pass`: filters each component and composes. Every per-pixel
    /// loop runs in parallel: at 640x480 the serial ones cost as much as a filter pass. A
    /// cancelled render ends with `RenderError::Cancelled` after a part's filter, and inside
    /// the lobe-aware gathers (`filter_counted_until`).
    fn compose(&self, scene: &Scene, pass: u32, cancel: &CancelToken) -> Result<Frame, RenderError> {
        let n = self.width * self.height;
        let mut color: Vec<[f64; 3]> = self.sums.par_iter().map(|s| mean(s.direct, s.taken)).collect();
        let mut unfiltered = color.clone();
        let mut width_px = vec![0.0f32; n];
        let mut components = Vec::new();
        let filters = self.mode != FilterMode::Adaptive;
        let g = self.gbuffer.as_ref();
        for &part in self.parts() {
            let at = |p: usize| part.of(&self.sums[p]);
            let light_mean = |p: usize| mean(at(p).light, at(p).surface);
            let mut light: Vec<[f64; 3]> = (0..n).into_par_iter().map(light_mean).collect();
            let mut part_width = vec![0.0f32; n];
            // AAF's per-pixel widths, for the modes that use them.
            let kernels: Option<Vec<FilterKernel>> = matches!(self.mode, FilterMode::Aaf | FilterMode::UniformFiltered)
                .then(|| {
                    let mu = self.mu(pass);
                    (0..n)
                        .into_par_iter()
                        .map(|p| {
                            let valid = g.is_some_and(|g| g.pixels[p].is_valid()) && at(p).surface > 0;
                            let beta = if !valid {
                                0.0
                            } else if self.mode == FilterMode::UniformFiltered || pass == 0 {
                                // The preview's reflector distances come from the one sample it
                                // filters: widths that follow each pixel's own sample would weight
                                // the samples by their values (a short ray, a narrow kernel), which
                                // biases the mean. Its fixed width depends on geometry alone.
                                self.opts.fixed_filter_px * self.d[p]
                            } else {
                                self.reflectors(scene, p, part).map_or(0.0, |r| {
                                    filter_width(&r, &self.opts.constants, mu) * self.opts.kernel_scale
                                })
                            };
                            FilterKernel { valid, beta, d: self.d[p] }
                        })
                        .collect()
                });
            // While upsampling: the unfiltered light, upsampled where the light was (only the
            // upsampled pixels' entries change, and only they read it).
            let mut raw_light = if self.upsampling.is_some() { light.clone() } else { Vec::new() };
            // A pixel without samples of the part is upsampled (only while upsampling).
            let traced = |p: usize| self.upsampling.is_none() || at(p).n > 0;
            if self.mode.tokuyoshi() {
                let initial = self.opts.initial_samples.max(1) as f64;
                let o = &self.lobe_opts;
                // An upsampled pixel's kernel is that of its sites, which have its samples.
                let n = |p: usize| if traced(p) { at(p).n } else { self.sums[p].taken };
                let sigma = |p: usize| o.sigma_px(n(p) as f64, initial);
                self.filter_tokuyoshi(part, sigma, &mut light, &mut raw_light, &mut part_width, &mut width_px, cancel);
            } else if let (Some(surface), Some(kernels)) = (&self.surface, &kernels) {
                part_width.par_iter_mut().zip(width_px.par_iter_mut()).zip(kernels).for_each(|((pw, wp), k)| {
                    if k.beta > 0.0 && k.d > 0.0 {
                        *pw = (k.beta / k.d) as f32;
                        *wp = wp.max(*pw);
                    }
                });
                surface.filter(kernels, &mut light);
            }
            if cancel.is_cancelled() {
                return Err(RenderError::Cancelled);
            }
            let which = if part == Part::Glossy { 1 } else { 0 };
            color.par_iter_mut().zip(unfiltered.par_iter_mut()).enumerate().for_each(|(p, (color, unfiltered))| {
                if !traced(p) {
                    // Upsampled: the light of the sites times the pixel's own reflectance.
                    let k = mean(self.sums[p].reflectance[which], self.sums[p].taken);
                    for c in 0..3 {
                        color[c] += k[c] * light[p][c];
                        unfiltered[c] += k[c] * raw_light[p][c];
                    }
                    return;
                }
                let s = at(p);
                let (k, raw, prod) = (mean(s.reflectance, s.n), light_mean(p), mean(s.product, s.n));
                for c in 0..3 {
                    // K filter(Dbar) + (P - K Dbar): see the module comment.
                    color[c] += k[c] * light[p][c] + (prod[c] - k[c] * raw[c]);
                    unfiltered[c] += prod[c];
                }
            });
            components.push(ComponentMaps {
                name: part.name().to_string(),
                spp: (0..n).into_par_iter().map(|p| at(p).n as f32).collect(),
                filter_width: filters.then_some(part_width),
            });
        }
        let spp: Vec<f32> = self.sums.par_iter().map(|s| s.taken as f32).collect();
        let to_f32 = |v: Vec<[f64; 3]>| v.into_par_iter().map(|c| c.map(|x| x.max(0.0) as f32)).collect::<Vec<_>>();
        Ok(Frame {
            shading: None,
            width: self.width as u32,
            height: self.height as u32,
            color: to_f32(color),
            unfiltered: filters.then(|| to_f32(unfiltered)),
            aovs: None,
            stats: FrameStats {
                mean_spp: spp.iter().map(|&s| s as f64).sum::<f64>() / n.max(1) as f64,
                rays_traced: self.rays,
                dropped_samples: self.dropped,
                method_seconds: self.method_seconds,
                ..FrameStats::default()
            },
            spp,
            filter_width: filters.then_some(width_px),
            components,
        })
    }
}

impl Strategy for IndirectStrategy {
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError> {
        if ctx.pass == 0 {
            self.setup(ctx);
        }
        if self.upsampling_ended {
            // The last pass's frame still upsampled; from this pass on nothing is.
            self.upsampling = None;
        }
        let t = Instant::now();
        let mut targets = self.targets(ctx.scene, ctx.pass);
        let taken = self.upsample_targets(ctx.pass, &mut targets);
        self.method_seconds += t.elapsed().as_secs_f64();
        // The initial samples (the preview's and pass 1's) record the reflector distances.
        let complete = self.trace(ctx, &targets, taken, ctx.pass <= 1)?;
        // Every pixel has its own indirect samples now: nothing is upsampled again.
        self.upsampling_ended = complete && taken == 0;
        let n = self.sums.len().max(1) as f64;
        let mean_spp = self.sums.iter().map(|s| s.taken as f32 as f64).sum::<f64>() / n;
        Ok(Sampled { complete, mean_spp, rays_traced: self.rays, dropped_samples: self.dropped })
    }

    fn frame(&mut self, ctx: &PassContext) -> Result<Frame, RenderError> {
        let t = Instant::now();
        let frame = self.compose(ctx.scene, ctx.pass, &ctx.stop.cancel);
        self.method_seconds += t.elapsed().as_secs_f64();
        let mut frame = frame?;
        frame.stats.method_seconds = self.method_seconds;
        Ok(frame)
    }
}

pub(crate) fn glossy_model(scene: &Scene, material: u32) -> GlossyModel {
    match scene.materials.get(material as usize) {
        Some(Material::Glossy { model, .. }) => *model,
        _ => GlossyModel::BlinnPhong,
    }
}

/// One camera sample of one pixel.
struct Sample<'a> {
    scene: &'a Scene,
    job: &'a RenderJob,
    owns_direct: bool,
    /// Record the cosine rays' hit distances (passes 0 and 1).
    record_z: bool,
    /// Whether the diffuse and the glossy component take this sample.
    want: (bool, bool),
    /// The pixel's centre ray and its hit, when shading pixel centres.
    centre: Option<(Vec3, Option<Surface>)>,
    /// Else the sample's own camera ray and its hit, traced with the pixel's others
    /// (`CameraSamples`, whose sampler has drawn the jitter pair); None: trace it here.
    own: Option<(Vec3, Option<Surface>)>,
}

impl Sample<'_> {
    /// Traces the sample into `px`. Returns (rays, dropped).
    fn run(&self, x: usize, y: usize, sampler: &mut PixelSampler, px: &mut PixelSums) -> (u64, u64) {
        let (scene, cam) = (self.scene, &self.job.view);
        if let Some((dir, hit)) = self.own {
            return self.run_from(dir, hit, 1, sampler, px);
        }
        let j = sampler.next_2d();
        let (dir, hit, rays) = match self.centre {
            Some((dir, hit)) => (dir, hit, 0u64),
            None => {
                let dir = cam.direction(x as f32 + j[0], y as f32 + j[1]);
                (dir, scene.intersect(cam.position, dir, 0.0), 1u64)
            }
        };
        self.run_from(dir, hit, rays, sampler, px)
    }

    /// `run` from the sample's camera ray `dir`, its hit, and the rays traced for it.
    fn run_from(
        &self,
        dir: Vec3,
        hit: Option<Surface>,
        camera_rays: u64,
        sampler: &mut PixelSampler,
        px: &mut PixelSums,
    ) -> (u64, u64) {
        let scene = self.scene;
        let mut rays = camera_rays;
        let mut dropped = 0u64;
        let Some(hit) = hit else {
            self.record(px, Vec3::ZERO, None, Vec3::ZERO, None);
            // The background belongs with emission: to whichever part owns direct light.
            if self.owns_direct {
                let background = scene.background(dir);
                for c in 0..3 {
                    px.direct[c] += background[c] as f64;
                }
            }
            return (rays, 0);
        };
        let wo = -dir;
        // Fixed dimensions first (stratified over the pixel's samples): diffuse, glossy.
        let (u_d, u_s) = (sampler.next_2d(), sampler.next_2d());
        if let Integrand::AmbientOcclusion { max_distance } = self.job.integrand {
            let (z, r) = occlusion_ray(scene, &hit, u_d, max_distance);
            rays += r as u64;
            if self.record_z {
                record_reflector(px, z.filter(|&t| t > 0.0));
            }
            self.record(px, Vec3::ONE, Some(Vec3::splat(if z.is_some() { 0.0 } else { 1.0 })), Vec3::ZERO, None);
            return (rays, 0);
        }
        if self.owns_direct {
            let (l, r) = direct_light(scene, &hit, wo, sampler);
            rays += r as u64;
            let v = l + emitted(scene, &hit, wo);
            if v.is_finite() {
                for c in 0..3 {
                    px.direct[c] += v[c] as f64;
                }
            } else {
                dropped += 1;
            }
        }
        let brdf = scene.materials[hit.material as usize].brdf(hit.uv);
        let front = hit.ns.dot(wo) > 0.0;
        if front {
            for c in 0..3 {
                px.reflectance[0][c] += brdf.kd[c] as f64;
                px.reflectance[1][c] += brdf.ks[c] as f64;
            }
        }
        let mut diffuse = None;
        if self.want.0 && brdf.kd != Vec3::ZERO && front {
            let wi = to_world(hit.ns, cosine_hemisphere(u_d));
            let (l, z, r) = self.incident(&hit, wi, sampler);
            rays += r;
            if self.record_z {
                record_reflector(px, z);
            }
            // kd/pi * L * cos / (cos/pi) = kd * L: D is L itself.
            diffuse = finite_or_drop(l, &mut dropped);
        }
        let mut glossy = None;
        if self.want.1 && brdf.ks != Vec3::ZERO && front {
            let l = match brdf.sample_specular(wo, hit.ns, u_s) {
                Some((wi, weight)) => {
                    let (l, z, r) = self.incident(&hit, wi, sampler);
                    rays += r;
                    // A surface without a diffuse part traces no cosine rays: its reflector
                    // distances come from the glossy ones.
                    if self.record_z && brdf.kd == Vec3::ZERO {
                        record_reflector(px, z);
                    }
                    l * weight
                }
                None => Vec3::ZERO,
            };
            glossy = finite_or_drop(l, &mut dropped);
        }
        self.record(px, brdf.kd, diffuse, brdf.ks, glossy);
        (rays, dropped)
    }

    /// Adds the sample's diffuse and glossy values (None: nothing reflected) to the components
    /// that take it.
    fn record(&self, px: &mut PixelSums, kd: Vec3, d: Option<Vec3>, ks: Vec3, s: Option<Vec3>) {
        if self.want.0 {
            px.diffuse.add(kd, d);
        }
        if self.want.1 {
            px.glossy.add(ks, s);
        }
    }

    fn incident(&self, hit: &Surface, wi: Vec3, sampler: &mut PixelSampler) -> (Vec3, Option<f32>, u64) {
        incident(self.scene, self.job.bounces, hit, wi, sampler)
    }
}

/// Radiance arriving at `hit` from direction `wi` over a path of `bounces` indirect bounces in
/// all (indirect only: a ray that reaches a light's surface brings nothing, direct light being
/// estimated apart), the reflector distance, and the rays traced.
pub(crate) fn incident(
    scene: &Scene,
    bounces: u32,
    hit: &Surface,
    wi: Vec3,
    sampler: &mut PixelSampler,
) -> (Vec3, Option<f32>, u64) {
    if hit.ng.dot(wi) <= 0.0 {
        return (Vec3::ZERO, None, 0);
    }
    let Some(next) = scene.intersect(hit.spawn_origin(), wi, 0.0) else { return (Vec3::ZERO, None, 1) };
    if matches!(scene.materials[next.material as usize], Material::Emitter { .. }) {
        return (Vec3::ZERO, Some(next.t), 1);
    }
    let r = radiance_from(scene, next, -wi, bounces.saturating_sub(1), sampler, DirectLights::All);
    (r.radiance, Some(next.t), 1 + r.rays as u64)
}

fn record_reflector(px: &mut PixelSums, z: Option<f32>) {
    if let Some(t) = z {
        px.z_min = px.z_min.min(t);
        px.z_max = px.z_max.max(t);
    }
}

fn finite_or_drop(v: Vec3, dropped: &mut u64) -> Option<Vec3> {
    if v.is_finite() {
        Some(v)
    } else {
        *dropped += 1;
        None
    }
}

#[cfg(test)]
mod tests;
