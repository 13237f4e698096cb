//! How many paths a camera sample of `uniform` splits into at its first hit
//! (`integrator::radiance_split`), chosen once per render from a pilot.
//!
//! A sample is a first stage (the camera ray, the first hit's emission and direct light) and
//! k second-stage paths on from that hit, averaged. Its variance is s_b^2 + s_w^2 / k, with
//! s_b^2 the variance between samples of their expected value and s_w^2 the variance of a
//! path about it, and its cost c_1 + k c_2, so the work-normalised variance
//! (s_b^2 + s_w^2 / k)(c_1 + k c_2) is least at k = (s_w / s_b) sqrt(c_1 / c_2): the optimal
//! second-stage size of two-stage sampling (Cochran, "Sampling Techniques", 3rd ed., Ch. 10,
//! units of equal size), the splitting factor of branched path tracing. Where the indirect light is what
//! varies (a closed room's walls) a sample takes many paths; where the first hit's direct light
//! varies (soft shadows) one.
//!
//! The pilot traces a few samples of two paths each at pixels spread over the image, from
//! numbers of their own. s_w^2 is half the two paths' squared difference; s_b^2 is taken as the
//! spread of the first stage alone within each pixel. Cochran's own estimate of s_b^2 (the
//! spread of the samples' whole values less s_w^2 / 2) subtracts two noisy sums and
//! swung k from 1 to 11 between seeds on `cornell`; the first stage's spread leaves out how the
//! paths' mean moves with the first hit and gave the same k on every seed tried. Samples that see
//! the sky or a light directly are left out. The costs are the rays each stage traced. One k for
//! the whole render keeps every sample's paths a block of `k`
//! consecutive points of the pixel's split stream, so the paths of all samples form one
//! stratified set with equal weights; it depends on the seed alone, so the image is the same
//! for any thread count.

use super::job::RenderJob;
use crate::render::integrator::{radiance_split, Integrand, PathResult};
use crate::render::material::{luminance, Material};
use crate::render::sampler::PixelSampler;
use crate::render::scene::Scene;
use rayon::prelude::*;

pub use crate::methods::uniform::options::MAX_SPLITS;

/// Pixels the pilot traces at most (spread over the image).
pub const PILOT_PIXELS: usize = 1024;
/// Camera samples per pilot pixel, each with two paths.
pub const PILOT_SAMPLES: u32 = 4;

/// Mixed into the seed of the pilot's numbers, so that they are not the render's own.
const PILOT_DOMAIN: u64 = 0x7069_6c6f_7453_706c;

/// One pilot sample: its first stage's luminance and rays (the camera ray included), and its
/// two paths' luminances and rays.
#[derive(Clone, Copy, Debug)]
pub struct PilotSample {
    pub first: f32,
    pub first_rays: u32,
    pub paths: [(f32, u32); 2],
}

/// The pilot's record, summed over its pixels: the within-sample squared differences of the
/// two paths, the within-pixel sample variances of the first stage, and the rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pilot {
    /// Sum over samples of (I_1 - I_2)^2 / 2 (each an unbiased estimate of s_w^2) and their count.
    within: f64,
    samples: u32,
    /// Sum over pixels of the sample variance of the first stage D (each estimates s_b^2, as
    /// the module says) and their count.
    between: f64,
    pixels: u32,
    first_rays: u64,
    path_rays: u64,
}

impl Pilot {
    /// Adds one pixel's samples. Non-finite samples are left out.
    pub fn add_pixel(&mut self, samples: &[PilotSample]) {
        let finite: Vec<&PilotSample> =
            samples.iter().filter(|s| s.first.is_finite() && s.paths.iter().all(|(l, _)| l.is_finite())).collect();
        for s in &finite {
            let diff = s.paths[0].0 as f64 - s.paths[1].0 as f64;
            self.within += diff * diff / 2.0;
            self.samples += 1;
            self.first_rays += s.first_rays as u64;
            self.path_rays += (s.paths[0].1 + s.paths[1].1) as u64;
        }
        if finite.len() >= 2 {
            let ys: Vec<f64> = finite.iter().map(|s| s.first as f64).collect();
            let mean = ys.iter().sum::<f64>() / ys.len() as f64;
            self.between += ys.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (ys.len() - 1) as f64;
            self.pixels += 1;
        }
    }

    /// The paths per sample, 1 to `max` (at most `MAX_SPLITS`): Cochran's optimum.
    pub fn splits(&self, max: u32) -> u32 {
        let max = max.clamp(1, MAX_SPLITS as u32);
        if self.samples == 0 || self.pixels == 0 {
            return 1;
        }
        let s_w2 = self.within / self.samples as f64;
        let s_b2 = self.between / self.pixels as f64;
        // Costs per sample of each stage; a stage costs its shading even without rays.
        let c1 = (self.first_rays as f64 / self.samples as f64).max(1.0);
        let c2 = (self.path_rays as f64 / (2 * self.samples) as f64).max(1.0);
        if !(s_w2 > 0.0) {
            return 1;
        }
        if !(s_b2 > 0.0) {
            return max;
        }
        let k = (s_w2 / s_b2 * c1 / c2).sqrt();
        if k.is_finite() {
            (k.round() as u32).clamp(1, max)
        } else {
            max
        }
    }
}

/// The pixels the pilot visits: at most `PILOT_PIXELS`, on a regular grid over the image.
pub fn pilot_pixels(width: u32, height: u32) -> Vec<(u32, u32)> {
    let (w, h) = (width as usize, height as usize);
    if w == 0 || h == 0 {
        return Vec::new();
    }
    let mut stride = ((w * h) as f64 / PILOT_PIXELS as f64).sqrt().ceil().max(1.0) as usize;
    while w.div_ceil(stride) * h.div_ceil(stride) > PILOT_PIXELS {
        stride += 1;
    }
    let offset = stride / 2;
    let xs = (offset..w).step_by(stride);
    xs.flat_map(|x| (offset.min(h - 1)..h).step_by(stride).map(move |y| (x as u32, y as u32))).collect()
}

/// The paths per sample for `job`'s render: 1 where there is nothing to split (no bounce,
/// ambient occlusion, or `uniform.max_splits` 1), else the pilot's choice.
pub fn choose(scene: &Scene, job: &RenderJob) -> u32 {
    let max = job.uniform.max_splits.clamp(1, MAX_SPLITS as u32);
    if max == 1 || job.bounces == 0 || job.integrand != Integrand::Radiance {
        return 1;
    }
    let cam = &job.view;
    let seed = job.seed ^ PILOT_DOMAIN;
    let pixels = pilot_pixels(cam.width, cam.height);
    let pilots: Vec<Pilot> = pixels
        .par_iter()
        .map(|&(x, y)| {
            let pixel = y * cam.width + x;
            let key = PixelSampler::pixel_key(seed, pixel);
            let split_key = PixelSampler::split_key(key);
            let mut samples = Vec::with_capacity(PILOT_SAMPLES as usize);
            for i in 0..PILOT_SAMPLES {
                let mut sampler = PixelSampler::of_pixel(key, i);
                let j = sampler.next_2d();
                let j = if job.pixel_centers { [0.5, 0.5] } else { j };
                let dir = cam.direction(x as f32 + j[0], y as f32 + j[1]);
                // Samples that see the sky or a light directly have no paths to split, and a
                // light's edge across a pixel would make that pixel's spread between samples
                // decide k for the whole image: they are left out, as the sky is.
                let Some(hit) = scene.intersect(cam.position, dir, 0.0) else { continue };
                if matches!(scene.materials[hit.material as usize], Material::Emitter { .. }) {
                    continue;
                }
                let mut splits = [PixelSampler::new(0, 0, 0); 2];
                PixelSampler::consecutive(split_key, 2 * i, &mut splits);
                let mut paths = [PathResult::default(); 2];
                let first = radiance_split(scene, hit, -dir, job.bounces, &mut sampler, &mut splits, &mut paths);
                let path = |p: &PathResult| (luminance(p.radiance), p.rays);
                samples.push(PilotSample {
                    first: luminance(first.radiance),
                    first_rays: first.rays + 1,
                    paths: [path(&paths[0]), path(&paths[1])],
                });
            }
            let mut p = Pilot::default();
            p.add_pixel(&samples);
            p
        })
        .collect();
    let total = pilots.iter().fold(Pilot::default(), |a, p| Pilot {
        within: a.within + p.within,
        samples: a.samples + p.samples,
        between: a.between + p.between,
        pixels: a.pixels + p.pixels,
        first_rays: a.first_rays + p.first_rays,
        path_rays: a.path_rays + p.path_rays,
    });
    total.splits(max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::tests::builtin;
    use crate::pipeline::job::{Halt, Method};

    /// A pixel whose samples have first stages `d` and paths `paths`, `rays` each.
    fn pilot(pixels: &[(&[f32], &[[f32; 2]])], first_rays: u32, path_rays: u32) -> Pilot {
        let mut p = Pilot::default();
        for (d, paths) in pixels {
            let samples: Vec<_> = d
                .iter()
                .zip(*paths)
                .map(|(&d, i)| PilotSample { first: d, first_rays, paths: [(i[0], path_rays), (i[1], path_rays)] })
                .collect();
            p.add_pixel(&samples);
        }
        p
    }

    /// The count is Cochran's optimum (s_w / s_b) sqrt(c_1 / c_2), rounded and clamped; a stage
    /// without variance sends it to an end.
    #[test]
    fn the_count_is_the_two_stage_optimum() {
        // Two samples whose paths differ by 8 (s_w^2 = 64 / 2 = 32) and whose first stages are 0
        // and 2 (sample variance s_b^2 = 2): k = sqrt(32 / 2) = 4 at equal costs.
        let d: &[f32] = &[0.0, 2.0];
        let paths: &[[f32; 2]] = &[[0.0, 8.0]; 2];
        let p = pilot(&[(d, paths)], 2, 2);
        assert_eq!(p.splits(16), 4);
        // Paths four times dearer than the first stage: sqrt(16 / 4) = 2.
        assert_eq!(pilot(&[(d, paths)], 1, 4).splits(16), 2);
        // The limit caps it; a limit above MAX_SPLITS is MAX_SPLITS.
        assert_eq!(p.splits(3), 3);
        assert_eq!(pilot(&[(&[-4.0, -4.0], paths)], 1, 1).splits(1000), MAX_SPLITS as u32, "no spread between samples");
        // Paths that agree: one path.
        assert_eq!(pilot(&[(d, &[[3.0, 3.0]; 2])], 1, 1).splits(16), 1);
        // No pilot samples: one path.
        assert_eq!(Pilot::default().splits(16), 1);
        // Between-pixel differences do not count: pixels of different levels, each without
        // spread between its samples, give the most.
        assert_eq!(pilot(&[(&[1.0, 1.0], paths), (&[9.0, 9.0], paths)], 1, 1).splits(16), 16);
    }

    /// Non-finite samples are left out, and huge values still give a count in range.
    #[test]
    fn non_finite_or_huge_values_give_a_count_in_range() {
        let d: &[f32] = &[0.0, 1.0, f32::NAN, 1.0];
        let p = pilot(&[(d, &[[0.0, 2.0]; 4])], 1, 1);
        assert_eq!(p.samples, 3);
        let huge = pilot(&[(&[0.0, 1.0, 0.0, 1.0], &[[0.0, f32::MAX]; 4])], 1, 1);
        assert!((1..=16).contains(&huge.splits(16)));
    }

    /// The pilot's pixels cover the image evenly, at most `PILOT_PIXELS`, all inside.
    #[test]
    fn pilot_pixels_spread_over_the_image() {
        for (w, h) in [(1, 1), (3, 2), (320, 240), (1920, 1080), (4000, 1)] {
            let px = pilot_pixels(w, h);
            assert!(!px.is_empty() && px.len() <= PILOT_PIXELS, "{w}x{h}: {}", px.len());
            assert!(px.iter().all(|&(x, y)| x < w && y < h));
            if w * h >= 4 * PILOT_PIXELS as u32 {
                assert!(px.len() >= PILOT_PIXELS / 2, "{w}x{h}: {}", px.len());
            }
        }
    }

    fn job(scene: &str, bounces: u32) -> RenderJob {
        let mut j = RenderJob::new(builtin(scene, 160, 120), Method::Uniform, Halt::passes(1));
        j.bounces = bounces;
        j
    }

    /// The pilot splits where indirect light is the noise (the closed `cornell` box, most of
    /// whose light is indirect) and not where soft shadows are (`grids`, an open plane under
    /// a large light); nothing is split without a bounce or with splitting off. (At a few
    /// pixels it splits nothing: a pixel's camera samples then spread over much of the scene.)
    #[test]
    fn the_pilot_splits_where_indirect_light_is_the_noise() {
        let cornell = job("cornell", 1);
        let k = choose(&cornell.scene, &cornell);
        assert!(k >= 2, "cornell: {k}");
        let grids = job("grids", 1);
        assert!(choose(&grids.scene, &grids) <= 2, "grids: {}", choose(&grids.scene, &grids));
        assert_eq!(choose(&cornell.scene, &job("cornell", 0)), 1);
        let mut off = job("cornell", 1);
        off.uniform.max_splits = 1;
        assert_eq!(choose(&off.scene, &off), 1);
    }
}
