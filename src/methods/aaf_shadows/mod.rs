//! Axis-aligned filtering of area-light soft shadows (Mehta, Wang, Ramamoorthi 2012) as a
//! progressive strategy, with the baselines of the paper's Fig. 6 as modes of the same code.
//!
//! Eq. 1 splits the diffuse direct light of a rectangular light as h(x) = r(x) * visibility.
//! Per pixel and light, every sample (a jittered camera ray, as in `uniform`, and a stratified
//! point on the light) adds:
//! - to R, the unshadowed diffuse light kd/pi L E(x) at the sample's hit, with E the light's
//!   irradiance computed deterministically (`RectLight::unshadowed_irradiance`): r = R/n has
//!   no light-sampling noise; textures live here, antialiased by the jitter;
//! - to A = sum u V and B = sum u, with u the diffuse integrand kd/pi Le G / pdf and V the
//!   visibility: h = A/B is the noisy visibility weighted by the light (Eq. 10), the only
//!   thing filtered (Eqs. 11-13).
//!
//! The output r * filtered h tends to r * A/B once the filter shrinks below a pixel, a ratio
//! estimator that converges with n to the same ground truth as `uniform` (the paper's
//! consistency, Sec. 5.2). Departures from the paper: r is exact at each sample rather than
//! the irradiance from the light's centre, and the visibility weights include the cosine and
//! distance terms (the paper's "cosine falloff folded into l(y)", Sec. 3 and 7). Jittered
//! samples also need antialiasing, which Eq. 21 knows nothing of: a pixel whose r(x) (or
//! other light, such as an emitter's edge) spreads over its samples gets the samples that make
//! that spread's standard error small (`AafOptions::antialias_error`), and only those samples
//! compute r, an average that more samples would barely refine (`Target`). The glossy
//! part of area lights' direct light is added unfiltered, as the paper assumes a separate
//! specular pass; so are point lights and emission. Indirect light is not this strategy's: the
//! indirect strategy adds it (`strategy::make_strategy`).
pub mod options;
pub mod params;

pub use options::{AafOptions, LightSigma};

use super::mode::FilterMode;
use crate::pipeline::film::{mean, Tally};
use crate::pipeline::frame::{ComponentMaps, Frame, FrameStats};
use crate::pipeline::job::{RenderError, RenderJob};
use crate::pipeline::strategy::{PassContext, Sampled, Strategy};
use crate::render::camera::Camera;
use crate::render::camera_samples::CameraSamples;
use crate::render::filter::{FilterKernel, FilterOptions, FilterSurface};
use crate::render::gbuffer::GBuffer;
use crate::render::huge_pages::filled;
use crate::render::integrator::{emitted, path_pairs, radiance_from, DirectLights, Integrand, PathResult};
use crate::render::light::{EmissionProfile, Light, RectLight};
use crate::render::material::Material;
use crate::render::mis::{light_terms, shadowed_lobe_term};
use crate::render::sampler::PixelSampler;
use crate::render::scene::Scene;
use crate::render::scene::Surface;
use crate::render::wide_bvh::MAX_PACKET;
use glam::{DVec3, Vec3};
use params::{filter_width, sample_count, slope, PixelGeometry};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// One rectangular light as the strategy (and `auto`'s shadow part) sees it.
pub(crate) struct ShadowLight {
    /// Index in `scene.lights`.
    pub(crate) index: usize,
    corner: Vec3,
    axis_u: Vec3,
    axis_v: Vec3,
    /// The light's standard deviation sigma of Eqs. 13 and 21.
    pub(crate) sigma: f64,
    /// mu's factor for this light's profile (uniform lights: `uniform_light_mu_scale`).
    pub(crate) mu_scale: f64,
}

/// Running sums of one pixel for one light.
#[derive(Clone, Copy, Debug)]
struct LightSums {
    a: [f64; 3],
    b: [f64; 3],
    /// Sum of the exact unshadowed diffuse light r.
    r: [f64; 3],
    /// Sum of the squared channel mean of r (its spread over the pixel: antialiasing).
    r2: f64,
    /// Samples that computed r: the first `r_n` of the `n`. r is exact at each sample, so
    /// only antialiasing asks for many of them (see `Target`).
    r_n: u32,
    /// Sum of the glossy direct light (sampled, shadowed, unfiltered).
    spec: [f64; 3],
    n: u32,
    /// Slopes from the sparse pass.
    occ: OccluderRange,
}

impl Default for LightSums {
    fn default() -> Self {
        LightSums {
            a: [0.0; 3],
            b: [0.0; 3],
            r: [0.0; 3],
            r2: 0.0,
            r_n: 0,
            spec: [0.0; 3],
            n: 0,
            occ: OccluderRange::NONE,
        }
    }
}

/// Everything else a pixel's samples carry (emission, point lights, indirect light).
#[derive(Clone, Copy, Debug, Default)]
struct OtherSums {
    sum: [f64; 3],
    /// Sum of the squared channel mean of each sample.
    sum2: f64,
    /// Camera samples drawn: the divisor of `sum` and the next sample index.
    taken: u32,
}

/// What a pixel-light should have after a pass: `n` samples in all (Eq. 21 and the floors), of
/// which the first `r` also compute the exact unshadowed light r(x). Past the antialiasing
/// count, more r values only refine an average that is already good enough, and each one
/// costs more than a shadow ray (an 8x8 quadrature for Gaussian lights).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Target {
    n: u32,
    r: u32,
}

/// A pixel-light's slopes s1 >= s2, if it has any, in f32: the fill writes one per pixel and
/// light, and f32's 7 digits are far finer than the slopes' own accuracy (9 rays).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Slopes {
    /// NaN when there are none.
    s1: f32,
    s2: f32,
}

impl Slopes {
    pub(crate) const NONE: Slopes = Slopes { s1: f32::NAN, s2: f32::NAN };

    fn new(s1: f64, s2: f64) -> Self {
        Slopes { s1: s1 as f32, s2: s2 as f32 }
    }

    pub(crate) fn get(self) -> Option<(f64, f64)> {
        (!self.s1.is_nan()).then_some((self.s1 as f64, self.s2 as f64))
    }
}

/// Slopes no larger than this keep averages and products finite (s -> inf means an occluder
/// at the light, where every formula has already saturated).
pub(crate) const MAX_SLOPE: f64 = 1e9;

pub struct ShadowStrategy {
    mode: FilterMode,
    opts: AafOptions,
    width: usize,
    height: usize,
    lights: Vec<ShadowLight>,
    /// The render's shared G-buffer (`PassContext::gbuffer`), from pass 0 on.
    gbuffer: Option<Arc<GBuffer>>,
    /// Per light, the filter's view of the G-buffer (positions in the light's plane, Eq. 12),
    /// built once per render; empty for `adaptive`, which does not filter.
    surfaces: Vec<FilterSurface>,
    /// Pixel-major: sums[pixel * lights + l].
    sums: Vec<LightSums>,
    other: Vec<OtherSums>,
    /// Slopes each pixel-light is filtered and sampled with (own or filled in), if any.
    slopes: Vec<Slopes>,
    /// Projected pixel size per pixel.
    d: Vec<f64>,
    rays: u64,
    dropped: u64,
    method_seconds: f64,
    /// Every camera sample at its pixel's centre (`RenderJob::pixel_centers`).
    pixel_centers: bool,
}

impl ShadowStrategy {
    pub fn new(job: &RenderJob, mode: FilterMode) -> Self {
        let lights = job
            .scene
            .lights
            .iter()
            .enumerate()
            .filter_map(|(index, l)| match l {
                Light::Rect(r) => Some(shadow_light(index, r, &job.aaf)),
                Light::Point(_) | Light::Environment(_) => None,
            })
            .collect();
        let (w, h) = (job.width() as usize, job.height() as usize);
        ShadowStrategy {
            mode,
            opts: job.aaf.clone(),
            width: w,
            height: h,
            lights,
            gbuffer: None,
            surfaces: Vec::new(),
            sums: Vec::new(),
            other: Vec::new(),
            slopes: Vec::new(),
            d: Vec::new(),
            rays: 0,
            dropped: 0,
            method_seconds: 0.0,
            pixel_centers: job.pixel_centers,
        }
    }

    /// mu of pass `pass` (before a light's own scale).
    /// Passes 0 (the preview) and 1 (the sparse samples completed) filter at `first_mu`; pass
    /// k >= 2 at mu0 * 2^(k-2).
    fn mu(&self, pass: u32) -> f64 {
        if pass <= 1 {
            return self.opts.first_mu;
        }
        self.opts.mu0 * 2f64.powi(pass.saturating_sub(2).min(60) as i32)
    }

    fn setup(&mut self, ctx: &PassContext) {
        let g = Arc::clone(ctx.gbuffer());
        self.d = g.pixel_sizes(ctx.view.position, self.opts.foreshortening);
        let n = self.width * self.height;
        self.sums = filled(n * self.lights.len(), LightSums::default());
        self.other = filled(n, OtherSums::default());
        self.slopes = filled(n * self.lights.len(), Slopes::NONE);
        // The surfaces are the filter's own work: they count in the method's seconds.
        let t = Instant::now();
        if self.mode != FilterMode::Adaptive {
            self.surfaces =
                self.lights.iter().map(|light| light_plane_surface(&g, light, self.width, &self.opts.filter)).collect();
        }
        self.method_seconds += t.elapsed().as_secs_f64();
        self.gbuffer = Some(g);
    }

    /// The fewest samples a pixel-light has after pass `pass`, whatever Eq. 21 says. The paper
    /// leaves pixels outside every penumbra at the 9 sparse samples; a floor that grows with
    /// mu is what makes every pixel converge. Jittered camera samples also antialias r(x)
    /// (edges, textures), which needs a count growing like mu / mu0 (9, 18, 36, ...); at
    /// pixel centres only an undetected penumbra can be wrong, and the floor grows as its
    /// square root (9, 13, 18, ...).
    fn floor(&self, pass: u32) -> u32 {
        let growth = (self.mu(pass) / self.opts.mu0).max(1.0);
        let growth = if self.pixel_centers { growth.sqrt() } else { growth };
        (self.opts.sparse_samples.max(1) as f64 * growth).ceil() as u32
    }

    /// The largest variance of a pixel's mean that antialiasing accepts after pass `pass`:
    /// (antialias_error * mu0 / mu * the image's mean value)^2. None at pixel centres (nothing
    /// to antialias) or when turned off.
    fn antialias_target(&self, pass: u32) -> Option<f64> {
        if self.pixel_centers || !(self.opts.antialias_error > 0.0) {
            return None;
        }
        let nl = self.lights.len();
        let level = self
            .other
            .par_iter()
            .enumerate()
            .map(|(p, o)| {
                let rect: f64 =
                    (0..nl).map(|l| channel_mean(mean(self.sums[p * nl + l].r, self.sums[p * nl + l].r_n))).sum();
                rect + channel_mean(mean(o.sum, o.taken))
            })
            .sum::<f64>()
            / self.other.len().max(1) as f64;
        let error = self.opts.antialias_error * self.opts.mu0 / self.mu(pass) * level;
        (error > 0.0 && error.is_finite()).then_some(error * error)
    }

    /// Samples pixel-light `k` needs for the variance of its mean r(x) plus the other light's
    /// to fall to `target`, from the spread seen so far (variance ~ 1/n), at most `cap`.
    fn antialias_count(&self, k: usize, target: f64, cap: f64) -> u32 {
        let (s, o) = (&self.sums[k], &self.other[k / self.lights.len().max(1)]);
        let var =
            variance_of_mean(channel_mean(s.r), s.r2, s.r_n) + variance_of_mean(channel_mean(o.sum), o.sum2, o.taken);
        let n = var * s.r_n.max(1) as f64 / target;
        if n.is_finite() {
            n.min(cap).ceil() as u32
        } else {
            cap as u32
        }
    }

    /// Samples each pixel-light should have after pass `pass`.
    fn targets(&self, pass: u32) -> Vec<Target> {
        let sparse = self.opts.sparse_samples.max(1);
        if pass <= 1 {
            let n = if pass == 0 { self.opts.preview_samples.clamp(1, sparse) } else { sparse };
            return vec![Target { n, r: n }; self.sums.len()];
        }
        let nl = self.lights.len();
        let antialias = self.antialias_target(pass);
        (0..self.sums.len())
            .into_par_iter()
            .map(|k| {
                let (pixel, l) = (k / nl, k % nl);
                let s = &self.sums[k];
                match self.mode {
                    // (Tokuyoshi's modes never build this strategy; they would sample uniformly.)
                    FilterMode::UniformFiltered | FilterMode::LobeAware | FilterMode::NormalAware => {
                        let n = sparse.saturating_mul(1u32 << (pass - 1).min(20));
                        Target { n, r: n }
                    }
                    FilterMode::Aaf | FilterMode::Adaptive => {
                        let light = &self.lights[l];
                        let mu = self.mu(pass) * light.mu_scale;
                        let cap = (self.opts.cap * mu * mu).max(sparse as f64);
                        let floor = self.floor(pass).max(antialias.map_or(0, |t| self.antialias_count(k, t, cap)));
                        let n = match self.slopes[k].get() {
                            None => floor,
                            Some((s1, s2)) => {
                                let g = PixelGeometry { s1, s2, sigma: light.sigma, d: self.d[pixel] };
                                let n = sample_count(&g, &self.opts.constants, mu, sparse as f64).min(cap);
                                (n.ceil() as u32).max(floor)
                            }
                        }
                        .max(s.n);
                        // At pixel centres r is computed once per pass anyway: every sample has it.
                        let r = if self.pixel_centers { n } else { floor.max(s.r_n).min(n) };
                        Target { n, r }
                    }
                }
            })
            .collect()
    }

    /// Traces the samples each pixel-light still needs to reach `targets`.
    fn trace(&mut self, ctx: &PassContext, targets: &[Target], record_slopes: bool) -> Result<bool, RenderError> {
        let (scene, job) = (ctx.scene, ctx.job);
        let (w, nl) = (self.width, self.lights.len());
        let lights = &self.lights;
        // Every light's pairs at the first hit (`sample`).
        let pairs_ahead = path_pairs(scene, Integrand::Radiance, 0);
        let results: Vec<Tally> = self
            .other
            .par_chunks_mut(w)
            .zip(self.sums.par_chunks_mut(w * nl.max(1)))
            .zip(targets.par_chunks(w * nl.max(1)))
            .enumerate()
            .map(|(y, ((other_row, sums_row), target_row))| {
                let (mut rays, mut dropped) = (0u64, 0u64);
                let mut camera = CameraSamples { pairs_ahead, ..CameraSamples::default() };
                for x in 0..w {
                    if ctx.stop.should_stop() {
                        return Tally { rays, dropped, complete: false };
                    }
                    let px = &mut other_row[x];
                    let sums = &mut sums_row[x * nl..(x + 1) * nl];
                    let want = &target_row[x * nl..(x + 1) * nl];
                    let new = sums.iter().zip(want).map(|(s, t)| t.n.saturating_sub(s.n)).max().unwrap_or(0);
                    // With pixel centres, the pass's samples share one camera ray and r.
                    let centre = (job.pixel_centers && new > 0).then(|| {
                        rays += 1;
                        Centre::new(scene, &job.view, lights, x, y)
                    });
                    let pixel = (y * w + x) as u32;
                    if let Some(c) = &centre {
                        // Every sample starts at the centre's hit: no jitter pair is drawn.
                        for _ in 0..new {
                            let mut sampler = PixelSampler::new(job.seed, pixel, px.taken);
                            px.taken += 1;
                            let camera = CameraRay::Centre(c);
                            let (r, d) =
                                sample_pixel(scene, lights, camera, &mut sampler, sums, want, px, record_slopes);
                            rays += r;
                            dropped += d;
                        }
                        continue;
                    }
                    // The pixel's camera rays a packet at a time, each sample then traced on.
                    let mut done = 0;
                    while done < new {
                        let m = ((new - done) as usize).min(MAX_PACKET);
                        camera.set(&job.view, job.seed, (x, y), pixel, px.taken, m, true);
                        camera.trace(scene, job.view.position);
                        for k in 0..m {
                            px.taken += 1;
                            let ray = CameraRay::Own { dir: camera.dirs[k], hit: camera.hits[k] };
                            let sampler = &mut camera.samplers[k];
                            let (r, d) = sample_pixel(scene, lights, ray, sampler, sums, want, px, record_slopes);
                            rays += r;
                            dropped += d;
                        }
                        done += m as u32;
                    }
                }
                Tally { rays, dropped, complete: true }
            })
            .collect();
        Tally::settle(&results, ctx.stop, &mut self.rays, &mut self.dropped)
    }

    /// Slopes for every pixel-light: its own from the sparse pass, or the mean of occluded
    /// pixels within `fill_radius` for pixels whose sparse rays saw no occluder (Sec. 6).
    fn fill_slopes(&mut self) {
        let Some(g) = self.gbuffer.as_ref() else { return };
        let sums = &self.sums;
        let own = |k: usize| sums[k].occ.get();
        let at = FillGrid { width: self.width, height: self.height, lights: self.lights.len() };
        self.slopes = fill_slopes(at, self.opts.fill_radius as usize, &|p| g.pixels[p].is_valid(), &own, true);
    }

    /// Builds the frame of pass `pass`: filters each light's visibility and composes. Also
    /// returns the seconds spent on the method's own work (filter widths and filtering), the
    /// part of the frame a plain Monte Carlo render does not do.
    fn compose(&self, pass: u32) -> (Frame, f64) {
        let mut method_seconds = 0.0;
        let (w, nl) = (self.width, self.lights.len());
        let n = w * self.height;
        let filters = self.mode != FilterMode::Adaptive;
        let mut width_px = vec![0.0f32; n];
        let g = self.gbuffer.as_ref();
        // Each light's filtered visibility (Eqs. 10-12); None where the method does not filter.
        let filtered: Vec<Option<Vec<[f64; 3]>>> = self
            .lights
            .iter()
            .enumerate()
            .map(|(l, light)| {
                let surface = self.surfaces.get(l)?;
                let at = |p: usize| &self.sums[p * nl + l];
                let mut vis: Vec<[f64; 3]> = (0..n).into_par_iter().map(|p| ratio(at(p).a, at(p).b)).collect();
                let t = Instant::now();
                let mu = self.mu(pass) * light.mu_scale;
                let kernel = |p: usize| {
                    let valid = g.is_some_and(|g| g.pixels[p].is_valid()) && at(p).b.iter().any(|&b| b > 0.0);
                    let beta = match (self.mode, self.slopes.get(p * nl + l).and_then(|s| s.get())) {
                        _ if !valid => 0.0,
                        (FilterMode::UniformFiltered, _) => self.opts.fixed_filter_px * self.d[p],
                        (_, Some((s1, s2))) => filter_width(
                            &PixelGeometry { s1, s2, sigma: light.sigma, d: self.d[p] },
                            &self.opts.constants,
                            mu,
                        ),
                        (_, None) => 0.0,
                    };
                    FilterKernel { valid, beta, d: self.d[p] }
                };
                surface.filter_by(kernel, &mut vis);
                width_px.par_iter_mut().enumerate().for_each(|(p, width_px)| {
                    let k = kernel(p);
                    if k.beta > 0.0 && k.d > 0.0 {
                        *width_px = width_px.max((k.beta / k.d) as f32);
                    }
                });
                method_seconds += t.elapsed().as_secs_f64();
                Some(vis)
            })
            .collect();
        // Compose r(x) times each light's visibility (filtered and raw) with the rest of the
        // light, straight into the frame's f32 images: one pass, no f64 image copies.
        let (color, unfiltered): (Vec<[f32; 3]>, Vec<[f32; 3]>) = (0..n)
            .into_par_iter()
            .map(|p| {
                let other = mean(self.other[p].sum, self.other[p].taken);
                let (mut color, mut unfiltered) = (other, other);
                for (l, vis) in filtered.iter().enumerate() {
                    let s = &self.sums[p * nl + l];
                    let (r, spec, raw) = (mean(s.r, s.r_n), mean(s.spec, s.n), ratio(s.a, s.b));
                    let vis = vis.as_ref().map_or(raw, |v| v[p]);
                    for c in 0..3 {
                        color[c] += r[c] * vis[c] + spec[c];
                        unfiltered[c] += r[c] * raw[c] + spec[c];
                    }
                }
                (color.map(|x| x as f32), unfiltered.map(|x| x as f32))
            })
            .unzip();
        // Samples per pixel: the shadow component's (all lights' together) and the pixel's.
        let (shadow_spp, spp): (Vec<f32>, Vec<f32>) = (0..n)
            .into_par_iter()
            .map(|p| {
                let shadow: u32 = (0..nl).map(|l| self.sums[p * nl + l].n).sum();
                (shadow as f32, shadow.max(self.other[p].taken) as f32)
            })
            .unzip();
        let frame = Frame {
            shading: None,
            width: self.width as u32,
            height: self.height as u32,
            color,
            unfiltered: filters.then_some(unfiltered),
            aovs: None,
            stats: FrameStats {
                mean_spp: spp.iter().map(|&s| s as f64).sum::<f64>() / n.max(1) as f64,
                rays_traced: self.rays,
                dropped_samples: self.dropped,
                method_seconds: self.method_seconds,
                ..FrameStats::default()
            },
            components: vec![ComponentMaps {
                name: "shadow".to_string(),
                spp: shadow_spp,
                filter_width: filters.then(|| width_px.clone()),
            }],
            spp,
            filter_width: filters.then_some(width_px),
        };
        (frame, method_seconds)
    }
}

impl ShadowStrategy {
    /// The mean of the frame's spp map (`frame`): per pixel, the shadow component's samples or
    /// the pixel's, whichever is more.
    fn mean_spp(&self) -> f64 {
        let nl = self.lights.len();
        let spp = |p: usize| {
            let shadow: u32 = (0..nl).map(|l| self.sums[p * nl + l].n).sum();
            shadow.max(self.other[p].taken) as f32 as f64
        };
        (0..self.other.len()).map(spp).sum::<f64>() / self.other.len().max(1) as f64
    }
}

impl Strategy for ShadowStrategy {
    fn sample(&mut self, ctx: &PassContext) -> Result<Sampled, RenderError> {
        if ctx.pass == 0 {
            self.setup(ctx);
        }
        let t = Instant::now();
        let targets = self.targets(ctx.pass);
        self.method_seconds += t.elapsed().as_secs_f64();
        // The sparse samples (the preview's and pass 1's) record slopes; the fixed-width
        // baseline uses none: it skips their extra closest-hit queries.
        let slopes = ctx.pass <= 1 && self.mode != FilterMode::UniformFiltered;
        let complete = self.trace(ctx, &targets, slopes)?;
        let t = Instant::now();
        if slopes {
            self.fill_slopes();
        }
        self.method_seconds += t.elapsed().as_secs_f64();
        Ok(Sampled { complete, mean_spp: self.mean_spp(), rays_traced: self.rays, dropped_samples: self.dropped })
    }

    fn frame(&mut self, ctx: &PassContext) -> Result<Frame, RenderError> {
        let (mut frame, filtering) = self.compose(ctx.pass);
        self.method_seconds += filtering;
        frame.stats.method_seconds = self.method_seconds;
        Ok(frame)
    }
}

/// The pixel-light grid `fill_slopes` works on: `lights` entries per pixel, pixel-major.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FillGrid {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) lights: usize,
}

/// Slopes for every pixel-light `k = pixel * lights + l` of valid pixels (Sec. 6): with
/// `prefer_own`, a pixel-light's own slopes (`own(k)`, Some where its rays saw an occluder),
/// else the mean over the pixels within `radius` whose own rays saw one of light l, itself
/// included (`auto` uses that mean everywhere, so that a pixel's width does not follow its own
/// few samples). The disc sums come from per-row prefix sums, one span per row of the disc.
/// Bands of rows run in parallel, each with the prefix sums of its own rows and the `radius`
/// rows around them: a band's prefix sums stay in cache, and no image-sized buffer is
/// allocated besides the result (fresh pages cost more than this pass's arithmetic).
pub(crate) fn fill_slopes(
    grid: FillGrid,
    radius: usize,
    valid: &(dyn Fn(usize) -> bool + Sync),
    own: &(dyn Fn(usize) -> Option<(f64, f64)> + Sync),
    prefer_own: bool,
) -> Vec<Slopes> {
    const BAND: usize = 32;
    let FillGrid { width: w, height: h, lights: nl } = grid;
    let mut slopes = filled(w * h * nl, Slopes::NONE);
    if w == 0 || nl == 0 {
        return slopes;
    }
    let r = radius;
    let half_widths: Vec<usize> = (0..=r).map(|dy| ((r * r - dy * dy) as f64).sqrt().floor() as usize).collect();
    slopes.par_chunks_mut(BAND * w * nl).enumerate().for_each_init(Vec::new, |prefix, (band, out)| {
        let (y0, y1) = (band * BAND, (band * BAND + BAND).min(h));
        let p0 = y0.saturating_sub(r);
        // prefix[((y - p0) * nl + l) * (w + 1) + x] = (count, sum s1, sum s2) of the
        // pixels of row y left of x whose own rays saw an occluder of light l.
        prefix.clear();
        prefix.resize(((y1 + r).min(h) - p0) * nl * (w + 1), [0.0f64; 3]);
        for (i, row) in prefix.chunks_mut(w + 1).enumerate() {
            let (y, l) = (p0 + i / nl, i % nl);
            for x in 0..w {
                let [c, a, b] = row[x];
                row[x + 1] = match own((y * w + x) * nl + l) {
                    Some((s1, s2)) => [c + 1.0, a + s1.min(MAX_SLOPE), b + s2.min(MAX_SLOPE)],
                    None => [c, a, b],
                };
            }
        }
        let span = |y: usize, l: usize| &prefix[((y - p0) * nl + l) * (w + 1)..][..w + 1];
        for (i, out) in out.iter_mut().enumerate() {
            let (y, x, l) = (y0 + i / (w * nl), (i / nl) % w, i % nl);
            if !valid(y * w + x) {
                continue;
            }
            if prefer_own {
                if let Some((s1, s2)) = own((y * w + x) * nl + l) {
                    *out = Slopes::new(s1.min(MAX_SLOPE), s2.min(MAX_SLOPE));
                    continue;
                }
            }
            let [mut count, mut s1, mut s2] = [0.0; 3];
            for ny in y.saturating_sub(r)..(y + r + 1).min(h) {
                let (row, hw) = (span(ny, l), half_widths[ny.abs_diff(y)]);
                let (lo, hi) = (x.saturating_sub(hw), (x + hw + 1).min(w));
                count += row[hi][0] - row[lo][0];
                s1 += row[hi][1] - row[lo][1];
                s2 += row[hi][2] - row[lo][2];
            }
            if count > 0.5 {
                *out = Slopes::new(s1 / count, s2 / count);
            }
        }
    });
    slopes
}

/// The filter's surface for `light`: each hit point in the light plane's coordinates, so that
/// offsets along the light normal do not count (Eq. 12).
fn light_plane_surface(g: &GBuffer, light: &ShadowLight, width: usize, o: &FilterOptions) -> FilterSurface {
    FilterSurface::new(g.pixels.len(), width, o, |p| {
        let s = &g.pixels[p];
        let pos = s.position - light.corner;
        (DVec3::new(pos.dot(light.axis_u) as f64, pos.dot(light.axis_v) as f64, 0.0), s.normal, s.object)
    })
}

pub(crate) fn shadow_light(index: usize, r: &RectLight, opts: &AafOptions) -> ShadowLight {
    let axis_u = r.edge_u.normalize_or_zero();
    ShadowLight {
        index,
        corner: r.corner,
        axis_u,
        axis_v: r.normal.cross(axis_u).normalize_or_zero(),
        // Uniform lights keep the paper's treatment (Sec. 7): sigma = sqrt(area)/2 and a
        // larger mu.
        sigma: match (r.profile, opts.light_sigma) {
            (EmissionProfile::Gaussian, LightSigma::Emitted) => r.emission_std(),
            _ => r.sigma(),
        } as f64,
        mu_scale: match r.profile {
            EmissionProfile::Gaussian => 1.0,
            EmissionProfile::Uniform => opts.uniform_light_mu_scale,
        },
    }
}

fn channel_mean(v: [f64; 3]) -> f64 {
    (v[0] + v[1] + v[2]) / 3.0
}

/// Unbiased sample variance of a mean of `n` values from their sum and sum of squares.
fn variance_of_mean(sum: f64, sum2: f64, n: u32) -> f64 {
    if n < 2 {
        return 0.0;
    }
    let n = n as f64;
    ((sum2 - sum * sum / n) / (n - 1.0)).max(0.0) / n
}

/// A / B per channel. Where no light sample carried any light (B = 0) there is no evidence of
/// occlusion, and the visibility is taken as 1: r alone decides (it is 0 where the pixel
/// cannot see the light at all).
pub(crate) fn ratio(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| if b[c] > 0.0 { a[c] / b[c] } else { 1.0 })
}

/// The unshadowed diffuse light r of `rect` at `hit` seen from `wo` (exact, Eq. 1's r(x)).
pub(crate) fn unshadowed(rect: &RectLight, hit: &Surface, wo: Vec3, kd: Vec3) -> DVec3 {
    // kd/pi where the BRDF is defined: like `Brdf::eval`, nothing where the shading normal
    // faces away from the viewer (silhouettes of smooth-shaded meshes).
    let diffuse = if hit.ns.dot(wo) > 0.0 { kd * (1.0 / std::f32::consts::PI) } else { Vec3::ZERO };
    diffuse.as_dvec3() * rect.radiance.as_dvec3() * rect.unshadowed_irradiance(hit.p, hit.ns, hit.ng)
}

/// A pixel's centre ray and, where it hits, each light's r there: shared by all the samples
/// of a pass when shading pixel centres.
struct Centre {
    dir: Vec3,
    hit: Option<Surface>,
    r: Vec<DVec3>,
}

impl Centre {
    fn new(scene: &Scene, cam: &Camera, lights: &[ShadowLight], x: usize, y: usize) -> Centre {
        let dir = cam.direction(x as f32 + 0.5, y as f32 + 0.5);
        let hit = scene.intersect(cam.position, dir, 0.0);
        let r = lights
            .iter()
            .map(|l| match (&scene.lights[l.index], &hit) {
                (Light::Rect(rect), Some(h)) => {
                    unshadowed(rect, h, -dir, scene.materials[h.material as usize].brdf(h.uv).kd)
                }
                _ => DVec3::ZERO,
            })
            .collect();
        Centre { dir, hit, r }
    }
}

/// A sample's camera ray: its pixel's shared centre ray when shading pixel centres, else its
/// own jittered ray, traced with the pixel's others (`CameraSamples`).
#[derive(Clone, Copy)]
enum CameraRay<'a> {
    Centre(&'a Centre),
    Own { dir: Vec3, hit: Option<Surface> },
}

/// One camera sample of one pixel: the rect lights that still need samples get one each; the
/// rest of the light (emission, point lights, the environment) goes to `other`. Returns (rays, dropped).
#[allow(clippy::too_many_arguments)]
fn sample_pixel(
    scene: &Scene,
    lights: &[ShadowLight],
    camera: CameraRay,
    sampler: &mut PixelSampler,
    sums: &mut [LightSums],
    want: &[Target],
    other: &mut OtherSums,
    record_slopes: bool,
) -> (u64, u64) {
    let (dir, hit, mut rays, centre) = match camera {
        CameraRay::Centre(c) => (c.dir, c.hit, 0u64, Some(c)),
        CameraRay::Own { dir, hit } => (dir, hit, 1u64, None),
    };
    let Some(hit) = hit else {
        for (s, t) in sums.iter_mut().zip(want) {
            if s.n < t.n {
                s.n += 1;
                s.r_n += u32::from(s.r_n < t.r);
            }
        }
        // The background is the rest of what a ray that leaves the scene sees.
        let background = scene.background(dir);
        for c in 0..3 {
            other.sum[c] += background[c] as f64;
        }
        other.sum2 += channel_mean(background.as_dvec3().to_array()).powi(2);
        return (rays, 0);
    };
    let wo = -dir;
    let brdf = scene.materials[hit.material as usize].brdf(hit.uv);
    let emitter = matches!(scene.materials[hit.material as usize], Material::Emitter { .. });
    for (l, light) in lights.iter().enumerate() {
        // Every light's dimensions are drawn whether used or not, so sample streams stay
        // aligned (a missed camera ray draws none, but then nothing else is drawn either).
        let light_u = sampler.next_2d();
        // The glossy part's second strategy, a direction from the lobe (`mis`).
        let lobe_u = scene.glossy.then(|| sampler.next_2d());
        let s = &mut sums[l];
        if s.n >= want[l].n {
            continue;
        }
        s.n += 1;
        // The first samples (a stratified prefix) carry r, black or not.
        let with_r = s.r_n < want[l].r;
        s.r_n += u32::from(with_r);
        let Light::Rect(rect) = &scene.lights[light.index] else { continue };
        if emitter || brdf.is_black() {
            continue;
        }
        if with_r {
            let r = centre.map_or_else(|| unshadowed(rect, &hit, wo, brdf.kd), |c| c.r[l]);
            if r.is_finite() {
                for c in 0..3 {
                    s.r[c] += r[c];
                }
                s.r2 += channel_mean(r.to_array()).powi(2);
            }
        }
        if let Some(ul) = lobe_u {
            let (g, r) = shadowed_lobe_term(scene, &hit, wo, &brdf, rect, ul, 1);
            rays += r as u64;
            for c in 0..3 {
                s.spec[c] += g[c] as f64;
            }
        }
        let Some(ls) = rect.sample(hit.p, light_u) else { continue };
        let Some((u, g)) = light_terms(&brdf, &hit, wo, &ls, lobe_u.is_some(), 1) else { continue };
        rays += 1;
        let visible = s.occ.visible(scene, &hit, ls.point, record_slopes);
        for c in 0..3 {
            s.b[c] += u[c] as f64;
            if visible {
                s.a[c] += u[c] as f64;
                s.spec[c] += g[c] as f64;
            }
        }
    }
    // Indirect light is the indirect strategy's part (see `strategy::make_strategy`). With
    // rect lights only, what is left is emission: no point-light samples to draw.
    let r = if lights.len() == scene.lights.len() {
        PathResult { radiance: emitted(scene, &hit, wo), rays: 0 }
    } else {
        radiance_from(scene, hit, wo, 0, sampler, DirectLights::SkipRect)
    };
    rays += r.rays as u64;
    if r.radiance.is_finite() {
        for c in 0..3 {
            other.sum[c] += r.radiance[c] as f64;
        }
        other.sum2 += channel_mean(r.radiance.as_dvec3().to_array()).powi(2);
        (rays, 0)
    } else {
        (rays, 1)
    }
}

/// The extreme slopes of a pixel-light's occluded sparse shadow rays (s1 the largest, s2 the
/// smallest: the occluders nearest the light and nearest the receiver, methods.md §1.1), and
/// whether any of them was occluded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct OccluderRange {
    s1: f64,
    s2: f64,
    occluded: bool,
}

impl OccluderRange {
    pub(crate) const NONE: OccluderRange = OccluderRange { s1: 0.0, s2: f64::INFINITY, occluded: false };

    /// Whether light point `y` is visible from `hit`. With `record` (a sparse sample), one
    /// traversal finds both ends of the occluded range and an occluded ray widens the slopes;
    /// otherwise an any-hit query answers.
    pub(crate) fn visible(&mut self, scene: &Scene, hit: &Surface, y: Vec3, record: bool) -> bool {
        if !record {
            return !scene.occluded(hit, y);
        }
        match occluder_slopes(scene, hit, y).0 {
            Some((s1, s2)) => {
                self.occluded = true;
                self.s1 = self.s1.max(s1);
                self.s2 = self.s2.min(s2);
                false
            }
            None => true,
        }
    }

    /// (s1, s2) if any recorded ray was occluded.
    pub(crate) fn get(&self) -> Option<(f64, f64)> {
        self.occluded.then_some((self.s1, self.s2))
    }
}

/// For a shadow ray from surface point `p` to light point `y`: None when unoccluded, else the
/// slopes (s1 from the occluder hit farthest from the receiver, s2 from the nearest) of this
/// ray, using the per-ray form s = t/(L - t) (methods.md §1.1). One traversal collects both
/// ends of the occluded range, as the authors' any-hit shader did. Also returns the extra rays
/// traced.
pub(crate) fn occluder_slopes(scene: &Scene, hit: &Surface, y: Vec3) -> (Option<(f64, f64)>, u64) {
    let Some((o, dir, tmax)) = hit.ray_to(y) else { return (None, 0) };
    let l = (y - o).length();
    let Some((near_t, far_t)) = scene.geometry.hit_range(o, dir, 0.0, tmax) else { return (None, 0) };
    let (l, near_t, far_t) = (l as f64, near_t as f64, far_t as f64);
    (Some((slope(far_t, l), slope(near_t, l))), 0)
}

#[cfg(test)]
mod tests;
