//! One camera sample of the `bandwidth` method, and the shading of its first hit.
//!
//! The method predicts the bandwidth of the unshadowed environment light `S` (what the paper
//! shades); wedge's images also hold shadows, other lights and bounces. Each camera sample
//! therefore splits the path tracer's own estimate (`uniform`'s sample) into `rest` (emission,
//! other lights, bounces) and `shadowed`, its environment light from two directions (one
//! light-, one BRDF-sampled, weighted by MIS), and adds `unshadowed`, the same two terms
//! without visibility. `shading` combines the pixel's sums of these with the shaded `S_hat`
//! (`options::Visibility`): where the sky is in view `shadowed` equals `unshadowed`, so only
//! the shadows, the bounces and the other lights are sampled per pixel at full resolution, as
//! the paper leaves them.
use crate::render::environment::EnvironmentLight;
use crate::render::integrator::{environment_terms, environment_terms_many, radiance_from, DirectLights};
use crate::render::material::Brdf;
use crate::render::sampler::PixelSampler;
use crate::render::scene::{Scene, Surface};
use glam::Vec3;

/// What one camera sample found.
#[derive(Clone, Copy, Debug)]
pub struct SampleTerms {
    /// Emission, the direct light of the other lights with their shadows, and the bounces (the
    /// sky itself where the ray escapes).
    pub rest: Vec3,
    /// The environment's direct light with its shadows; `rest + shadowed` is the full estimate.
    pub shadowed: Vec3,
    /// The same two environment terms without their shadows (0 where nothing is hit).
    pub unshadowed: Vec3,
    /// Rays traced after the camera ray.
    pub rays: u32,
}

/// The terms of a camera ray towards `-wo` that found `hit` (None: it escaped), with `bounces`
/// indirect bounces. The environment's numbers are drawn first, then the path's.
pub fn sample_terms(
    scene: &Scene,
    env: &EnvironmentLight,
    hit: Option<&Surface>,
    wo: Vec3,
    bounces: u32,
    sampler: &mut PixelSampler,
) -> SampleTerms {
    let Some(s) = hit else {
        return SampleTerms { rest: scene.background(-wo), shadowed: Vec3::ZERO, unshadowed: Vec3::ZERO, rays: 0 };
    };
    let (u_light, u_lobe, u_brdf) = (sampler.next_2d(), sampler.next_1d(), sampler.next_2d());
    let path = radiance_from(scene, *s, wo, bounces, sampler, DirectLights::SkipEnvironment);
    let brdf = scene.materials[s.material as usize].brdf(s.uv);
    let (mut shadowed, mut unshadowed, mut rays) = (Vec3::ZERO, Vec3::ZERO, path.rays);
    if !brdf.is_black() {
        for (value, wi) in environment_terms(s, wo, &brdf, env, u_light, u_lobe, u_brdf).into_iter().flatten() {
            unshadowed += value;
            rays += 1;
            if scene.escapes(s, wi) {
                shadowed += value;
            }
        }
    }
    SampleTerms { rest: path.radiance, shadowed, unshadowed, rays }
}

/// Lookups a shaded sample may take at most (its streams' indices are spaced by this).
pub const MAX_LOOKUPS: u32 = 1024;

/// Where a shaded sample's lookups draw their numbers: the stream of `seed`, for camera sample
/// `index` of `pixel` (each lookup its own sample index below it).
#[derive(Clone, Copy, Debug)]
pub struct LookupStream {
    pub seed: u64,
    pub pixel: u32,
    pub index: u32,
}

/// `S` at `s` towards `wo` from `lookups` pairs of a light- and a BRDF-sampled direction (no
/// rays: the light is unshadowed), their numbers from `stream`: an unbiased estimate whose
/// variance falls as 1 / lookups. The lookups go four at a time (`environment_terms_many`), so
/// that their reads of a large map overlap; the terms and their sum are those of one lookup at
/// a time.
pub fn shade(scene: &Scene, env: &EnvironmentLight, s: &Surface, wo: Vec3, lookups: u32, stream: LookupStream) -> Vec3 {
    let brdf = scene.materials[s.material as usize].brdf(s.uv);
    if brdf.is_black() {
        return Vec3::ZERO;
    }
    let lookups = lookups.clamp(1, MAX_LOOKUPS);
    let mut sum = Vec3::ZERO;
    let mut j = 0;
    while j < lookups {
        let n = (lookups - j).min(4);
        match n {
            4 => add_lookups::<4>(&mut sum, s, wo, &brdf, env, stream, j),
            3 => add_lookups::<3>(&mut sum, s, wo, &brdf, env, stream, j),
            2 => add_lookups::<2>(&mut sum, s, wo, &brdf, env, stream, j),
            _ => add_lookups::<1>(&mut sum, s, wo, &brdf, env, stream, j),
        }
        j += n;
    }
    sum / lookups as f32
}

/// Adds the terms of lookups `first .. first + N` of `stream` to `sum`, one at a time in order
/// (the same sum as one lookup at a time gives).
#[inline]
fn add_lookups<const N: usize>(
    sum: &mut Vec3,
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    env: &EnvironmentLight,
    stream: LookupStream,
    first: u32,
) {
    let (mut u_light, mut u_lobe, mut u_brdf) = ([[0.0; 2]; N], [0.0; N], [[0.0; 2]; N]);
    for i in 0..N {
        let index = stream.index.wrapping_mul(MAX_LOOKUPS).wrapping_add(first + i as u32);
        let mut sampler = PixelSampler::new(stream.seed, stream.pixel, index);
        (u_light[i], u_lobe[i], u_brdf[i]) = (sampler.next_2d(), sampler.next_1d(), sampler.next_2d());
    }
    for terms in environment_terms_many(s, wo, brdf, env, &u_light, &u_lobe, &u_brdf) {
        for (value, _) in terms.into_iter().flatten() {
            *sum += value;
        }
    }
}
