//! One camera sample of `auto`: one jittered camera path, split at its first hit into the parts
//! the frame filters apart (methods.md §5.1).
use crate::methods::aaf_indirect::{incident, ComponentSums};
use crate::methods::aaf_shadows::{unshadowed, OccluderRange};
use crate::pipeline::job::RenderJob;
use crate::render::frame_basis::{cosine_hemisphere, to_world};
use crate::render::integrator::{emitted, light_radiance, LightDims};
use crate::render::light::Light;
use crate::render::material::Material;
use crate::render::mis::{light_terms, shadowed_lobe_term};
use crate::render::sampler::PixelSampler;
use crate::render::scene::{Scene, Surface};
use glam::Vec3;

/// A pixel's running sums of everything but the rectangular lights' diffuse direct light and
/// the indirect light (`IndirectSums`).
#[derive(Clone, Copy, Debug)]
pub(super) struct PixelSums {
    /// Camera samples drawn: every part's divisor and the next sample index.
    pub taken: u32,
    /// Light no filter touches: emission, point lights, the glossy part of rect lights.
    pub rest: [f64; 3],
    /// What the first camera sample saw (object and shading normal; None: nothing), and whether
    /// a later one of the first `r_block` saw something else: the pixel straddles an edge.
    pub first_seen: Option<(u32, Vec3)>,
    pub mixed: bool,
    /// Sum of the shading normals the first `r_block` camera samples saw.
    pub seen_normals: Vec3,
    /// Sums of each sample's plain Monte Carlo value x (everything it adds, the rect lights'
    /// diffuse light as u V) and of x^2, over `x_n` finite samples: the unfiltered pixel's
    /// variance, an upper estimate of it (`blend.rs`).
    pub x: [f64; 3],
    pub x2: [f64; 3],
    pub x_n: u32,
    /// Sums of y and y^2 over the `y_n` samples that computed r(x) (`r_due`), y the channel
    /// mean of a sample's direct light as `auto` estimates it: r(x) times the sample's own
    /// visibility per rectangular light, plus the rest. Its variance is what `auto`'s direct
    /// light keeps of one sample's noise before the filter: visibility and the pixel's
    /// footprint, not the light sample's place on the light (`counts.rs`).
    pub y: f64,
    pub y2: f64,
    pub y_n: u32,
}

impl Default for PixelSums {
    fn default() -> Self {
        PixelSums {
            taken: 0,
            rest: [0.0; 3],
            first_seen: None,
            mixed: false,
            seen_normals: Vec3::ZERO,
            x: [0.0; 3],
            x2: [0.0; 3],
            x_n: 0,
            y: 0.0,
            y2: 0.0,
            y_n: 0,
        }
    }
}

/// A pixel's sums of the indirect light, in renders with bounces alone (a direct-light render
/// keeps none: they are over half of a pixel's sums, and a fresh page of memory costs a fault).
#[derive(Clone, Copy, Debug)]
pub(super) struct IndirectSums {
    /// Indirect light under the cosine lobe (D) and under the glossy lobe (S), untextured.
    pub diffuse: ComponentSums,
    pub glossy: ComponentSums,
    /// Nearest and farthest reflector hit by the analysis samples' bounce rays.
    pub z_min: f32,
    pub z_max: f32,
}

impl IndirectSums {
    /// The sums of the glossy or of the diffuse component.
    pub fn component(&self, glossy: bool) -> &ComponentSums {
        if glossy {
            &self.glossy
        } else {
            &self.diffuse
        }
    }
}

impl Default for IndirectSums {
    fn default() -> Self {
        IndirectSums {
            diffuse: ComponentSums::default(),
            glossy: ComponentSums::default(),
            z_min: f32::INFINITY,
            z_max: 0.0,
        }
    }
}

/// A pixel's sums for one rectangular light: the soft-shadow paper's Eq. 1 split
/// h = r(x) * visibility, with r exact and the visibility A / B (`aaf_shadows`).
#[derive(Clone, Copy, Debug)]
pub(super) struct LightSums {
    /// Sums of u V and of u, u the diffuse integrand of the light sample.
    pub a: [f64; 3],
    pub b: [f64; 3],
    /// Sum of the exact unshadowed diffuse light r over the `r_n` samples that computed it.
    pub r: [f64; 3],
    pub r_n: u32,
    /// Extreme slopes of the analysis samples' occluded shadow rays.
    pub occ: OccluderRange,
    /// Whether the light's visibility filter at this pixel is narrow
    /// (`AutoStrategy::mark_narrow_penumbrae`).
    pub narrow: bool,
}

impl LightSums {
    /// Whether the pixel's samples so far found the light both blocked and unblocked, and its
    /// filter is too narrow to average that noise away.
    fn narrow_penumbra(&self) -> bool {
        let (a, b) = (self.a[0] + self.a[1] + self.a[2], self.b[0] + self.b[1] + self.b[2]);
        self.narrow && a > 0.0 && a < b
    }
}

/// Light sample `ray` of `k` drawn at one camera sample: the sample's point `u` shifted by a
/// rank-1 lattice (j / k, frac(j phi^-1)) modulo 1 (a Cranley-Patterson rotation), so that
/// the k points spread over the light, each uniform in [0, 1)^2 as the estimate needs; ray 0
/// is `u` itself.
pub(super) fn lattice_shift(u: [f32; 2], ray: u32, k: u32) -> [f32; 2] {
    if ray == 0 {
        return u;
    }
    const INVERSE_GOLDEN: f32 = 0.618_034;
    let frac = |x: f32| x - x.floor();
    let shift = [ray as f32 / k as f32, frac(ray as f32 * INVERSE_GOLDEN)];
    [frac(u[0] + shift[0]), frac(u[1] + shift[1])]
}

impl PixelSums {
    fn add_x(&mut self, x: Vec3) {
        if x.is_finite() {
            self.x_n += 1;
            for c in 0..3 {
                self.x[c] += x[c] as f64;
                self.x2[c] += (x[c] * x[c]) as f64;
            }
        }
    }

    /// The variance of the mean of the samples' plain values, summed over the channels.
    pub(super) fn mean_variance(&self) -> f64 {
        if self.x_n < 2 {
            return f64::INFINITY;
        }
        let n = self.x_n as f64;
        (0..3).map(|c| (self.x2[c] / n - (self.x[c] / n).powi(2)).max(0.0) / (n - 1.0)).sum()
    }

    fn add_y(&mut self, y: Vec3) {
        let y = ((y.x + y.y + y.z) / 3.0) as f64;
        if y.is_finite() {
            self.y_n += 1;
            self.y += y;
            self.y2 += y * y;
        }
    }

    /// The variance of one sample's y (`PixelSums::y`); None below two samples.
    pub(super) fn direct_variance(&self) -> Option<f64> {
        if self.y_n < 2 {
            return None;
        }
        let n = self.y_n as f64;
        Some((self.y2 / n - (self.y / n).powi(2)).max(0.0) * n / (n - 1.0))
    }

    /// Notes what camera sample `index` saw (None: nothing, or a light), while `index` is among
    /// the first `r_block`.
    pub(super) fn note_seen(&mut self, index: u32, r_block: u32, seen: Option<(u32, Vec3)>) {
        if index >= r_block {
            return;
        }
        if let Some((_, n)) = seen {
            self.seen_normals += n;
        }
        if self.mixed {
            return;
        }
        if index == 0 {
            self.first_seen = seen;
            return;
        }
        self.mixed = match (self.first_seen, seen) {
            (Some((o0, n0)), Some((o, n))) => o != o0 || n.dot(n0) < EDGE_COS,
            (None, None) => false,
            _ => true,
        };
    }
}

/// Two shading normals further apart than this (about 25 degrees) within a pixel make it an edge.
const EDGE_COS: f32 = 0.9;

impl Default for LightSums {
    fn default() -> Self {
        LightSums { a: [0.0; 3], b: [0.0; 3], r: [0.0; 3], r_n: 0, occ: OccluderRange::NONE, narrow: true }
    }
}

/// What every sample of a render shares.
pub(super) struct Sampling<'a> {
    pub scene: &'a Scene,
    pub job: &'a RenderJob,
    /// Per scene light, its index among the rectangular lights' sums (None: a point light).
    pub slot: &'a [Option<usize>],
    /// Samples with a lower index feed the analysis (slopes, reflector distances).
    pub analysis_spp: u32,
    /// See `r_due`.
    pub r_block: u32,
    /// Light samples per camera sample in a penumbra (`AutoOptions::penumbra_rays`).
    pub penumbra_rays: u32,
}

impl Sampling<'_> {
    /// Adds sample `px.taken` of pixel (x, y) into the sums (`indirect`: the pixel's indirect
    /// sums, given exactly when the render has bounces), from its camera ray: the sampler after
    /// the jitter pair, the ray's direction and its hit (`CameraSamples`). Returns (rays,
    /// dropped), the camera ray counted.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &self,
        px: &mut PixelSums,
        lights: &mut [LightSums],
        indirect: Option<&mut IndirectSums>,
        mut sampler: PixelSampler,
        dir: Vec3,
        hit: Option<Surface>,
    ) -> (u64, u64) {
        let (scene, job) = (self.scene, self.job);
        let index = px.taken;
        px.taken += 1;
        debug_assert_eq!(indirect.is_some(), job.bounces > 0, "indirect sums exactly with bounces");
        let r_due = self.r_due(index, px.mixed);
        let Some(hit) = hit else {
            px.note_seen(index, self.r_block, None);
            // r's mean counts the samples that see nothing (or a light, or a black surface)
            // as zeros: the pixel's share of the surface the light falls on.
            for (light, slot) in scene.lights.iter().zip(self.slot) {
                if let (Light::Rect(_), Some(l)) = (light, slot) {
                    lights[*l].r_n += u32::from(r_due);
                }
            }
            if let Some(ind) = indirect {
                ind.diffuse.add(Vec3::ZERO, None);
                ind.glossy.add(Vec3::ZERO, None);
            }
            let background = scene.background(dir);
            for c in 0..3 {
                px.rest[c] += background[c] as f64;
            }
            px.add_x(background);
            if r_due {
                px.add_y(background);
            }
            return (1, 0);
        };
        let analysis = index < self.analysis_spp;
        let wo = -dir;
        let brdf = scene.materials[hit.material as usize].brdf(hit.uv);
        let emitter = matches!(scene.materials[hit.material as usize], Material::Emitter { .. });
        px.note_seen(index, self.r_block, (!emitter).then_some((hit.object, hit.ns)));
        let front = hit.ns.dot(wo) > 0.0;
        let (mut rays, mut dropped) = (1u64, 0u64);
        let mut rest = emitted(scene, &hit, wo);
        // The rect lights' diffuse light as plain Monte Carlo gives it (for `x` alone).
        let mut diffuse_direct = Vec3::ZERO;
        // The rect lights' diffuse light as r(x) times this sample's visibility (for `y`).
        let mut shadowed_r = Vec3::ZERO;
        // Every light draws its dimensions (`LightDims`), used or not, so that the streams stay
        // aligned.
        for (light, slot) in scene.lights.iter().zip(self.slot) {
            let dims = LightDims::draw(light, scene.glossy, &mut sampler);
            let u = dims.light;
            let mut r_here = Vec3::ZERO;
            if let (Light::Rect(rect), Some(l)) = (light, slot) {
                let s = &mut lights[*l];
                if r_due {
                    s.r_n += 1;
                    let r = unshadowed(rect, &hit, wo, brdf.kd);
                    if !emitter && r.is_finite() {
                        r_here = r.as_vec3();
                        for c in 0..3 {
                            s.r[c] += r[c];
                        }
                    }
                }
            }
            if emitter || brdf.is_black() {
                continue;
            }
            match (light, slot) {
                (Light::Rect(rect), Some(l)) => {
                    let s = &mut lights[*l];
                    // In a penumbra several light samples, each weighing 1 / k, so that every
                    // camera sample still counts once in A, B and the pixel's mean.
                    let k = if s.narrow_penumbra() { self.penumbra_rays.max(1) } else { 1 };
                    let share = 1.0 / k as f32;
                    for ray in 0..k {
                        let Some(ls) = rect.sample(hit.p, lattice_shift(u, ray, k)) else { continue };
                        // The glossy part is weighed against the lobe sample below (`mis`).
                        let Some((u, g)) = light_terms(&brdf, &hit, wo, &ls, dims.lobe.is_some(), k) else { continue };
                        let (u, g) = (u * share, g * share);
                        rays += 1;
                        let visible = s.occ.visible(scene, &hit, ls.point, analysis && ray == 0);
                        for c in 0..3 {
                            s.b[c] += u[c] as f64;
                            if visible {
                                s.a[c] += u[c] as f64;
                            }
                        }
                        if visible {
                            rest += g;
                            diffuse_direct += u;
                            shadowed_r += r_here * share;
                        }
                    }
                    if let Some(ul) = dims.lobe {
                        let (g, r) = shadowed_lobe_term(scene, &hit, wo, &brdf, rect, ul, k);
                        rays += r as u64;
                        rest += g;
                    }
                }
                (Light::Rect(_), None) => {}
                (other, _) => {
                    let (l, r) = light_radiance(scene, &hit, wo, &brdf, other, &dims);
                    rest += l;
                    rays += r as u64;
                }
            }
        }
        if rest.is_finite() {
            for c in 0..3 {
                px.rest[c] += rest[c] as f64;
            }
        } else {
            dropped += 1;
        }
        if r_due {
            px.add_y(rest + shadowed_r);
        }
        let mut x = rest + diffuse_direct;
        if let Some(ind) = indirect {
            let (r, d, reflected) = self.indirect(&hit, wo, front, analysis, &mut sampler, ind);
            rays += r;
            dropped += d;
            x += reflected;
        }
        px.add_x(x);
        (rays, dropped)
    }

    /// Whether sample `index` computes r(x): every sample of the first block of `r_block`
    /// (16), then one block in four (samples 64-79, 128-143, ...). r is exact at each sample
    /// point, so more of them only refine its average over the pixel (antialiasing), and each
    /// costs as much as a shadow ray (an 8 x 8 quadrature for Gaussian lights). Whole blocks of
    /// consecutive indices keep the subset stratified (each is a net of the Sobol sequence; every
    /// fourth single sample would crowd into one quarter of the pixel), and the count still grows
    /// without bound. In a pixel whose first block saw two surfaces (`mixed`), every sample:
    /// there r's average over the pixel is its coverage of each, as noisy as the visibility's,
    /// and a quarter of the samples left it the largest error of the image's edges.
    fn r_due(&self, index: u32, mixed: bool) -> bool {
        r_due(self.r_block, index, mixed)
    }

    /// The indirect light at the first hit, diffuse and glossy apart, as `aaf_indirect` samples
    /// it: one cosine ray for kd, one lobe-sampled ray for ks. Returns (rays, dropped, the
    /// light reflected: kd and ks times their incident light).
    fn indirect(
        &self,
        hit: &Surface,
        wo: Vec3,
        front: bool,
        analysis: bool,
        sampler: &mut PixelSampler,
        px: &mut IndirectSums,
    ) -> (u64, u64, Vec3) {
        let scene = self.scene;
        let bounces = self.job.bounces;
        let (u_d, u_s) = (sampler.next_2d(), sampler.next_2d());
        let brdf = scene.materials[hit.material as usize].brdf(hit.uv);
        let (mut rays, mut dropped) = (0u64, 0u64);
        let mut keep = |v: Vec3| {
            if v.is_finite() {
                Some(v)
            } else {
                dropped += 1;
                None
            }
        };
        let mut diffuse = None;
        if brdf.kd != Vec3::ZERO && front {
            let (l, z, r) = incident(scene, bounces, hit, to_world(hit.ns, cosine_hemisphere(u_d)), sampler);
            rays += r;
            if analysis {
                record_reflector(px, z);
            }
            diffuse = keep(l);
        }
        let mut glossy = None;
        if brdf.ks != Vec3::ZERO && front {
            let l = match brdf.sample_specular(wo, hit.ns, u_s) {
                Some((wi, weight)) => {
                    let (l, z, r) = incident(scene, bounces, hit, wi, sampler);
                    rays += r;
                    if analysis && brdf.kd == Vec3::ZERO {
                        record_reflector(px, z);
                    }
                    l * weight
                }
                None => Vec3::ZERO,
            };
            glossy = keep(l);
        }
        px.diffuse.add(brdf.kd, diffuse);
        px.glossy.add(brdf.ks, glossy);
        let reflected = brdf.kd * diffuse.unwrap_or(Vec3::ZERO) + brdf.ks * glossy.unwrap_or(Vec3::ZERO);
        (rays, dropped, reflected)
    }
}

/// `Sampling::r_due` for blocks of `r_block` samples.
pub(super) fn r_due(r_block: u32, index: u32, mixed: bool) -> bool {
    let block = r_block.max(1);
    mixed || index < block || (index / block).is_multiple_of(4)
}

fn record_reflector(px: &mut IndirectSums, z: Option<f32>) {
    if let Some(t) = z {
        px.z_min = px.z_min.min(t);
        px.z_max = px.z_max.max(t);
    }
}
